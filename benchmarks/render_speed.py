"""Time to render and encode a 1000-step 640x480 episode to MP4 (target: <= 5 s on 2 cores).

Runs ``acrobot_mj.report.video.record_episode`` with a seeded random policy (1001 frames with
captions) several times and prints the median, next to the parts measured alone: stepping and
rendering without encoding, and encoding the same frames without rendering. The GL backend is
whatever acrobot_mj chose (or MUJOCO_GL): run it once with MUJOCO_GL=egl and once with osmesa
to compare.

    python benchmarks/render_speed.py [--repeats R] [--width 640 --height 480]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import gymnasium as gym

import acrobot_mj
from acrobot_mj.control.policies import make_policy
from acrobot_mj.envs.rollout import PolicyActor
from acrobot_mj.report.video import RenderSettings, VideoWriter, caption, record_episode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    args = parser.parse_args()
    env = gym.make(acrobot_mj.ENV_ID, render_mode="rgb_array", width=args.width, height=args.height)
    folder = Path(tempfile.mkdtemp())
    whole, render_only, encode_only = [], [], []
    for k in range(args.repeats):
        start = time.perf_counter()
        actor = PolicyActor(make_policy("random", k))
        settings = RenderSettings(args.width, args.height, seed=k)
        record = record_episode(env, actor, folder / "episode.mp4", settings)
        whole.append(time.perf_counter() - start)
        assert record["frames"] == 1001

        env.reset(seed=k)
        policy, frames = make_policy("random", k), []
        start = time.perf_counter()
        frames.append(caption(env.render(), "t = 0.00 s"))
        for _ in range(1000):
            env.step(policy(None))
            frames.append(caption(env.render(), "t = 0.00 s"))
        render_only.append(time.perf_counter() - start)

        start = time.perf_counter()
        with VideoWriter(folder / "frames.mp4", fps=20) as writer:
            for frame in frames:
                writer.append(frame)
        encode_only.append(time.perf_counter() - start)
    env.close()
    size = os.path.getsize(folder / "episode.mp4") / 1e6
    print(
        f"GL backend: {os.environ.get('MUJOCO_GL')}, {os.cpu_count()} CPUs, "
        f"{args.width}x{args.height}, 1001 frames, median of {args.repeats}"
    )
    print(
        f"render and encode (record_episode)   {statistics.median(whole):6.2f} s   "
        f"target <= 5 s   ({size:.2f} MB)"
    )
    print(f"  step and render alone              {statistics.median(render_only):6.2f} s")
    print(f"  encode alone                       {statistics.median(encode_only):6.2f} s")


if __name__ == "__main__":
    main()
