"""docs/figures/demos-front.png: what a dataset's (and the environment's) ``front`` camera shows of one
demonstration at 256 x 256, a frame from the middle of each of its slide, approach, grasp and lift.

    MUJOCO_GL=egl python benchmarks/front_camera_figure.py [--scene square] [--out docs/figures/demos-front.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from PIL import Image

from slideplan.demos.draw import draw, episode_seed
from slideplan.demos.frames import PHASES, CameraSpec, Frames
from slideplan.demos.generate import Request, front_points
from slideplan.experiments.tasks import cached_scene
from slideplan.sim.closed_loop import run

SHOWN = ("slide", "approach", "grasp", "lift")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="square")
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent.parent / "docs" / "figures" / "demos-front.png"))
    args = parser.parse_args()
    scene = cached_scene(args.scene)
    drawn = draw(scene, Request.objects, "nominal", episode_seed(5, 0))  # docs/demos.md's first command's first episode
    taken = {}

    def observe(plan, built, runner, robot):
        taken["frames"] = Frames(built, runner, robot, 10, (CameraSpec("front", 256, 256),), front_points(scene))
        return taken["frames"].after_step

    report = run(scene, drawn.object, drawn.pose, seed=drawn.seed, closed=True, observe=observe)
    rows = taken["frames"].rows
    tiles = []
    for name in SHOWN:
        phase = [index for index, row in enumerate(rows) if row["phase"] == PHASES.index(name)]
        tiles.append(rows[phase[len(phase) // 2]]["front"])
    Image.fromarray(np.hstack(tiles)).save(args.out)
    print(f"wrote {args.out} (the episode {'succeeded' if report.success else 'failed'})")


if __name__ == "__main__":
    main()
