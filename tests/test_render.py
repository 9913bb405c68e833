"""Offscreen rendering and MP4s through EGL and through OSMesa (Mesa, software GL).

MuJoCo fixes its GL backend when it is imported, so each backend runs in its own Python process
with MUJOCO_GL set; the frames and videos it writes are checked here.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest

# isort: off
import acrobot_mj  # before mujoco: it picks the GL backend mujoco reads on import
import mujoco

# isort: on
from acrobot_mj.envs import gl as render
from acrobot_mj.envs.assets import model_path

GL_BACKENDS = ("egl", "osmesa")
W, H = 240, 240

# Renders the two keyframes with env.render() and writes a 40-step pump-policy video, both
# without captions (so that only the acrobot changes between frames).
PROBE = f"""
import json, numpy as np, mujoco, gymnasium as gym, acrobot_mj
from acrobot_mj.envs import gl as render
from acrobot_mj.report.video import RenderSettings, render_policy
env = gym.make(acrobot_mj.ENV_ID, render_mode="rgb_array", width={W}, height={H})
env.reset(seed=0)
u = env.unwrapped
frames = {{}}
for key in ("hanging", "upright"):
    mujoco.mj_resetDataKeyframe(u.model, u.data, u.model.key(key).id)
    frames[key] = env.render()
env.close()
np.savez("poses.npz", **frames)
render_policy("pump", "pump.mp4", RenderSettings(width={W}, height={H}, captions=False,
                                                max_steps=40))
print(json.dumps({{"backend": mujoco.rendering.classic.gl_context.GLContext.__module__,
                  "choice": render.CHOICE}}))
"""


def run_python(code: str, cwd, **env_vars) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    env.update(env_vars)
    return subprocess.run(
        [sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )


@pytest.fixture(scope="module", params=GL_BACKENDS)
def rendered(request, tmp_path_factory):
    folder = tmp_path_factory.mktemp(request.param)
    result = run_python(PROBE, folder, MUJOCO_GL=request.param)
    assert result.returncode == 0, result.stderr[-3000:]
    info = json.loads(result.stdout.strip().splitlines()[-1])
    return request.param, folder, info


def test_the_requested_backend_was_used(rendered) -> None:
    backend, _, info = rendered
    assert info["backend"] == f"mujoco.{backend}" and info["choice"] == "user"


def test_video_frames(rendered) -> None:
    _, folder, _ = rendered
    frames = iio.imread(folder / "pump.mp4")
    assert frames.shape == (41, H, W, 3)  # the reset frame plus one per step
    record = json.loads((folder / "pump.json").read_text())
    assert record["fps"] == 20 and record["frames"] == 41
    # Not blank: a light background with dark and coloured links (std over pixels ~40).
    assert all(frame.std() > 10 for frame in frames)
    # The pump policy keeps the acrobot moving, so every frame differs from the one before.
    # Mean absolute difference of a moved frame: >= 0.3 grey levels measured; video noise
    # between identical frames at crf 30 stays below 0.05.
    changes = np.abs(np.diff(frames.astype(float), axis=0)).mean(axis=(1, 2, 3))
    assert np.all(changes > 0.1), changes


def _pixel(point_xz: tuple[float, float]) -> tuple[int, int]:
    """Project a point (x, 0, z) [m] through the scene's side camera to (row, column)."""
    model = mujoco.MjModel.from_xml_path(str(model_path()))
    camera = model.camera("side")
    depth = -camera.pos[1]  # the camera looks along +y at the plane y = 0
    focal = (H / 2) / math.tan(math.radians(camera.fovy[0]) / 2)
    column = W / 2 + point_xz[0] * focal / depth
    row = H / 2 - (point_xz[1] - camera.pos[2]) * focal / depth
    return round(row), round(column)


def _is_orange(rgb) -> bool:  # link 1: material rgba 0.85 0.45 0.1
    r, g, b = (int(v) for v in rgb)
    return r > 150 and 50 < g < 160 and b < 90


def _is_blue(rgb) -> bool:  # link 2: material rgba 0.15 0.45 0.85
    r, _, b = (int(v) for v in rgb)
    return b > 150 and r < 110


@pytest.mark.parametrize(("pose", "sign"), [("hanging", -1), ("upright", 1)])
def test_known_poses_put_the_links_where_they_belong(rendered, pose, sign) -> None:
    _, folder, _ = rendered
    with np.load(folder / "poses.npz") as npz:
        frame = npz[pose]
    assert frame.shape == (H, W, 3) and frame.dtype == np.uint8
    # Link 1 spans 0..1 m from the pivot, link 2 1..2 m, straight down (hanging) or up.
    for distance in (0.3, 0.5, 0.7):
        assert _is_orange(frame[_pixel((0.0, sign * distance))]), (pose, distance)
    for distance in (1.3, 1.5, 1.7):
        assert _is_blue(frame[_pixel((0.0, sign * distance))]), (pose, distance)
    # The other side of the pivot, and beside the links, is not link-coloured.
    for point in [(0.0, -sign * 0.5), (0.6, sign * 0.5), (-0.6, sign * 1.5)]:
        rgb = frame[_pixel(point)]
        assert not _is_orange(rgb) and not _is_blue(rgb), (pose, point)


def test_a_backend_that_cannot_load_gives_a_clear_error(tmp_path) -> None:
    # OSMesa requested while PyOpenGL is pinned to EGL: MuJoCo cannot load its OSMesa context.
    code = (
        "from acrobot_mj.cli import main; "
        "main(['render', '--policy', 'zero', '--steps', '2', '--out', 'x.mp4'])"
    )
    result = run_python(code, tmp_path, MUJOCO_GL="osmesa", PYOPENGL_PLATFORM="egl")
    assert result.returncode == 2
    assert "no headless OpenGL backend" in result.stderr
    assert "MUJOCO_GL=osmesa does not work" in result.stderr
    assert "libosmesa6" in result.stderr  # what to install
    assert not (tmp_path / "x.mp4").exists()


def test_no_working_backend_names_every_attempt_and_never_a_window() -> None:
    backend, attempts = render.select_backend(
        {"egl": lambda: "libEGL cannot be loaded (test)", "osmesa": lambda: "no OSMesa (test)"}
    )
    assert backend is None
    message = str(render.backend_error(attempts))
    for text in (
        "tried egl: libEGL cannot be loaded (test)",
        "libegl1",
        "tried osmesa: no OSMesa (test)",
        "libosmesa6",
        "never falls back to a window",
    ):
        assert text in message
    # The first working probe wins; later ones are not tried.
    assert render.select_backend({"egl": lambda: "broken", "osmesa": lambda: None}) == (
        "osmesa",
        {"egl": "broken", "osmesa": None},
    )


def test_configure_respects_the_users_choice(monkeypatch) -> None:
    monkeypatch.setattr(render, "CHOICE", render.CHOICE)  # restored after the test
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    assert render.configure_gl() == "osmesa"
    assert os.environ["MUJOCO_GL"] == "osmesa"


def test_record_video_wrapper(tmp_path) -> None:
    # Gymnasium's RecordVideo (needs the `video` extra: moviepy) works on this env as is.
    pytest.importorskip(
        "moviepy", reason="RecordVideo needs moviepy: pip install acrobot-mj[video]"
    )
    import gymnasium as gym
    from gymnasium.wrappers import RecordVideo

    env = gym.make(
        acrobot_mj.ENV_ID, render_mode="rgb_array", max_episode_steps=20, width=160, height=160
    )
    folder = tmp_path / "videos"
    env = RecordVideo(env, str(folder), episode_trigger=lambda episode: True, disable_logger=True)
    env.reset(seed=0)
    while not any(env.step(2)[2:4]):
        pass
    env.close()
    (video,) = folder.glob("*.mp4")
    assert iio.imread(video).shape == (21, 160, 160, 3)


def test_rgb_array_list_through_make() -> None:
    # gymnasium.make adds its RenderCollection wrapper: one frame per reset and step.
    import gymnasium as gym

    env = gym.make(acrobot_mj.ENV_ID, render_mode="rgb_array_list", width=64, height=48)
    env.reset(seed=0)
    for _ in range(3):
        env.step(2)
    frames = env.render()
    env.close()
    assert len(frames) == 4 and frames[0].shape == (48, 64, 3)
