"""A genuinely valid sliding plan built without the planner, for the verifier and plot tests.

On the square scene, a 10 cm x 6 cm plate lies with its right side 1 cm from the table
edge x = 0.70. The fingertip presses 1 cm deep at pitch 1.0, yaw 0, and slides 3.5 cm
along +x in 2.5 mm steps (IK waypoint by waypoint, each seeded with the previous one), so
the plate ends 2.5 cm over the edge with its centre of mass on the table. The approach
then lifts the fingertip straight up 7 cm; its last configuration is the "grasp".
"""

from __future__ import annotations

import math

import numpy as np

from slideplan import _core
from slideplan.planning import PlannerConfig, PlanResult, robot_description, robot_model
from slideplan.scenes import load_scene
from slideplan.transforms import pose_to_row

STEP_M = 0.0025  # close enough to the density bounds that skipping a waypoint breaks them
SLIDE_STEPS = 14
LIFT_STEPS = 28
DEPTH_M = 0.01
PITCH = 1.0
TABLE_EDGE_X = 0.70
THICKNESS = 0.004
START_TIP_X = 0.61


def contact_target(x: float, y: float, z: float, yaw: float = 0.0, pitch: float = PITCH) -> np.ndarray:
    """4x4 fingertip pose at (x, y, z) with the contact orientation r(yaw, pitch)."""
    target = np.eye(4)
    target[:3, :3] = _core.contact_rotation(yaw, pitch)
    target[:3, 3] = (x, y, z)
    return target


def follow(robot, targets, seed) -> np.ndarray:
    """IK for each target in turn, seeded with the previous solution (keeps the path continuous)."""
    configs = []
    for target in targets:
        config = robot.ik(target, seed=seed, rng_seed=1)
        assert config is not None, f"IK failed at {target[:3, 3]}"
        configs.append(config)
        seed = config
    return np.array(configs)


def plate_points() -> np.ndarray:
    """(N, 3) grid on a 10 cm x 6 cm plate, x in [0.59, 0.69], y in [-0.03, 0.03], at z_s."""
    xs, ys = np.meshgrid(np.linspace(0.59, 0.69, 21), np.linspace(-0.03, 0.03, 13))
    return np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, THICKNESS)])


def build_plan() -> PlanResult:
    """Return the valid hand-made plan described in the module docstring."""
    scene = load_scene("square")
    robot = robot_model(scene)
    config = PlannerConfig()
    tip_z = THICKNESS - DEPTH_M
    slide_xs = START_TIP_X + STEP_M * np.arange(SLIDE_STEPS + 1)
    elbow_up_seed = np.array([0.0, 1.0, 0.0, 1.5, 0.0, 0.5, 0.0])
    trajectory = follow(robot, [contact_target(x, 0.0, tip_z) for x in slide_xs], elbow_up_seed)
    poses = np.array([robot.fk(q) for q in trajectory])
    lift_zs = tip_z + STEP_M * np.arange(LIFT_STEPS + 1)
    approach = follow(robot, [contact_target(slide_xs[-1], 0.0, z) for z in lift_zs], trajectory[-1])
    approach[0] = trajectory[-1]  # the approach starts exactly at the goal configuration

    first, last = poses[0], poses[-1]
    yaw = math.atan2(last[1, 0], last[0, 0]) - math.atan2(first[1, 0], first[0, 0])
    rotation = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    motion_xy = last[:2, 3] - rotation @ first[:2, 3]
    points = plate_points()
    moved = points[:, :2] @ rotation.T + motion_xy
    params = {key: value for key, value in config.to_dict().items() if key not in ("planner", "seed")}
    return PlanResult(
        status="solved",
        planner="handmade",
        seed=0,
        planning_time_s=0.0,
        params=params,
        table={"polygon": np.array(scene.table.vertices), "height": 0.0},
        object={"name": "plate", "thickness": THICKNESS, "points": points, "com_xy": points[:, :2].mean(axis=0)},
        robot=robot_description(scene),
        obstacles=[],
        object_motion={"x": float(motion_xy[0]), "y": float(motion_xy[1]), "yaw": float(yaw)},
        overhang_m=float(moved[:, 0].max() - TABLE_EDGE_X),
        joint_names=list(robot.joint_names),
        start_config=trajectory[0].copy(),
        goal_config=trajectory[-1].copy(),
        trajectory=trajectory,
        fingertip_poses=np.array([pose_to_row(pose) for pose in poses]),
        grasp={
            "pose": pose_to_row(robot.link_pose(approach[-1], "t42_grasp")),
            "config": approach[-1].copy(),
            "approach": approach,
        },
        stats={"iterations": 0, "start_roots": 1, "goal_roots": 1, "pairs_checked": 1, "pairs_rejected": 0},
    )
