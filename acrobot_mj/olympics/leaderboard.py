"""The AI Olympics acrobot leaderboards' published figures, the one place they are written,
each board with its public source: a file of dfki-ric-underactuated-lab/real_ai_gym_leaderboard
(read at commit 81ea5bc8, September 2025). The figures are the files' own, digit for digit;
entries keep the files' names (their ``Controller`` column)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from acrobot_mj.olympics.protocol import CATEGORY_KEYS

#: The repository that publishes the leaderboards.
REPOSITORY = "dfki-ric-underactuated-lab/real_ai_gym_leaderboard"


@dataclass(frozen=True)
class Board:
    """One leaderboard: its ``name``, the ``path`` of its file in :data:`REPOSITORY`, each
    entry's RealAI ``scores``, and (robustness) each entry's category ``percents`` [%] by
    category key (:data:`~acrobot_mj.olympics.protocol.CATEGORY_KEYS`)."""

    name: str
    path: str
    scores: Mapping[str, float]
    percents: Mapping[str, Mapping[str, float]] = field(default_factory=dict)

    def best(self) -> tuple[str, float]:
        """The entry with the highest score, and its score."""
        name = max(self.scores, key=self.scores.__getitem__)
        return name, self.scores[name]

    def best_percent(self, key: str) -> float:
        """The highest percentage [%] of the category ``key`` on this board."""
        return max(entry[key] for entry in self.percents.values())

    def source(self) -> str:
        """Where the figures come from, as Markdown: the repository and the file."""
        return f"`{REPOSITORY}`, `{self.path}`"


def _percents(*rows: tuple[str, tuple[float, ...]]) -> dict[str, dict[str, float]]:
    return {name: dict(zip(CATEGORY_KEYS, values, strict=True)) for name, values in rows}


#: The swing-up leaderboard (simulation_v2): the v2 score of one 10 s episode from hanging.
PERFORMANCE = Board(
    "performance (simulation_v2)",
    "leaderboards/acrobot_simulation_performance_leaderboard_v2.csv",
    {
        "mcpilco": 0.316,
        "History SAC": 0.655,
        "TVLQR": 0.504,
        "AR-EAPO": 0.633,
        "iLQR Riccati Gains": 0.396,
        "evolsac": 0.524,
        "iLQR MPC stabilization": 0.345,
    },
)

#: The robustness leaderboard (robustness_v2): the overall score and the categories' [%] (model,
#: velocity noise, torque noise, torque step response, time delay, perturbations).
ROBUSTNESS = Board(
    "robustness (robustness_v2)",
    "leaderboards/acrobot_simulation_robustness_leaderboard_v2.csv",
    {
        "mcpilco": 0.241,
        "History SAC": 0.751,
        "TVLQR": 0.607,
        "AR-EAPO": 0.727,
        "iLQR Riccati Gains": 0.138,
        "evolsac": 0.687,
        "iLQR MPC stabilization": 0.343,
    },
    _percents(
        ("mcpilco", (9.0, 9.5, 19.0, 52.4, 4.8, 50.0)),
        ("History SAC", (58.1, 23.8, 100.0, 100.0, 90.5, 78.0)),
        ("TVLQR", (48.1, 19.0, 100.0, 95.2, 23.8, 78.0)),
        ("AR-EAPO", (67.6, 28.6, 100.0, 100.0, 76.2, 64.0)),
        ("iLQR Riccati Gains", (4.8, 9.5, 9.5, 52.4, 4.8, 2.0)),
        ("evolsac", (64.8, 23.8, 100.0, 100.0, 47.6, 76.0)),
        ("iLQR MPC stabilization", (6.7, 9.5, 90.5, 52.4, 4.8, 42.0)),
    ),
)

#: The ICRA 2025 acrobot simulation leaderboard: the global policy's score, the time up of its
#: 60 s episode (simulation_v3, the test's April 2025 draws).
GLOBAL = Board(
    "global policy (ICRA 2025 simulation)",
    "leaderboards/icra2025/ICRA_2025_acrobot_simulation_results.csv",
    {
        "mcpilco": 0.307,
        "VIMPPI": 0.648,
        "AcadosMpc": 0.63,
        "AR-EAPO": 0.658,
        "prx_analytical": 0.117,
    },
)

#: The boards by the part of the protocol they score.
BOARDS = {"performance": PERFORMANCE, "robustness": ROBUSTNESS, "global": GLOBAL}
