"""Tracking benchmark: pose error and time per frame of ``slideplan.perception.tracking``.

Rendered 320 x 240 depth frames of the square table (MuJoCo, 2 mm depth noise at 1 m, 5 % dropouts,
the camera 0.75 m above the table) with a box 6 cm above the object standing in for the hand and
finger (it hides about a third of the object). Two regimes, each object at seeded random poses:

- ``step``: the object moved by up to 5 mm and 2 degrees since the tracker last saw it (a frame every
  0.1 s of a slide at the fingertip speed cap);
- ``disturbed``: up to 3 cm and 10 degrees (the closed loop's ``--disturb`` test);
- ``arm``: the closed loop's own view: frames of the execution model (arm, hand and finger over the
  object, the closed loop's camera) at 8 waypoints along a real plan for each object at seeded poses,
  the object where Eq. 2 puts it there, tracked from a guess off by up to 5 mm and 2 degrees with the
  fingertip as the contact (as ``slideplan.sim.closed_loop`` does). Frames where the arm hides the object
  count as lost: the closed loop then goes on with Eq. 2.

Prints and writes (docs/benchmarks/tracking.md) the median and p95 of the centre-of-mass error, the
turn error and the time of ``Tracker.track`` (one core; the rendering is not timed), with the build, CPU
and date named.
Not a test: ``make bench``.

    python benchmarks/tracking_bench.py [--poses 20]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from plan_bench import write_report  # benchmarks/ is the script's directory, hence on sys.path
from slideplan import load_object, load_scene
from slideplan.perception.camera import Camera
from slideplan.sim.rendering import Box, depth_image, noisy_depth, place_objects, scene_spec
from slideplan.perception.tracking import Tracker
from slideplan.transforms import wrap_angle

OBJECTS = ("crescent", "L", "E", "triangle", "irregular")
REGIMES = {"step": (0.005, math.radians(2.0)), "disturbed": (0.03, math.radians(10.0))}


def box_frames(table, camera, rng, poses: int, reach: float, turn: float):
    """(tracker, depth, guess, contact, true motion) of the step and disturbed regimes."""
    for name in OBJECTS:
        for _ in range(poses):
            last = (rng.uniform(0.5, 0.6), rng.uniform(-0.1, 0.1), rng.uniform(-math.pi, math.pi))
            step = (*rng.uniform(-reach, reach, 2), rng.uniform(-turn, turn))
            now = tuple(a + b for a, b in zip(last, step))
            hand = [Box((now[0] + 0.02, now[1], table.height + 0.06), (0.05, 0.04, 0.03))]
            depth = noisy_depth(depth_image(scene_spec(table, place_objects([(name, now)]), hand, camera), camera),
                                0.002, 0.05, rng)
            tracker = Tracker(load_object(name, table_height=table.height, pose=last), camera, table_height=table.height)
            # The reference is the object as last seen: the motion to now turns it about the world's origin.
            yield tracker, depth, (0.0, 0.0, 0.0), None, _motion_between(last, now)


def _motion_between(first, second) -> tuple[float, float, float]:
    """The planar motion taking an outline at pose ``first`` to pose ``second``."""
    turn = second[2] - first[2]
    cos, sin = math.cos(turn), math.sin(turn)
    return (second[0] - (cos * first[0] - sin * first[1]), second[1] - (sin * first[0] + cos * first[1]), turn)


def arm_frames(rng, poses: int):
    """(tracker, depth, guess, contact, true motion) of the arm regime: the execution model along plans."""
    import mujoco

    from slideplan import PlannerConfig, plan
    from slideplan.sim.closed_loop import default_camera
    from slideplan.sim import ExecutionSettings
    from slideplan.sim.model import DEPTH_CAMERA, build_model
    from slideplan.world.objects import load_outline, sample_pose_on_table
    from slideplan.sim.rendering import camera_depth
    from slideplan.transforms import row_to_pose
    from slideplan.transforms import planar_motion

    scene = load_scene("square")
    camera = default_camera(scene)
    for name in OBJECTS:
        for _ in range(poses):
            pose = sample_pose_on_table(load_outline(name)[0], scene.table, rng)
            obj = load_object(name, table_height=scene.table.height, pose=pose)
            result = plan(scene, obj, PlannerConfig.for_scene(scene, seed=int(rng.integers(1 << 31))))
            if not result.solved:
                continue
            built = build_model(result, ExecutionSettings(), camera=camera)
            tracker = Tracker(obj, camera, table_height=scene.table.height)
            address = built.model.jnt_qposadr[built.model.body_jntadr[built.object_body]]
            with mujoco.Renderer(built.model, camera.height, camera.width) as renderer:
                renderer.enable_depth_rendering()
                for k in np.linspace(0, len(result.trajectory) - 1, 8).round().astype(int):
                    tip = row_to_pose(result.fingertip_poses[k])
                    motion = planar_motion(row_to_pose(result.fingertip_poses[0]), tip)
                    built.data.qpos[built.arm_qpos] = result.trajectory[k]
                    built.data.qpos[address:address + 2] = obj.moved(motion).centroid_xy
                    built.data.qpos[address + 3:address + 7] = [math.cos(motion[2] / 2), 0, 0, math.sin(motion[2] / 2)]
                    mujoco.mj_forward(built.model, built.data)
                    depth = noisy_depth(camera_depth(renderer, built.model, built.data, DEPTH_CAMERA), 0.002, 0.05, rng)
                    off = (*rng.uniform(-0.005, 0.005, 2), rng.uniform(-math.radians(2.0), math.radians(2.0)))
                    guess = tuple(a + b for a, b in zip(motion, off))
                    yield tracker, depth, guess, tip[:2, 3], tuple(float(value) for value in motion)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=20, help="seeded poses per object and regime")
    parser.add_argument("--arm-poses", type=int, default=4, help="seeded poses per object in the arm regime (8 frames each)")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks/tracking.md"))
    args = parser.parse_args()
    table = load_scene("square").table
    centre = table.polygon.centroid
    camera = Camera((centre.x - 0.15, centre.y, table.height + 0.75), (centre.x, centre.y, table.height))
    rows = []
    for regime in (*REGIMES, "arm"):
        rng = np.random.default_rng(len(rows))
        frames = arm_frames(rng, args.arm_poses) if regime == "arm" else box_frames(table, camera, rng, args.poses, *REGIMES[regime])
        errors, times, lost = [], [], 0
        for tracker, depth, guess, contact, truth in frames:
            tracker.track(depth, guess, contact)  # warm: the first call imports SciPy's modules
            started = time.perf_counter()
            estimate = tracker.track(depth, guess, contact)
            times.append(time.perf_counter() - started)
            if not estimate.ok:
                lost += 1
                continue
            moved = tracker.obj.moved(estimate.motion)
            errors.append((np.linalg.norm(moved.centroid_xy - tracker.obj.moved(truth).centroid_xy),
                           abs(wrap_angle(estimate.motion[2] - truth[2]))))
        errors, times = np.array(errors), np.array(times)
        rows.append(f"| {regime} | {len(times)} | {lost} | {1000 * np.median(errors[:, 0]):.2f} | {1000 * np.percentile(errors[:, 0], 95):.2f} "
                    f"| {np.degrees(np.median(errors[:, 1])):.2f} | {np.degrees(np.percentile(errors[:, 1], 95)):.2f} "
                    f"| {1000 * np.median(times):.1f} | {1000 * np.percentile(times, 95):.1f} |")
    lines = [
        "# Tracking the object in depth frames",
        "",
        f"`python benchmarks/tracking_bench.py --poses {args.poses} --arm-poses {args.arm_poses}`: "
        f"{len(OBJECTS)} objects ({', '.join(OBJECTS)}), 320 x 240 frames. step and "
        f"disturbed: {args.poses} seeded poses per object, a box 6 cm above each object hiding about a third of it; "
        f"arm: {args.arm_poses} seeded poses per object, 8 frames along its plan with the arm in view (the module "
        "docstring). Errors: the centre of mass (mm) and the turn (deg) against the truth, of the frames not lost; "
        "time: one `Tracker.track` call (rendering not included).",
        "",
        "| regime | frames | lost | CoM median | CoM p95 | turn median | turn p95 | ms median | ms p95 |",
        "|---|---|---|---|---|---|---|---|---|",
        *rows,
    ]
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
