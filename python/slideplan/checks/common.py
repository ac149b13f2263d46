"""What every check of a plan shares (:func:`slideplan.checks.verify.verify` and the grasp's checks,
:mod:`slideplan.checks.grasp`): the tolerances, the plan's world rebuilt from its data, and the joint-limit,
collision and step-density violations."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..world.geometry import SupportSurface
from ..plan.result import PlanResult
from ..transforms import rotation_angle_between

POSE_TOLERANCE = 1e-6  # m and rad: recorded poses must be the forward kinematics (JSON keeps floats exact)
DEPTH_TOLERANCE_M = 1e-3  # contact depth band slack (the planner projects to 1e-4)
ANGLE_TOLERANCE_RAD = 1e-3  # pitch band slack and largest allowed roll
STEP_SLACK = 1e-9  # rounding slack on the joint and fingertip step bounds
MOTION_TOLERANCE = 1e-6  # object motion and overhang against their recomputed values (m, rad)
LIFT_SLACK_M = 1e-3  # the approach switches to free-mode checks once the fingertip is this close to the lift height
GRASP_TOLERANCE_M = 1e-4  # the grasp frame against H_g recomputed from the cloud (the planner computes it from the same points)
GRASP_ANGLE_TOLERANCE_RAD = 1e-4
CONTACT_SLACK_M = 1e-3  # the first contact against contact_radius (IK lands within this of its target)
SPACING_SAMPLE = 2000  # points whose nearest neighbours give a cloud's point spacing (Eq. 3's tolerance)
TIMING_SLACK = 1e-6  # relative slack on the timing limits (the parameterization slows to meet them exactly)


@dataclass
class PlanWorld:
    """What the checks share: the robot, the table and the collision world, rebuilt from the plan."""

    robot: object
    collision_world: object
    table: SupportSurface
    object_top_z: float  # z_s = table height + object thickness
    approach_tips: np.ndarray  # (K, 3) fingertip positions along grasp.approach, by forward kinematics


def pose_mismatch(computed: np.ndarray, recorded: np.ndarray) -> str:
    """Describe how far two 4x4 poses differ, or return "" when within POSE_TOLERANCE."""
    position_error = float(np.linalg.norm(computed[:3, 3] - recorded[:3, 3]))
    angle_error = rotation_angle_between(computed, recorded)
    if position_error > POSE_TOLERANCE or angle_error > POSE_TOLERANCE:
        return f"{position_error:.3g} m and {angle_error:.3g} rad"
    return ""


def plan_world(result: PlanResult, collisions: bool = True) -> PlanWorld:
    """Load the plan's robot and build its table and, with ``collisions``, its collision world (sliding:
    no object)."""
    robot = result.robot_model()  # the parsed URDF, shared (immutable): a mesh robot takes 0.5 s to parse
    polygon = np.asarray(result.table["polygon"], dtype=float)
    height = float(result.table["height"])
    collision_world = result.collision_world() if collisions else None
    return PlanWorld(
        robot=robot,
        collision_world=collision_world,
        table=SupportSurface.from_vertices(polygon, height, field="table.polygon"),
        object_top_z=height + float(result.object["thickness"]),
        approach_tips=np.array([np.asarray(robot.fk(q))[:3, 3] for q in np.asarray(result.grasp["approach"])]).reshape(-1, 3),
    )


def joint_limit_violations(name: str, config: np.ndarray, robot) -> list[str]:
    """One violation per joint of ``config`` outside the robot's limits."""
    lower, upper = np.asarray(robot.lower_limits), np.asarray(robot.upper_limits)
    return [
        f"{name}: joint {joint} = {config[joint]:.6g} rad outside its limits [{lower[joint]:.6f}, {upper[joint]:.6f}]"
        for joint in np.flatnonzero((config < lower - STEP_SLACK) | (config > upper + STEP_SLACK))
    ]


def collision_violation(name: str, config: np.ndarray, collision_world, mode) -> list[str]:
    """A violation naming the colliding pairs if ``config`` collides in ``mode``."""
    if collision_world.is_valid(config, mode):
        return []
    pairs = ", ".join(f"{link}-{other}" for link, other in collision_world.collisions(config, mode))
    return [f"{name}: collision in {mode.name.lower()} mode ({pairs})"]


def density_violations(name: str, path: np.ndarray, max_joint_step: float, tip_positions=None, max_tip_step=None) -> list[str]:
    """Violations of the step bounds between consecutive waypoints of ``path`` (named ``name``)."""
    violations = []
    joint_steps = np.max(np.abs(np.diff(path, axis=0)), axis=1) if len(path) > 1 else np.zeros(0)
    for index in np.flatnonzero(joint_steps > max_joint_step + STEP_SLACK):
        violations.append(
            f"{name}[{index}]->[{index + 1}]: a joint moves {joint_steps[index]:.6g} rad > max_joint_step {max_joint_step}"
        )
    if tip_positions is not None:
        tip_steps = np.linalg.norm(np.diff(tip_positions, axis=0), axis=1)
        for index in np.flatnonzero(tip_steps > max_tip_step + STEP_SLACK):
            violations.append(
                f"{name}[{index}]->[{index + 1}]: fingertip moves {tip_steps[index]:.6g} m > max_tip_step {max_tip_step}"
            )
    return violations
