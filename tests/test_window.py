"""``render_mode="human"``: MuJoCo's viewer window, seen on a virtual X display (Xvfb), and a
clear one-line error where there is no display."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Steps, screenshots of the display, then (or not) close: one JSON line with what it saw.
SCRIPT = """
import json, sys, time
import numpy as np
from PIL import ImageGrab
import gymnasium as gym
import acrobot_mj

env = gym.make("acrobot_mj/Acrobot-v0", render_mode="human")
env.reset(seed=0)
shots, started = [], time.perf_counter()
for steps in (10, 30):
    for _ in range(steps):
        env.step(2)
    shots.append(np.asarray(ImageGrab.grab(xdisplay=sys.argv[1]).convert("RGB")).astype(int))
elapsed = time.perf_counter() - started
orange = [int(((s[..., 0] > 180) & (s[..., 1] > 70) & (s[..., 1] < 170) & (s[..., 2] < 90)).sum())
          for s in shots]
blue = [int(((s[..., 2] > 180) & (s[..., 0] < 110)).sum()) for s in shots]
moved = int((np.abs(shots[0] - shots[1]).sum(axis=-1) > 60).sum())
if sys.argv[2] == "close":
    env.close()
print(json.dumps({"elapsed": elapsed, "orange": orange, "blue": blue, "moved": moved}))
"""


@pytest.fixture(scope="module")
def display():
    if shutil.which("Xvfb") is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb)")
    number = next(n for n in range(90, 190) if not Path(f"/tmp/.X{n}-lock").exists())
    server = subprocess.Popen(
        ["Xvfb", f":{number}", "-screen", "0", "800x600x24", "-nolisten", "tcp"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    socket = Path(f"/tmp/.X11-unix/X{number}")
    deadline = time.monotonic() + 30
    while not socket.exists():
        assert server.poll() is None and time.monotonic() < deadline, "Xvfb did not start"
        time.sleep(0.05)
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)


def _run(args: list[str], **env: str) -> subprocess.CompletedProcess:
    clean = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    return subprocess.run(
        args,
        env={**clean, "PYTHONPATH": str(ROOT), **env},
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.slow
@pytest.mark.parametrize("ending", ["close", "no close"])
def test_human_mode_shows_the_acrobot_moving_at_real_time(display, ending) -> None:
    done = _run([sys.executable, "-c", SCRIPT, display, ending], DISPLAY=display)
    # Exit 0 both ways: a process that ended with the window open, or while it was torn down,
    # crashed (GLFW ended under the viewer's thread).
    assert done.returncode == 0, done.stderr[-2000:]
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    # The links, orange and blue, in both screenshots (hundreds of pixels each in an 800 x 600
    # screen's window), in other places after 30 steps of +1 N m.
    assert min(seen["orange"]) > 100 and min(seen["blue"]) > 100, seen
    assert seen["moved"] > 100, seen
    # 40 steps of 0.05 s shown at real time: at least 2 s (less 10 % for timer granularity).
    assert seen["elapsed"] >= 1.8, seen


def test_without_a_display_the_window_is_one_line_naming_why(display) -> None:
    command = [sys.executable, "-m", "acrobot_mj_main", "render", "--policy", "pump", "--live"]
    done = _run([*command, "--steps", "3"])
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1, done.stderr
    assert "no display is set (DISPLAY)" in done.stderr
    unused = f":{int(display[1:]) + 50}"  # no server there: GLFW would have ended the process
    done = _run([*command, "--steps", "3"], DISPLAY=unused)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1, done.stderr
    assert "cannot open a window" in done.stderr


@pytest.mark.slow
def test_render_live_shows_a_policy_and_says_how_it_went(display) -> None:
    command = [sys.executable, "-m", "acrobot_mj_main", "render", "--policy", "pump", "--live"]
    done = _run([*command, "--frame-skip", "4", "--steps", "5"], DISPLAY=display)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "showed 5 actions; the goal was not reached"
    done = _run([*command, "--out", "x.mp4"], DISPLAY=display)
    assert done.returncode == 2 and "give no --out" in done.stderr


def test_depth_array_gives_distances_that_change_as_the_acrobot_moves() -> None:
    import gymnasium as gym

    env = gym.make("acrobot_mj/Acrobot-v0", render_mode="depth_array", width=64, height=48)
    env.reset(seed=0)
    before = env.render()
    assert before.dtype == np.float32 and before.shape == (48, 64)
    assert np.all(np.isfinite(before)) and before.min() > 0
    # The side camera: the links are nearer than the backdrop behind them.
    assert before.max() - before.min() > 1.0
    for _ in range(40):
        env.step(2)
    assert not np.array_equal(env.render(), before)
    env.close()


@pytest.mark.slow
def test_gymnasiums_checker_renders_every_mode_cleanly(display) -> None:
    # check_env renders each of render_modes (human, rgb_array, depth_array); no warning.
    script = (
        "import warnings, gymnasium as gym, acrobot_mj\n"
        "from gymnasium.utils.env_checker import check_env\n"
        "warnings.simplefilter('error')\n"
        "check_env(gym.make('acrobot_mj/AcrobotRL-v0').unwrapped)\n"
        "print('clean')\n"
    )
    done = _run([sys.executable, "-c", script], DISPLAY=display)
    assert done.returncode == 0 and done.stdout.strip() == "clean", done.stderr[-2000:]
