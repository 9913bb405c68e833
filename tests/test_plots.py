"""Figures: the data each one is drawn from, read back off the matplotlib Figure; the formats
chosen by suffix; matplotlib stays out of ``import acrobot_mj`` and out of pyplot."""

from __future__ import annotations

import json
import subprocess
import sys

import matplotlib
import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.physics.dynamics import HANGING
from acrobot_mj.report import plots
from acrobot_mj.report.crosscheck import COMPARED, integrator_study
from acrobot_mj.report.validation import phase_figures
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.records import plot_learning_curves


def exits(argv: list[str]) -> int:
    """The CLI's exit code (SystemExit caught)."""
    try:
        return main(argv)
    except SystemExit as stop:
        return stop.code


RUNS = np.array([[900.0, 400, 200, 90], [700, 500, 150, 80], [1000, 300, 120, 70]])


def band_edges(collection, xs) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and highest vertex of a filled band at each of ``xs``."""
    vertices = collection.get_paths()[0].vertices
    low = [vertices[np.isclose(vertices[:, 0], x), 1].min() for x in xs]
    high = [vertices[np.isclose(vertices[:, 0], x), 1].max() for x in xs]
    return np.array(low), np.array(high)


def test_curves_figure_draws_median_band_and_reference() -> None:
    figure = plots.curves_figure(
        {"a": RUNS, "b": RUNS[:2] * 2}, "Curves", [(63.0, "best known: 63 decisions")]
    )
    (ax,) = figure.axes
    assert ax.get_title() == "Curves" and ax.get_xlabel() == "episode"
    assert ax.get_ylabel() == "decisions per episode (log scale)" and ax.get_yscale() == "log"
    reference, a, b = ax.get_lines()
    assert list(reference.get_ydata()) == [63.0, 63.0]
    assert reference.get_label() == "best known: 63 decisions"
    assert a.get_label() == "a: median of 3 seeds, 25-75 % band"
    assert b.get_label() == "b: median of 2 seeds, 25-75 % band"
    np.testing.assert_array_equal(a.get_xdata(), [1, 2, 3, 4])
    np.testing.assert_array_equal(a.get_ydata(), np.median(RUNS, axis=0))
    np.testing.assert_array_equal(b.get_ydata(), np.median(RUNS[:2] * 2, axis=0))
    band_a, band_b = ax.collections
    low, high = band_edges(band_a, [1, 2, 3, 4])
    np.testing.assert_allclose(low, np.percentile(RUNS, 25, axis=0))
    np.testing.assert_allclose(high, np.percentile(RUNS, 75, axis=0))
    np.testing.assert_allclose(
        band_edges(band_b, [1])[1], [np.percentile(RUNS[:2] * 2, 75, axis=0)[0]]
    )
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["best known: 63 decisions", a.get_label(), b.get_label()]


def test_runs_of_different_lengths_count_where_they_have_episodes() -> None:
    # A decision budget ends each run after its own number of episodes.
    runs = [[10.0, 20.0, 30.0], [20.0, 40.0], [30.0, 60.0, 90.0, 120.0]]
    (ax,) = plots.curves_figure({"": runs}, "Budget").axes
    (line,) = ax.get_lines()
    assert line.get_label() == "median of 3 seeds, 25-75 % band (of the runs still going)"
    # Medians by hand: of 3, 3, 2 and 1 runs.
    np.testing.assert_array_equal(line.get_ydata(), [20.0, 40.0, 60.0, 120.0])


def test_one_run_is_a_line_without_band_on_linear_axes() -> None:
    figure = plots.curves_figure({"": [RUNS[0]]}, "One", ylabel="return", log_y=False)
    (ax,) = figure.axes
    (line,) = ax.get_lines()
    assert line.get_label() == "one run" and not ax.collections
    np.testing.assert_array_equal(line.get_ydata(), RUNS[0])
    assert ax.get_ylabel() == "return" and ax.get_yscale() == "linear"


def test_line_figure_arrows_labels_and_long_titles() -> None:
    arrows = np.array([[0.0, 1.0, 0.1, -0.2], [1.0, 2.0, 0.3, 0.0]])
    title = "A long title " * 10
    figure = plots.line_figure(
        [plots.Series("s", [0, 1, 2], [3, 4, 5])],
        plots.Labels(title, "q1 [rad]", "dq1 [rad/s]"),
        arrows=arrows,
    )
    (ax,) = figure.axes
    assert ax.get_xlabel() == "q1 [rad]" and ax.get_ylabel() == "dq1 [rad/s]"
    assert " ".join(ax.get_title().split()) == " ".join(title.split())  # wrapped, not cut
    (quiver,) = ax.collections
    np.testing.assert_array_equal(quiver.get_offsets(), arrows[:, :2])
    np.testing.assert_array_equal(np.stack([quiver.U, quiver.V], 1), arrows[:, 2:])


@pytest.mark.parametrize(
    ("name", "magic"),
    [
        ("f.png", b"\x89PNG\r\n\x1a\n"),
        ("f.svg", b"<?xml"),
        ("f.SVG", b"<?xml"),
        ("f.pdf", b"%PDF-"),
    ],
)
def test_the_suffix_chooses_the_format(tmp_path, name, magic) -> None:
    path = plots.learning_curve(tmp_path / name, RUNS, "Curves", [(63.0, "best")])
    assert path.read_bytes().startswith(magic)
    assert [p.name for p in tmp_path.iterdir()] == [name]  # no temporary file left


def test_svg_and_pdf_are_reproducible(tmp_path) -> None:
    for name in ("a.svg", "b.svg", "a.pdf", "b.pdf"):
        plots.learning_curve(tmp_path / name, RUNS, "Curves")
    assert (tmp_path / "a.svg").read_bytes() == (tmp_path / "b.svg").read_bytes()
    assert (tmp_path / "a.pdf").read_bytes() == (tmp_path / "b.pdf").read_bytes()
    assert matplotlib.rcParams["svg.hashsalt"] is None  # the user's settings, restored


@pytest.mark.parametrize("name", ["f.jpg", "f", "f.png.txt"])
def test_an_unknown_suffix_is_refused_before_drawing(tmp_path, name, monkeypatch) -> None:
    monkeypatch.setattr(plots, "curves_figure", lambda *a: pytest.fail("drew a figure"))
    with pytest.raises(ValueError, match=r"must end in \.png, \.svg, \.pdf") as error:
        plots.compare_curves(tmp_path / name, {"": RUNS}, "Curves")
    assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match="must end in"):
        plots.line_plot(tmp_path / name, [], plots.Labels("t", "x", "y"))
    assert not any(tmp_path.iterdir())


def test_matplotlib_stays_out_of_import_and_pyplot() -> None:
    timings = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", "import acrobot_mj, acrobot_mj.cli"],
        capture_output=True,
        text=True,
        check=True,
    ).stderr
    assert "acrobot_mj.cli" in timings and "matplotlib" not in timings
    drawn = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from acrobot_mj.report import plots; "
            "plots.curves_figure({'': [[1.0, 2.0]]}, 't'); "
            "print('matplotlib' in sys.modules, 'matplotlib.pyplot' in sys.modules)",
        ],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert drawn.split() == ["True", "False"]


def test_training_curve_figure_is_the_runs_scores(tmp_path, figures) -> None:
    config = PRESETS["book"]
    records = [{"episode_lengths": list(r), "episode_returns": list(-r)} for r in RUNS]
    plot_learning_curves(tmp_path / "learning_curve.png", config, records, "3 seeds")
    (ax,) = figures["learning_curve.png"].axes
    line = ax.get_lines()[-1]
    np.testing.assert_array_equal(line.get_ydata(), np.median(RUNS, axis=0))
    assert ax.get_title().startswith("sarsa_lambda") and ax.get_title().endswith("3 seeds")
    assert ax.get_xlabel() == "episode" and ax.get_ylabel().endswith("(log scale)")


def test_cli_curves_writes_svg_and_refuses_bad_suffix(tmp_path, figures, capsys) -> None:
    for name, runs in (("a", RUNS), ("b", RUNS[:2])):
        folder = tmp_path / name
        for seed, lengths in enumerate(runs):
            record = {"episode_lengths": list(lengths), "episode_returns": list(-lengths)}
            (folder / f"seed_{seed}").mkdir(parents=True)
            (folder / f"seed_{seed}" / "run.json").write_text(json.dumps(record))
        summary = {"config": PRESETS["book"].to_dict(), "runs": [f"seed_{s}" for s in range(3)]}
        summary["runs"] = summary["runs"][: len(runs)]
        (folder / "summary.json").write_text(json.dumps(summary))
    out = tmp_path / "curves.svg"
    assert exits(["curves", str(tmp_path / "a"), str(tmp_path / "b"), "--out", str(out)]) == 0
    assert out.read_bytes().startswith(b"<?xml")
    (ax,) = figures["curves.svg"].axes
    a, b = ax.get_lines()
    np.testing.assert_array_equal(a.get_ydata(), np.median(RUNS, axis=0))
    np.testing.assert_array_equal(b.get_ydata(), np.median(RUNS[:2], axis=0))
    assert [a.get_label()[:2], b.get_label()[:2]] == ["a:", "b:"]
    capsys.readouterr()
    assert exits(["curves", str(tmp_path / "a"), "--out", str(tmp_path / "c.gif")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ".png, .svg, .pdf" in err
    assert not (tmp_path / "c.gif").exists()


def test_validation_figures_draw_the_flow_and_the_swing(tmp_path, figures) -> None:
    actions = [2, 0, 1]
    names = phase_figures(actions, tmp_path)
    assert names == ["phase_portrait.png", "swing_up_phase.png"]
    (flow,) = figures["phase_portrait.png"].axes
    assert len(flow.get_lines()) == 5 and len(flow.collections[0].get_offsets()) == 15 * 11
    for line in flow.get_lines():
        assert len(line.get_xdata()) == 201 and line.get_ydata()[0] == 0.0  # from rest
    (swing,) = figures["swing_up_phase.png"].axes
    shoulder, elbow = swing.get_lines()
    assert len(shoulder.get_xdata()) == 1 + 4 * len(actions)
    assert (shoulder.get_xdata()[0], shoulder.get_ydata()[0]) == (HANGING[0], HANGING[2])
    assert (elbow.get_xdata()[0], elbow.get_ydata()[0]) == (HANGING[1], HANGING[3])
    assert swing.get_xlabel() == "angle [rad]" and swing.get_ylabel() == "angular velocity [rad/s]"


def test_energy_drift_figure_has_each_integrator(tmp_path, figures) -> None:
    integrator_study(seconds=1.0, reference_substeps=2, out=tmp_path)
    (ax,) = figures["energy_drift.png"].axes
    lines = ax.get_lines()
    assert [line.get_label() for line in lines][:3] == [m.replace("_", " ") for m in COMPARED]
    assert ax.get_yscale() == "log" and ax.get_xlabel() == "time [s]"
    for line in lines:
        np.testing.assert_allclose(line.get_xdata(), np.arange(21) * 0.05)
        assert line.get_ydata()[0] == 1e-16  # no error at t = 0 (floored for the log axis)
