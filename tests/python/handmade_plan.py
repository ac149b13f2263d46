"""Sliding plans built without the planner, for the verifier, plot, timing and execution tests.

:func:`build_grasp_plan` is a genuinely valid plan, grasp included. :func:`build_plan` has a valid
slide but no grasp: on the square scene, a 10 cm x 6 cm plate lies with its right side 1 cm from the
table edge x = 0.70. The fingertip presses 1 cm deep at pitch 1.0, yaw 0, and slides 3.5 cm along +x
in 2.5 mm steps (IK waypoint by waypoint, each seeded with the previous one), so the plate ends 2.5 cm
over the edge with its centre of mass on the table. The approach then lifts the fingertip straight up
7 cm and calls its last configuration the "grasp": the far edge admits no side grasp for this arm, so
the verifier rejects it (the grasp frame is far from H_g); its corruptions still name their own checks.
"""

from __future__ import annotations

import math

import numpy as np

from slideplan import _core
from slideplan.world.geometry import area_centroid
from slideplan.plan.config import PlannerConfig
from slideplan.plan.robot import robot_description, robot_model
from slideplan.plan.result import PlanResult
from slideplan.world.scenes import load_scene
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


def dense_motion(robot, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """The straight joint-space motion start -> end (end included, start not), dense as the planner's
    approach: every joint within 0.02 rad and the fingertip within 1 cm between waypoints."""
    steps = max(1, int(np.ceil(np.abs(end - start).max() / 0.02)))
    while True:
        motion = np.linspace(start, end, steps + 1)
        tips = np.array([robot.fk(q)[:3, 3] for q in motion])
        if np.linalg.norm(np.diff(tips, axis=0), axis=1).max() <= 0.01:
            return motion[1:]
        steps *= 2


def plate_points() -> np.ndarray:
    """(N, 3) grid on a 10 cm x 6 cm plate, x in [0.59, 0.69], y in [-0.03, 0.03], at z_s."""
    xs, ys = np.meshgrid(np.linspace(0.59, 0.69, 21), np.linspace(-0.03, 0.03, 13))
    return np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, THICKNESS)])


def build_plan() -> PlanResult:
    """Return the valid hand-made plan described in the module docstring."""
    scene = load_scene("square")
    robot = robot_model(scene)
    config = PlannerConfig().resolved()
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
        object={"name": "plate", "thickness": THICKNESS, "points": points, "com_xy": area_centroid(points[:, :2])},
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


GRASP_PLATE = (0.52, 0.58, 0.05, 0.25)  # x0, x1, y0, y1: 5 cm over the table edge y = 0.20
GRASP_Y = 0.235  # fingertips (2.3 cm ahead of the grasp frame) end 1.2 cm beyond the edge
GRASP_BACKOFF = 0.045  # the open fingers clear the plate's far end (reach ends near y = 0.28)
FINGER_REACH = 0.025  # the T42's fingertips end 2.3 cm ahead of its grasp frame, plus 2 mm
GRASP_TABLE_EDGE_Y = 0.20


def _grasp_frame(x: float, y: float, z: float) -> np.ndarray:
    """Side grasp at (x, y, z) approached along -y (from outside the edge y = 0.20): y_H up, x_H = +x."""
    frame = np.eye(4)
    frame[:3, :3] = np.column_stack([(1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)])
    frame[:3, 3] = (x, y, z)
    return frame


def build_grasp_plan(grasp_y: float = GRASP_Y, slide_steps: int = 4) -> PlanResult:
    """A valid plan whose object overhangs far enough for a firm side grasp, grasped at H_g.

    A 6 cm x 20 cm plate lies 5 cm over the table edge y = 0.20 (centre of mass 5 cm inside). The
    fingertip slides it ``slide_steps`` x 2.5 mm along +x (as in :func:`build_plan`); the approach lifts the
    fingertip 20 cm, swings in joint space to 20 cm above a pre-grasp beyond the plate's far end, comes
    down to it and moves in along -y to the side grasp (default 3.5 cm out), whose fingertips then end
    1.2 cm beyond the table edge. With ``grasp_y`` < 0.223 the fingertips reach over the table instead.
    The grasp frame is H_g of IV-C.1 for ``grasp_standoff = grasp_y - 0.20``: at the centroid of the
    overhanging points (x), moved out to the standoff (y), mid-thickness, approaching along -y.

    Args:
        grasp_y: y of the grasp frame (m); the pre-grasp backs off far enough that the open
            fingers clear the plate's far end.
        slide_steps: slide steps of 2.5 mm.
    """
    scene = load_scene("square")
    robot = robot_model(scene)
    x0, x1, y0, y1 = GRASP_PLATE
    xs, ys = np.meshgrid(np.linspace(x0, x1, 13), np.linspace(y0, y1, 41))
    points = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, THICKNESS)])
    tip_z = THICKNESS - DEPTH_M
    slide_xs = 0.535 + STEP_M * np.arange(slide_steps + 1)
    trajectory = follow(robot, [contact_target(x, 0.12, tip_z) for x in slide_xs], np.array([0.0, 1.0, 0.0, 1.5, 0.0, 0.5, 0.0]))
    poses = np.array([robot.fk(q) for q in trajectory])
    lift = follow(robot, [contact_target(slide_xs[-1], 0.12, tip_z + STEP_M * k) for k in range(1, 81)], trajectory[-1])
    backoff = max(GRASP_BACKOFF, y1 + FINGER_REACH - grasp_y)
    grasp_x = (x0 + x1) / 2 + slide_xs[-1] - slide_xs[0]
    candidates = [robot.ik(_grasp_frame(grasp_x, grasp_y, THICKNESS / 2), seed=None, rng_seed=seed, link="t42_grasp") for seed in range(8)]
    grasp = min((q for q in candidates if q is not None), key=lambda q: np.abs(q - lift[-1]).max())
    outward = [grasp]  # backing out from the grasp, each IK seeded with the previous one
    for k in range(1, 7):
        outward.append(robot.ik(_grasp_frame(grasp_x, grasp_y + backoff * k / 6, THICKNESS / 2), seed=outward[-1], rng_seed=1, link="t42_grasp"))
        assert outward[-1] is not None, f"grasp approach IK failed {k} cm out"
    upward = [outward[-1]]  # above the pre-grasp, so that the swing passes high over the plate
    for k in range(1, 21):
        upward.append(robot.ik(_grasp_frame(grasp_x, grasp_y + backoff, THICKNESS / 2 + 0.01 * k), seed=upward[-1], rng_seed=1, link="t42_grasp"))
        assert upward[-1] is not None, f"pre-grasp IK failed {k} cm up"
    waypoints = np.vstack([trajectory[-1:], lift, upward[::-1], outward[-2::-1]])
    approach = np.vstack([trajectory[-1:]] + [dense_motion(robot, a, b) for a, b in zip(waypoints[:-1], waypoints[1:])])
    motion_x = float(slide_xs[-1] - slide_xs[0])
    moved = points[:, :2] + (motion_x, 0.0)
    # Pressed 3.4 cm from the centre of mass: a hand-made slide, not drawn within contact_radius.
    config = PlannerConfig(grasp_standoff=max(0.0, grasp_y - GRASP_TABLE_EDGE_Y), contact_radius=0.0).resolved()
    params = {key: value for key, value in config.to_dict().items() if key not in ("planner", "seed")}
    return PlanResult(
        status="solved",
        planner="handmade",
        seed=0,
        planning_time_s=0.0,
        params=params,
        table={"polygon": np.array(scene.table.vertices), "height": 0.0},
        object={"name": "long plate", "thickness": THICKNESS, "points": points, "com_xy": area_centroid(points[:, :2])},
        robot=robot_description(scene),
        obstacles=[],
        object_motion={"x": motion_x, "y": 0.0, "yaw": 0.0},
        overhang_m=float(moved[:, 1].max() - GRASP_TABLE_EDGE_Y),
        joint_names=list(robot.joint_names),
        start_config=trajectory[0].copy(),
        goal_config=trajectory[-1].copy(),
        trajectory=trajectory,
        fingertip_poses=np.array([pose_to_row(pose) for pose in poses]),
        grasp={"pose": pose_to_row(_grasp_frame(grasp_x, grasp_y, THICKNESS / 2)), "config": approach[-1].copy(), "approach": approach},
        stats={"iterations": 0, "start_roots": 1, "goal_roots": 1, "pairs_checked": 1, "pairs_rejected": 0},
    )
