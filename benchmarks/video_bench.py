"""Video benchmark (a run with its video should cost at most 1.5x the run without): the wall time of
the demo plan's ``execute`` and of the README's pushed closed-loop ``run``, each without a video, with its
frames rendered and encoded in the stepping process (:class:`slideplan.sim.video_frames.FrameWriter`, as
before the render process) and with today's render process (:class:`~slideplan.sim.video_frames.RenderProcess`),
all in one process, the variants interleaved, from the call to the finished file.

    python benchmarks/video_bench.py [--repeats 5] [--out docs/benchmarks/video.md]

Not a test (``make bench``).
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo is first imported

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from execute_profile import demo_plan  # noqa: E402
from plan_bench import write_report  # noqa: E402

PUSH = ("square", "crescent", (0.55, -0.08, 0.4), 1, (0.0, -0.03, 0.17, 2.0))  # the README's closed-loop run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs/benchmarks/video.md")
    args = parser.parse_args()
    from slideplan.sim import closed_loop
    from slideplan.sim.conditions import Disturbance
    from slideplan.sim import execute, replay, video, video_frames

    today = video.Recorder
    before = functools.partialmethod(today.__init__, frames=video_frames.FrameWriter)
    before = type("InProcess", (today,), {"__init__": before})
    plan = demo_plan()
    scene, obj, pose, seed, push = PUSH

    def execute_case(path):
        execute(plan, video=path)

    def run_case(path):
        closed_loop.run(scene, obj, pose, seed=seed, disturbance=Disturbance(*push), video=path)

    cases = {"execute (demo plan)": execute_case, "run (README push, closed loop)": run_case}
    variants = {"no video": (None, today), "video, in the stepping process": ("mp4", before),
                "video, render process": ("mp4", today)}
    walls = {(case, variant): [] for case in cases for variant in variants}
    with tempfile.TemporaryDirectory() as folder:
        for case, call in cases.items():
            call(None)  # warm: imports, grasp maps
            for repeat in range(args.repeats):
                for variant, (suffix, recorder) in variants.items():
                    replay.Recorder = closed_loop.Recorder = recorder
                    path = None if suffix is None else Path(folder) / f"{repeat}.{suffix}"
                    started = time.perf_counter()
                    call(path)
                    walls[(case, variant)].append(time.perf_counter() - started)
    replay.Recorder = closed_loop.Recorder = today
    lines = ["# Video benchmark: what a video costs a run",
             f"`benchmarks/video_bench.py --repeats {args.repeats}`, one process stepping (the render process and "
             "ffmpeg, encoding the MP4, are processes of their own), the variants interleaved; wall time from the "
             f"call to the finished file. Frames: 640x480, {video.VIDEO_FPS} per simulated second, x264 preset "
             f"`{video_frames.X264_PRESET}`.", "",
             "| case | variant | wall median | min | max | against no video |", "|---|---|---|---|---|---|"]
    for case in cases:
        base = float(np.median(walls[(case, "no video")]))
        for variant in variants:
            values = np.asarray(walls[(case, variant)])
            lines.append(f"| {case} | {variant} | {np.median(values):.2f} s | {values.min():.2f} s | {values.max():.2f} s "
                         f"| {np.median(values) / base:.2f}x |")
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
