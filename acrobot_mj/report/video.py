"""MP4 videos (and still strips) of the acrobot, through imageio and imageio-ffmpeg: real time
(``fps = 1 / (timestep * frame_skip)``), one frame for the reset state and one per step; at
most :data:`MAX_FPS`, one step in every few drawn where the steps are shorter (and the last)."""

from __future__ import annotations

import contextlib
import functools
import itertools
import math
import os
import queue
import re
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import imageio.v2 as imageio
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from acrobot_mj.bars import Steps
from acrobot_mj.control.policies import make_policy
from acrobot_mj.envs.rollout import (
    UNWATCHED,
    Actor,
    Hooks,
    PolicyActor,
    ResetHook,
    StepHook,
    run_episode,
)
from acrobot_mj.envs.spaces import TORQUES
from acrobot_mj.envs.tasks import HeightGoal
from acrobot_mj.files import read_json, write_atomic, write_json

#: x264's fastest preset at constant quality: software GL and the encoder share the CPU.
FFMPEG_PARAMS = ["-preset", "ultrafast", "-crf", "30", "-pix_fmt", "yuv420p"]


class VideoWriter:
    """An MP4 writer encoding on a thread into a temporary file, renamed to ``path`` when
    complete; any failure is one ``OSError`` naming the file, raised in the caller's thread."""

    def __init__(self, path: str | Path, fps: float, queue_size: int = 16) -> None:
        self.path = Path(path)
        self._tmp = self.path.with_name(f".{self.path.stem}.{os.getpid()}.tmp.mp4")
        try:  # ffmpeg quiet: _failure reports in one line
            self._writer = imageio.get_writer(
                self._tmp,
                fps=fps,
                codec="libx264",
                macro_block_size=2,
                ffmpeg_params=FFMPEG_PARAMS,
                ffmpeg_log_level="quiet",
            )
        except OSError as error:
            raise self._failure(error) from None
        self._queue: queue.Queue[np.ndarray | None] = queue.Queue(maxsize=queue_size)
        self._error: BaseException | None = None
        self._frames = 0  # appended
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _failure(self, error: BaseException) -> OSError:
        # ffmpeg's first line goes on with its whole command line: the folder says more.
        reason = (str(error).strip().splitlines() or [type(error).__name__])[0]
        with contextlib.suppress(OSError, AttributeError):  # no statvfs on Windows
            folder = os.statvfs(self.path.parent)  # before the partial video is removed
            if folder.f_flag & os.ST_RDONLY:
                reason = "its folder is on a read-only file system"
            elif folder.f_bavail * folder.f_frsize < 2**20:
                reason = "no space left on the device"
        with contextlib.suppress(OSError):  # a read-only file system: nothing was written
            self._tmp.unlink(missing_ok=True)
        return OSError(f"cannot write the video {self.path}: {reason}")

    def _check_frames(self) -> BaseException | None:
        """Why the encoded file is not the whole video (a full disk), or None."""
        import imageio_ffmpeg

        try:
            frames, _ = imageio_ffmpeg.count_frames_and_secs(str(self._tmp))
        except (RuntimeError, OSError) as error:
            return OSError(f"the encoded file cannot be read back ({str(error).splitlines()[0]})")
        if frames != self._frames:
            return OSError(f"the encoded file holds {frames} of {self._frames} frames")
        return None

    def _run(self) -> None:
        while (frame := self._queue.get()) is not None:
            if self._error is None:
                try:
                    self._writer.append_data(frame)
                except BaseException as error:  # re-raised in the caller's thread
                    self._error = error

    def append(self, frame: np.ndarray) -> None:
        if self._error is not None:
            self.close(complete=False)
        self._queue.put(frame)
        self._frames += 1

    def close(self, complete: bool = True) -> None:
        """Finish the video (``complete``) and move it into place, or discard it."""
        self._queue.put(None)
        self._thread.join()
        try:
            self._writer.close()
        except OSError as error:
            self._error = self._error or error
        if self._error is None and complete:  # ffmpeg may end early without saying so
            self._error = self._check_frames()
        if self._error is not None:
            raise self._failure(self._error)
        if complete:
            os.replace(self._tmp, self.path)
        else:
            self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, kind: type | None, *exc: object) -> None:
        self.close(complete=kind is None)


def caption(frame: np.ndarray, text: str, colour: tuple[int, int, int] = (20, 20, 20)):
    """Draw ``text`` at the top left of ``frame`` (in place, returned), in a font that fits."""
    shape = re.sub(r"\d", "0", text)  # captions of one video share a size
    size, font = _fitting_font(shape, max(10, frame.shape[0] // 24), frame.shape[1] - 16)
    band = frame[: size + 12]  # only the caption's band goes through Pillow
    image = Image.fromarray(band)
    ImageDraw.Draw(image).text((8, 6), text, fill=colour, font=font)
    band[...] = np.asarray(image)
    return frame


@functools.lru_cache(maxsize=256)
def _fitting_font(
    text: str, size: int, width: int
) -> tuple[int, ImageFont.FreeTypeFont | ImageFont.ImageFont]:
    while size > 8 and ImageFont.load_default(size).getlength(text) > width:
        size -= 1
    return size, ImageFont.load_default(size)


def check_outputs(path: Path, strip: str | Path | None) -> None:
    """Refuse to replace anything but an earlier video's files: ``path`` must end in .mp4, its
    JSON record may only replace a video record, and the strip (a .png) only one a record names."""
    if path.suffix.lower() != ".mp4":
        raise ValueError(f"the video file must end in .mp4, got {path}")
    record = path.with_suffix(".json")
    if record.exists() and "video" not in _json_object(record):
        raise FileExistsError(
            f"{record} exists and is not a video record: the video's record "
            "would replace it; choose another --out"
        )
    strip = None if strip is None else Path(strip)
    if strip is not None and strip.suffix.lower() != ".png":
        raise ValueError(f"the strip must be a .png file, got {strip}")
    if strip is not None and strip.exists():
        records = map(_json_object, strip.parent.glob("*.json"))
        named = {Path(r.get("strip", "")).resolve() for r in records if "video" in r}
        if strip.resolve() not in named:
            raise FileExistsError(f"{strip} exists and is no video's strip: choose another")


def _json_object(path: Path) -> dict[str, Any]:
    try:
        value = read_json(path)
    except (OSError, ValueError):
        return {}
    return value if isinstance(value, dict) else {}


@dataclass(frozen=True)
class RenderSettings:
    """Frame size [pixels], camera (``side`` or ``wide``), captions, a 6-frame strip (a .png, or
    None), at most ``max_steps`` actions (None: all), the reset seed, a bar on stderr."""

    width: int = 480
    height: int = 480
    camera: str = "side"
    captions: bool = True
    strip: str | Path | None = None
    max_steps: int | None = None
    seed: int = 0
    progress: bool = False

    def env_kwargs(self) -> dict[str, Any]:
        return {"width": self.width, "height": self.height, "camera": self.camera}


def check_video(env: Any, path: Path, strip: str | Path | None) -> None:
    """Refuse, before any frame, a video :func:`record_episode` cannot write: ``env`` not
    ``rgb_array``, a frame of odd size, or files :func:`check_outputs` refuses."""
    if env.render_mode != "rgb_array":
        raise ValueError(f"record_episode needs render_mode='rgb_array', got {env.render_mode!r}")
    size = (env.unwrapped.width, env.unwrapped.height)
    if size[0] % 2 or size[1] % 2:  # H.264 in yuv420p: ffmpeg would resize the video silently
        raise ValueError(f"an MP4's width and height must be even, got {size[0]} x {size[1]}")
    check_outputs(path, strip)


#: The most frames a second a video has: steps of 0.002 s (the AI Olympics') are drawn one in
#: ten, at 50 fps, not 500 (which players drop and which takes ten times as long to render).
MAX_FPS = 50.0


def record_episode(
    env: Any,
    actor: Actor,
    path: str | Path,
    settings: RenderSettings = RenderSettings(),
    *,
    reset_options: dict[str, Any] | None = None,
    hooks: Hooks = UNWATCHED,
) -> dict[str, Any]:
    """Write an episode of ``actor`` on ``env`` (``rgb_array``) as MP4 (and the strip); its
    record, which the caller completes and writes beside it (:func:`write_video_record`);
    ``hooks`` see the reset and each step, before its frame."""
    path, strip = Path(path), settings.strip
    check_video(env, path, strip)
    path.parent.mkdir(parents=True, exist_ok=True)
    every = max(1, math.ceil(env.metadata["render_fps"] / MAX_FPS - 1e-9))
    fps = env.metadata["render_fps"] / every
    limit = settings.max_steps or getattr(env.spec, "max_episode_steps", None)  # None: unknown
    bar = Steps(limit + 1 if limit else None, "render", settings.progress, "steps")
    with VideoWriter(path, fps) as writer, bar:
        frames = _Frames(env, writer, bar, settings.captions, [] if strip else None, every)
        watched = Hooks(frames.reset_hook(hooks.on_reset), frames.step_hook(hooks.on_step))
        episode = run_episode(
            env, actor, settings.seed, reset_options, max_steps=settings.max_steps, hooks=watched
        )
    record = {
        "video": str(path),
        "fps": fps,
        "frames": frames.written,
        "length": episode.length,
        "return": episode.episode_return,
        "success": episode.success,
        "seed": settings.seed,
        "size": [env.unwrapped.width, env.unwrapped.height],
        "camera": env.unwrapped.camera,
    }
    if strip is not None and frames.kept is not None:
        picks = np.linspace(0, len(frames.kept) - 1, 6).round().astype(int)
        image = Image.fromarray(np.concatenate([frames.kept[i] for i in picks], axis=1))
        write_atomic(strip, lambda f: image.save(f, format="PNG"))
        record["strip"] = str(strip)
    return record


def write_video_record(record: dict[str, Any]) -> None:
    """A video's record as JSON beside it (``record["video"]``, ``.json`` for ``.mp4``)."""
    write_json(Path(record["video"]).with_suffix(".json"), record)


class _Frames:
    """An episode's frames into ``writer`` (and ``kept``, for a strip), captioned or not."""

    def __init__(
        self,
        env: Any,
        writer: VideoWriter,
        bar: Steps,
        captions: bool,
        kept: list | None,
        every: int = 1,
    ) -> None:
        self.env, self.writer, self.bar, self.captions, self.kept = env, writer, bar, captions, kept
        self.steps = itertools.count(1)
        #: Draw one step in ``every`` (and the last); the frames written so far.
        self.every, self.written = every, 0

    def frame(self, step: int, torque: float, info: dict[str, Any], note: str = "") -> None:
        self.bar.done()
        if step % self.every and not note:  # a step between frames (the last has a note)
            return
        image, task = self.env.render(), self.env.unwrapped.task
        if self.captions:
            words = f"torque {torque:+.2f} N m   {task.caption(info)}{note}"
            caption(image, f"t = {step * self.env.unwrapped.dt:5.2f} s   {words}")
        self.writer.append(image)
        self.written += 1
        if self.kept is not None:
            self.kept.append(image)

    def reset_hook(self, then: ResetHook | None) -> ResetHook:
        def reset(obs: np.ndarray, info: dict[str, Any]) -> None:
            if then is not None:
                then(obs, info)
            self.frame(0, 0.0, info)

        return reset

    def step_hook(self, then: StepHook | None) -> StepHook:
        continuous = getattr(self.env.unwrapped, "continuous", False)
        task = self.env.unwrapped.task

        def step(action, obs, reward, terminated, truncated, info) -> None:
            if then is not None:
                then(action, obs, reward, terminated, truncated, info)
            torque = float(np.asarray(action).ravel()[0]) if continuous else TORQUES[int(action)]
            success = bool(info.get("is_success", terminated))
            note = f"   {task.success_label}" if success else "   truncated" if truncated else ""
            self.frame(next(self.steps), torque, info, note)

        return step


def watch(
    env: gym.Env,
    actor: Actor,
    settings: RenderSettings = RenderSettings(),
    reset_options: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """An episode of ``actor`` on ``env`` (``render_mode="human"``) in MuJoCo's viewer window
    at real time, closed at the end; its length and outcome."""
    try:
        episode = run_episode(
            env, actor, settings.seed, reset_options, max_steps=settings.max_steps
        )
    finally:
        env.close()
    return {"length": episode.length, "success": episode.success}


def watch_policy(
    name: str, settings: RenderSettings = RenderSettings(), frame_skip: int = 1
) -> dict[str, Any]:
    """A fixed policy from rest, live in a window (see :func:`watch`)."""
    env = gym.make(
        HeightGoal.env_id, frame_skip=frame_skip, render_mode="human", camera=settings.camera
    )
    return watch(env, PolicyActor(make_policy(name, settings.seed)), settings)


def render_policy(
    name: str, out: str | Path, settings: RenderSettings = RenderSettings(), frame_skip: int = 1
) -> dict[str, Any]:
    """A video of a fixed policy (``pump``, ``zero`` or ``random``) from rest."""
    env = gym.make(
        HeightGoal.env_id, frame_skip=frame_skip, render_mode="rgb_array", **settings.env_kwargs()
    )
    try:
        record = record_episode(env, PolicyActor(make_policy(name, settings.seed)), out, settings)
    finally:
        env.close()
    record.update(policy=name, frame_skip=frame_skip)
    write_video_record(record)
    return record
