"""MP4 videos (and still strips) of the acrobot, through imageio and imageio-ffmpeg.

A video is real time: ``fps = 1 / (timestep * frame_skip)``, one frame for the reset state and
one per step. Frames get an optional caption with the time, the torque and the tip height.
"""

from __future__ import annotations

import functools
import json
import queue
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import imageio.v2 as imageio
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from acrobot_mj.env import TORQUES

#: x264 at constant quality, its fastest preset: software GL and the encoder share the CPU, and
#: at crf 30 a 300-frame swing-up still takes only ~100 kB.
FFMPEG_PARAMS = ["-preset", "ultrafast", "-crf", "30", "-pix_fmt", "yuv420p"]


class VideoWriter:
    """An MP4 writer whose frames go to ffmpeg from a background thread, so piping and encoding
    overlap the rendering of the next frames. Errors in the thread surface in the caller."""

    def __init__(self, path: str | Path, fps: float, queue_size: int = 16) -> None:
        self._writer = imageio.get_writer(
            path,
            fps=fps,
            codec="libx264",
            macro_block_size=8,
            ffmpeg_params=FFMPEG_PARAMS,
            ffmpeg_log_level="error",
        )
        self._queue: queue.Queue[np.ndarray | None] = queue.Queue(maxsize=queue_size)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while (frame := self._queue.get()) is not None:
            if self._error is None:
                try:
                    self._writer.append_data(frame)
                except BaseException as error:  # re-raised in the caller's thread
                    self._error = error

    def append(self, frame: np.ndarray) -> None:
        if self._error is not None:
            raise self._error
        self._queue.put(frame)

    def close(self) -> None:
        self._queue.put(None)
        self._thread.join()
        self._writer.close()
        if self._error is not None:
            raise self._error

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def caption(frame: np.ndarray, text: str, colour: tuple[int, int, int] = (20, 20, 20)):
    """Draw ``text`` in the top-left corner of ``frame`` (in place) and return it."""
    size = max(10, frame.shape[0] // 24)
    band = frame[: size + 12]  # only the caption's band goes through Pillow: 5x faster
    image = Image.fromarray(band)
    ImageDraw.Draw(image).text((8, 6), text, fill=colour, font=_font(size))
    band[...] = np.asarray(image)
    return frame


@functools.lru_cache(maxsize=8)
def _font(size: int) -> ImageFont.FreeTypeFont:
    return ImageFont.load_default(size)


def _torque_of(env, action: Any) -> float:
    if getattr(env.unwrapped, "continuous", False):
        return float(np.asarray(action).ravel()[0])
    return TORQUES[int(action)]


def record_episode(
    env,
    policy: Callable[[np.ndarray], Any],
    path: str | Path,
    seed: int | None = None,
    max_steps: int | None = None,
    reset_options: dict[str, Any] | None = None,
    captions: bool = True,
    strip: str | Path | None = None,
    strip_frames: int = 6,
) -> dict[str, Any]:
    """Run ``policy`` for one episode of ``env`` (``render_mode="rgb_array"``) and write an MP4.

    Stops at termination, truncation or ``max_steps``. With ``strip``, also writes a PNG of
    ``strip_frames`` frames spread over the episode. Returns a record of the episode, also
    written as JSON beside the video.
    """
    if env.render_mode != "rgb_array":
        raise ValueError(f"record_episode needs render_mode='rgb_array', got {env.render_mode!r}")
    path = Path(path)
    if path.suffix.lower() != ".mp4":
        raise ValueError(f"the video file must end in .mp4, got {path}")
    path.parent.mkdir(parents=True, exist_ok=True)
    fps = env.metadata["render_fps"]
    dt = env.unwrapped.dt
    obs, info = env.reset(seed=seed, options=reset_options)
    length, total, success = 0, 0.0, False
    kept: list[np.ndarray] = []
    with VideoWriter(path, fps) as writer:
        torque, done, note = 0.0, False, ""
        while True:
            frame = env.render()
            if captions:
                caption(
                    frame,
                    f"t = {length * dt:5.2f} s   torque {torque:+.2f} N m   "
                    f"tip {info['tip_height']:+.2f} m{note}",
                )
            writer.append(frame)
            if strip is not None:
                kept.append(frame)
            if done:
                break
            action = policy(obs)
            torque = _torque_of(env, action)
            obs, reward, terminated, truncated, info = env.step(action)
            length += 1
            total += float(reward)
            success = bool(info.get("is_success", terminated))
            done = terminated or truncated or (max_steps is not None and length >= max_steps)
            note = "   GOAL" if success else "   truncated" if truncated else ""
    record = {
        "video": str(path),
        "fps": fps,
        "frames": length + 1,
        "length": length,
        "return": total,
        "success": success,
        "seed": seed,
        "size": [env.unwrapped.width, env.unwrapped.height],
        "camera": env.unwrapped.camera,
    }
    if strip is not None:
        picks = np.linspace(0, len(kept) - 1, strip_frames).round().astype(int)
        Image.fromarray(np.concatenate([kept[i] for i in picks], axis=1)).save(strip)
        record["strip"] = str(strip)
    path.with_suffix(".json").write_text(json.dumps(record, indent=1))
    return record


def render_run(
    run_dir: str | Path,
    out: str | Path,
    seed: int = 0,
    width: int = 480,
    height: int = 480,
    camera: str = "side",
    max_steps: int | None = None,
    strip: str | Path | None = None,
    captions: bool = True,
) -> dict[str, Any]:
    """A video of a trained run's greedy policy from rest, on the run's own env settings."""
    from acrobot_mj.training import load_agent, make_env, tie_stream

    config, run_seed, agent = load_agent(run_dir)
    env = make_env(config, render_mode="rgb_array", width=width, height=height, camera=camera)
    stream = tie_stream(run_seed)  # as the run's greedy_from_rest and evaluate's episode 0
    try:
        record = record_episode(
            env,
            lambda obs: agent.greedy_action(obs, stream),
            out,
            seed=seed,
            max_steps=max_steps,
            reset_options={"start_noise": 0.0},
            captions=captions,
            strip=strip,
        )
    finally:
        env.close()
    record.update(run=str(run_dir), run_seed=run_seed, policy="greedy")
    Path(out).with_suffix(".json").write_text(json.dumps(record, indent=1))
    return record


def render_policy(
    name: str,
    out: str | Path,
    seed: int = 0,
    steps: int | None = None,
    frame_skip: int = 1,
    width: int = 480,
    height: int = 480,
    camera: str = "side",
    strip: str | Path | None = None,
    captions: bool = True,
) -> dict[str, Any]:
    """A video of a fixed policy (``pump``, ``zero`` or ``random``) from rest."""
    import gymnasium as gym

    import acrobot_mj
    from acrobot_mj.policies import make_policy

    env = gym.make(
        acrobot_mj.ENV_ID,
        frame_skip=frame_skip,
        render_mode="rgb_array",
        width=width,
        height=height,
        camera=camera,
    )
    try:
        record = record_episode(
            env,
            make_policy(name, seed),
            out,
            seed=seed,
            max_steps=steps,
            captions=captions,
            strip=strip,
        )
    finally:
        env.close()
    record.update(policy=name, frame_skip=frame_skip)
    Path(out).with_suffix(".json").write_text(json.dumps(record, indent=1))
    return record
