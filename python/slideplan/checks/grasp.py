"""The grasp's checks (paper IV-C.1 and beyond): the recorded grasp frame against ``H_g`` recomputed from
the object's points, the hold (``grasp_hold``) and the approach from the slide's goal to the grasp,
dense and free of collisions."""

from __future__ import annotations


import numpy as np
import shapely
from shapely.geometry import MultiPoint

from .common import (
    GRASP_ANGLE_TOLERANCE_RAD,
    GRASP_TOLERANCE_M,
    LIFT_SLACK_M,
    PlanWorld,
    collision_violation,
    density_violations,
    joint_limit_violations,
    pose_mismatch,
)
from ..world.geometry import overhang
from ..plan.result import PlanResult
from ..transforms import rotation_vector, row_to_pose


def _holding_shift(reached: np.ndarray, hold: float) -> float | None:
    """``grasp_hold``: how far along the edge from the paper's ``H_g`` the nearest strip ``hold`` wide lies
    in which the object extends ``hold`` along the approach; None if none does.

    Args:
        reached: (N, 2) the overhanging points within the fingers' reach, as (along the edge from ``H_g``,
            beyond it along the outward normal).
        hold: ``grasp_hold`` (m).
    """
    def holds(shift: float) -> bool:
        strip = reached[np.abs(reached[:, 0] - shift) <= 0.5 * hold, 1]
        return strip.size > 0 and float(strip.max() - strip.min()) >= hold

    if holds(0.0):
        return 0.0
    return next((float(shift) for shift in sorted(reached[:, 0], key=lambda value: (abs(value), value)) if holds(shift)), None)


def check_grasp_pose(result: PlanResult, world: PlanWorld,
                     tolerance: tuple[float, float] = (GRASP_TOLERANCE_M, GRASP_ANGLE_TOLERANCE_RAD)) -> list[str]:
    """Check the grasp frame against ``H_g`` of IV-C.1, recomputed from the object's points at their
    final pose: at the centroid of ``P_out`` (moved outward along the closest edge's normal until it is
    ``grasp_standoff`` beyond the edge, then along the edge to the nearest place where the fingers close
    on ``grasp_hold`` of the object), at mid-thickness, approaching perpendicular to that edge in
    the table plane, the fingers closing vertically (``y`` up; down too when ``grasp_flip``).

    Returns:
        Violations naming ``grasp.pose`` and the numbers.
    """
    moved = result.moved_object_xy()
    _, outside, edge = overhang(world.table, moved)
    if edge is None:
        return []  # check_graspability reports it
    start, normal = edge
    centroid = moved[outside].mean(axis=0)
    beyond = float((centroid - start) @ normal)
    standoff, hold = result.params.get("grasp_standoff", 0.0), result.params.get("grasp_hold", 0.0)
    xy = centroid + (max(beyond, standoff) - beyond) * normal
    where = "the centroid of the overhanging points (IV-C.1)"
    if hold > 0.0:
        along = np.array([-normal[1], normal[0]])
        relative = moved[outside] - xy
        reached = np.column_stack([relative @ along, relative @ normal])
        shift = _holding_shift(reached[reached[:, 1] >= -max(standoff, hold)], hold)
        if shift is None:
            return [f"grasp.pose: no place along the table edge puts grasp_hold = {hold} m of the object between "
                    f"the fingers, yet the plan grasps it"]
        xy = xy + shift * along
        if shift != 0.0:
            where = f"the centroid of the overhanging points (IV-C.1) moved {shift:+.4f} m along the edge onto the object"
    expected = np.array([*xy, float(result.table["height"]) + 0.5 * float(result.object["thickness"])])
    pose = row_to_pose(result.grasp["pose"])
    violations = check_hold(result, xy, float((xy - start) @ normal), normal)
    offset = float(np.linalg.norm(pose[:3, 3] - expected))
    if offset > tolerance[0]:
        violations.append(f"grasp.pose: {offset:.4f} m from H_g at ({expected[0]:.4f}, {expected[1]:.4f}, "
                          f"{expected[2]:.4f}), {where}")
    # H_g's orientation (x along the edge, y up: the closing axis, z the approach), or rolled by pi about
    # z (grasp_flip); the hand may turn from it within the tolerated rotation about these axes, as the
    # planner's grasp IK allows (a dead zone on each component of the rotation between the two).
    approach = np.array([-normal[0], -normal[1], 0.0])
    nominal = np.column_stack([np.cross([0.0, 0.0, 1.0], approach), [0.0, 0.0, 1.0], approach])
    frames = [nominal] + ([nominal @ np.diag([-1.0, -1.0, 1.0])] if result.params.get("grasp_flip", True) else [])
    allowed = np.array([result.params.get(f"grasp_{axis}_tolerance", 0.0) for axis in ("tilt", "yaw", "roll")])
    turns = [rotation_vector(frame.T @ pose[:3, :3]) for frame in frames]
    turn = min(turns, key=lambda rotation: float(np.max(np.abs(rotation) - allowed)))
    if np.any(np.abs(turn) > allowed + tolerance[1]):
        violations.append(f"grasp.pose: turned ({turn[0]:.4f}, {turn[1]:.4f}, {turn[2]:.4f}) rad from H_g about its x "
                          f"(along the edge), y (up) and z (the approach), beyond the tolerated "
                          f"({allowed[0]:g}, {allowed[1]:g}, {allowed[2]:g})"
                          + (" (or rolled by pi: grasp_flip)" if len(frames) > 1 else ""))
    return violations


def check_hold(result: PlanResult, grasp_xy: np.ndarray, beyond: float, outward: np.ndarray) -> list[str]:
    """With ``grasp_model``: the hand closed at ``H_g`` holds the object up (cpp/include/slideplan/hold_model.hpp),
    judged where the object lay (``H_g`` and the edge's normal moved back by the object's motion: the plate's
    material is then the planner's to the last bit).

    Args:
        result: the plan.
        grasp_xy: ``H_g`` in the table plane, at the object's final pose.
        beyond: how far ``H_g`` lies beyond the closest table edge (m).
        outward: that edge's outward normal.

    Returns:
        A violation naming ``grasp.pose`` with gravity's moment and what the pads resist, or none.
    """
    from .. import _core
    from ..plan.config import PARAMETERS, PlannerConfig

    if not result.params.get("grasp_model", False):
        return []  # off, or a plan from before the model
    motion = result.object_motion
    yaw = float(motion["yaw"])
    back = np.array([[np.cos(yaw), np.sin(yaw)], [-np.sin(yaw), np.cos(yaw)]])  # R(yaw)^T
    params = PlannerConfig(**{name: result.params[name] for name in PARAMETERS if name in result.params}).to_params()
    hold = _core.estimate_hold(np.ascontiguousarray(np.asarray(result.object["points"], dtype=float)[:, :2]),
                               np.asarray(result.object["com_xy"], dtype=float), float(result.object["thickness"]),
                               back @ (grasp_xy - np.array([motion["x"], motion["y"]])), beyond, back @ outward, params)
    if hold["demand"] <= hold["capacity"] * (1.0 + 1e-6):
        return []
    return [f"grasp.pose: the closed hand would not hold the object up (grasp_model): gravity's moment "
            f"{hold['demand']:.5f} N m about the pads exceeds the {hold['capacity']:.5f} N m they resist "
            f"({1000 * hold['lever']:.1f} mm lever, {1000 * hold['patch_length']:.1f} mm of patch along it)"]


def check_grasp(result: PlanResult, world: PlanWorld) -> list[str]:
    """Check the grasp and the approach motion to it.

    The grasp link's forward kinematics at ``grasp.config`` must equal ``grasp.pose``; the
    approach must start at the goal configuration, end at the grasp configuration, respect
    the joint limits, ``max_joint_step`` and ``max_tip_step``, and be collision-free against the
    object at its final pose: in sliding mode (the contact links may touch) while the fingertip
    lifts off, until it first reaches ``z_s + grasp_lift``, then in free mode with the hand's full
    collision model, down to the grasp.

    Args:
        result: the plan (array shapes already checked).
        world: the rebuilt robot, table and collision world (its object is set and cleared here).

    Returns:
        Violations naming ``grasp`` or ``approach[i]``.
    """
    from .. import _core

    violations = []
    config = np.asarray(result.grasp["config"])
    approach = np.asarray(result.grasp["approach"])
    grasp_link = result.robot["grasp_link"]
    pose = np.asarray(world.robot.frame_pose(config, grasp_link, np.asarray(result.robot["grasp_offset"])))
    mismatch = pose_mismatch(pose, row_to_pose(result.grasp["pose"]))
    if mismatch:
        violations.append(f"grasp.pose: forward kinematics of {grasp_link} at grasp.config differs by {mismatch}")
    violations += joint_limit_violations("grasp.config", config, world.robot)
    tips = world.approach_tips
    violations += density_violations("approach", approach, result.params["max_joint_step"], tips, result.params["max_tip_step"])
    reached = np.flatnonzero(tips[:, 2] >= world.object_top_z + result.params["grasp_lift"] - LIFT_SLACK_M)
    lift_end = int(reached[0]) if reached.size else len(approach)  # from here on the hand is free of the object
    collision_world = world.collision_world
    hull = MultiPoint(result.moved_object_xy()).convex_hull
    collision_world.set_object(shapely.get_coordinates(hull.exterior)[:-1], world.object_top_z)
    try:
        for index, waypoint in enumerate(approach):
            violations += joint_limit_violations(f"approach[{index}]", waypoint, world.robot)
            mode = _core.ContactMode.SLIDING if index < lift_end else _core.ContactMode.FREE
            violations += collision_violation(f"approach[{index}]", waypoint, collision_world, mode)
    finally:
        collision_world.clear_object()
    if lift_end == len(approach):
        violations.append(f"grasp.approach: the fingertip never rises to grasp_lift ({result.params['grasp_lift']} m) "
                          "above the object before the grasp")
    return violations
