"""A second check of a plan, from the plan data alone (not independent of the planner: see below).

:func:`verify` recomputes, from the fields of a :class:`~slideplan.plan.result.PlanResult`
(robot URDF and mount, table, object cloud, configurations), everything the plan claims:
the contact constraint at every waypoint (docs/design.md 3, paper IV-C.3), the path density,
the object motion of Eq. 2, the graspability of the final object pose (paper IV-C.1) and
the approach to the grasp.
The grasp's checks live in :mod:`slideplan.checks.grasp`; what every check shares (the tolerances, the
plan's world rebuilt from its data) in :mod:`slideplan.checks.common`.

It is not independent of the planner's code. It shares with the planner:

- the C++ core's robot model (``_core.RobotModel``, loaded through ``slideplan.plan.robot.plan_robot``
  by :meth:`PlanResult.robot_model`): the URDF parse, the forward kinematics (``fk``,
  ``frame_pose``), the joint names and limits;
- the core's FCL collision world (``_core.CollisionWorld`` with ``_core.SupportSurface`` and
  ``_core.ContactMode``): the links' collision shapes, which links may touch while sliding,
  and the object prism it sets;
- the one collision-world builder (``slideplan.plan.robot.collision_world``: the plan's obstacles as the core's) and
  ``scenes.obstacle_footprint`` (their footprints);
- the data layer: ``geometry.SupportSurface`` (the table polygon: ``contains``,
  ``edge_margin``), ``geometry.Ending`` (the one "ends graspable" comparison, given the verifier's
  tolerances), ``geometry.area_centroid`` (the core's ``_core.area_centroid``, the one
  centre-of-mass computation the planner uses too), ``transforms`` and ``timing.NEAR_TABLE_M``.

A bug in any of these can pass both the planner and the verifier. What it computes on its own,
from the plan's numbers: the contact depth and angle bands, the density bounds, Eq. 2's motion,
the overhang and the centre-of-mass margins, ``H_g`` (with ``grasp_hold``) and the grasp frame's
turn, and the timing limits; it calls none of the planner's search, projection, IK or
validators.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import MultiPoint

from .common import (
    ANGLE_TOLERANCE_RAD,
    CONTACT_SLACK_M,
    DEPTH_TOLERANCE_M,
    GRASP_ANGLE_TOLERANCE_RAD,
    GRASP_TOLERANCE_M,
    MOTION_TOLERANCE,
    PlanWorld,
    SPACING_SAMPLE,
    STEP_SLACK,
    TIMING_SLACK,
    collision_violation,
    density_violations,
    joint_limit_violations,
    plan_world,
    pose_mismatch,
)
from ..errors import InputError, require_type
from ..world.geometry import Ending, SupportSurface, area_centroid, overhang, support_margin
from .grasp import check_grasp, check_grasp_pose
from ..plan.result import PlanResult
from ..plan.schema import check_ends, check_shapes
from ..world.scenes import obstacle_footprint
from ..transforms import contact_angles, move_planar, planar_motion, row_to_pose, wrap_angle


@dataclass
class Verification:
    """The verdict of :func:`verify`.

    Attributes:
        violations: one line per problem, naming the waypoint (e.g. ``trajectory[12]``) or
            the field and the numbers that are wrong; empty for a valid plan.
    """

    violations: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True if no violation was found."""
        return not self.violations

    def __str__(self) -> str:
        return "ok" if self.ok else f"{len(self.violations)} violations:\n" + "\n".join(self.violations)


def verify(result: PlanResult, *, grasp_tolerance: tuple[float, float] = (GRASP_TOLERANCE_M, GRASP_ANGLE_TOLERANCE_RAD),
           given_start: bool = False) -> Verification:
    """Re-check every claim of a solved plan from its data.

    Checks: consistent array shapes; at every trajectory waypoint, that the forward
    kinematics reproduces the recorded fingertip pose, the contact depth ``z_s - z_F`` lies
    in ``[dz_min, dz_max]`` (+- 1 mm), the pitch in ``beta0 +- delta_beta`` and the roll is 0
    (+- 1 mrad), the fingertip is over the table, the joints are within limits and the arm
    is collision-free (sliding mode); the density bounds between waypoints; Eq. 2 (the
    recorded object motion is the planar motion of the fingertip from first to last
    waypoint); the final object pose (overhang ``u >= u*`` and equal to the recorded one,
    centre of mass on the table, and with ``com_supported`` at every waypoint); and the grasp
    (its recorded pose is the forward kinematics of the grasp link, the approach runs densely
    and without collision from the goal to the grasp configuration).

    Args:
        result: the plan.
        grasp_tolerance: (m, rad) the grasp frame may lie off ``H_g`` recomputed from the plan's own
            points; wider only to judge a plan against geometry other than what it was planned on
            (e.g. ground truth behind a perceived cloud).
        given_start: the plan was made from a given start configuration (``plan(..., start_config=q)``: a
            re-plan from where the finger is), so its first contact was not drawn from Eq. 3's region and
            ``contact_radius`` does not bound it (the plan file does not record this).

    Returns:
        The verification; ``ok`` is False for any plan that is not solved.
    """
    require_type(result, PlanResult, "result", "a PlanResult (from plan or PlanResult.load)")
    if result.status not in ("solved", "invalid"):
        return Verification([f"status is {result.status!r}: there is no plan to verify"])
    violations = check_shapes(result)
    if violations:
        return Verification(violations)  # the remaining checks index into the arrays
    violations = check_names(result, result.robot_model())
    if violations:
        return Verification(violations)  # the remaining checks look these up
    world = plan_world(result)
    violations = check_ends(result)
    violations += check_sliding_path(result, world)
    violations += check_object_motion(result)
    violations += check_turning(result, given_start)
    violations += check_clutter(result, world)
    violations += check_graspability(result, world.table)
    violations += check_support(result, world.table)
    violations += check_grasp_pose(result, world, grasp_tolerance)
    violations += check_grasp(result, world)
    violations += check_timing(result, world)
    return Verification(violations)


def check_motion(result: PlanResult) -> list[str]:
    """What a controller needs of a plan before it moves the arm, without the geometry (cheap): the
    robot's names (:func:`check_names`), the shapes, every waypoint of the slide and the approach within the joint limits, consecutive waypoints
    within ``max_joint_step``, and the timing block within its limits (:func:`verify` checks all this
    and the rest).

    Returns:
        Violations; for a plan that is not solved only the robot's names (there is nothing to move).
    """
    require_type(result, PlanResult, "result", "a PlanResult (from plan or PlanResult.load)")
    robot = result.robot_model()
    violations = check_names(result, robot)
    if violations or result.status not in ("solved", "invalid"):
        return violations
    violations = check_shapes(result)
    if violations:
        return violations
    violations = check_ends(result)
    world = plan_world(result, collisions=False)
    for name, path in (("trajectory", np.asarray(result.trajectory)), ("grasp.approach", np.asarray(result.grasp["approach"]))):
        for index, config in enumerate(path):
            violations += joint_limit_violations(f"{name}[{index}]", config, world.robot)
        violations += density_violations(name, path, result.params["max_joint_step"])
    return violations + check_timing(result, world)


def require_motion(result: PlanResult) -> None:
    """Refuse a plan that :func:`check_motion` finds fault with (``export``, ``execute`` and ``view`` run
    it on every plan they read: a joint jump or a velocity of 1e6 was once exported and executed, and an
    unknown grasp link a traceback in ``view``).

    Raises:
        InputError: the first violations and how many there are, naming the plan's field.
    """
    violations = check_motion(result)
    if violations:
        more = f" (and {len(violations) - 3} more)" if len(violations) > 3 else ""
        field = violations[0].split(":")[0].split("[")[0].split("->")[0]
        raise InputError("the plan cannot be run: " + "; ".join(violations[:3]) + more, field=field)


def check_names(result: PlanResult, robot) -> list[str]:
    """Check that the links and joints the plan names are the robot's: its joints are the chain's, in
    order, and the grasp and contact links are links of the URDF (the tip link the core checks)."""
    violations = []
    if list(result.joint_names) != list(robot.joint_names):
        violations.append(f"joint_names: {list(result.joint_names)} are not the chain's joints {list(robot.joint_names)}")
    links = set(robot.link_names)
    for name, named in (("robot.grasp_link", [result.robot["grasp_link"]]), ("robot.contact_links", result.robot["contact_links"])):
        violations += [f"{name}: {link!r} is not a link of the URDF" for link in named if link not in links]
    return violations


def start_contact(cloud_xy: np.ndarray, tip_xy: np.ndarray) -> tuple[float, float]:
    """Eq. 3's test of a slide's first contact: ``(gap, tolerance)``, the fingertip's distance to the
    cloud's nearest point and the cloud's own point spacing (at least 1 mm); the slide starts on the object
    when ``gap <= tolerance``. The closed loop asks it too, before it plans from where the finger presses."""
    tree = shapely.STRtree(shapely.points(cloud_xy))
    # Each point's nearest other point (exclusive: not itself, nor its duplicates); of a dense cloud, every
    # k-th point's (200,000 points took 2.2 s, most of verifying the plan; the median of 2,000 is as good).
    queried = tree.geometries[::max(1, len(cloud_xy) // SPACING_SAMPLE)]
    nearest = tree.query_nearest(queried, return_distance=True, exclusive=True, all_matches=False)[1]
    ordered = np.sort(nearest)  # its median; np.median would import numpy.ma (16 ms of every CLI plan)
    spacing = 0.5 * float(ordered[(len(ordered) - 1) // 2] + ordered[len(ordered) // 2]) if len(ordered) else 0.0
    gap = float(tree.query_nearest(shapely.Point(tip_xy), return_distance=True, all_matches=False)[1][0])
    return gap, max(spacing, 1e-3)


def _start_contact_violations(cloud_xy: np.ndarray, tip_xy: np.ndarray) -> list[str]:
    """Eq. 3: the slide starts with the fingertip on the object (within the cloud's own point spacing
    of one of its points), or nothing is pushed."""
    gap, tolerance = start_contact(cloud_xy, tip_xy)
    if gap <= tolerance:
        return []
    return [f"trajectory[0]: the fingertip is {gap:.4f} m from the nearest point of the object (point spacing "
            f"{tolerance:.4f} m): the slide does not start on the object"]


def check_sliding_path(result: PlanResult, world: PlanWorld) -> list[str]:
    """Check every trajectory waypoint against the contact constraint, and the path density.

    Args:
        result: the plan (array shapes already checked).
        world: the rebuilt robot, table and collision world.

    Returns:
        Violations, each naming ``trajectory[i]`` and the numbers.
    """
    from .. import _core

    params = result.params
    violations = []
    tips = []
    for index, config in enumerate(np.asarray(result.trajectory)):
        name = f"trajectory[{index}]"
        pose = np.asarray(world.robot.fk(config))
        tips.append(pose[:3, 3])
        mismatch = pose_mismatch(pose, row_to_pose(result.fingertip_poses[index]))
        if mismatch:
            violations.append(f"{name}: forward kinematics differs from fingertip_poses[{index}] by {mismatch}")
        depth = world.object_top_z - pose[2, 3]
        if not params["dz_min"] - DEPTH_TOLERANCE_M <= depth <= params["dz_max"] + DEPTH_TOLERANCE_M:
            violations.append(
                f"{name}: contact depth {depth:.6f} m outside [dz_min, dz_max] = [{params['dz_min']}, {params['dz_max']}]"
            )
        _, pitch, roll = contact_angles(pose)
        if abs(pitch - params["beta0"]) > params["delta_beta"] + ANGLE_TOLERANCE_RAD:
            violations.append(
                f"{name}: pitch {pitch:.6f} rad outside beta0 +- delta_beta = {params['beta0']} +- {params['delta_beta']}"
            )
        if abs(roll) > ANGLE_TOLERANCE_RAD:
            violations.append(f"{name}: roll {roll:.6f} rad, expected 0 (+- {ANGLE_TOLERANCE_RAD})")
        if not world.table.contains(pose[:2, 3]):
            violations.append(f"{name}: fingertip ({pose[0, 3]:.4f}, {pose[1, 3]:.4f}) is not over the table")
        violations += joint_limit_violations(name, config, world.robot)
        violations += collision_violation(name, config, world.collision_world, _core.ContactMode.SLIDING)
    violations += density_violations(
        "trajectory", np.asarray(result.trajectory), params["max_joint_step"], np.array(tips), params["max_tip_step"]
    )
    if tips:
        violations += _start_contact_violations(np.asarray(result.object["points"], dtype=float)[:, :2], tips[0][:2])
    return violations


def obstacle_footprints(result: PlanResult):
    """The union of the footprints (shapely, world xy) of the plan's obstacles that reach down to the
    object's top: the sliding object must not overlap them. None if there are none."""
    top = result.object_top
    shapes = [footprint for footprint, bottom in map(obstacle_footprint, result.obstacles) if bottom < top]
    return shapely.union_all(shapes) if shapes else None


def check_clutter(result: PlanResult, world: PlanWorld) -> list[str]:
    """Check that the object, carried by Eq. 2 from its start, overlaps no obstacle at any waypoint,
    and that the arm meets it only through the contact links (sliding mode).

    Args:
        result: the plan (array shapes already checked).
        world: the rebuilt robot, table and collision world (its object is set and cleared here).

    Returns:
        Violations naming ``trajectory[i]``.
    """
    from .. import _core

    points = np.asarray(result.object["points"], dtype=float)[:, :2]
    hull = np.asarray(MultiPoint(points).convex_hull.exterior.coords)[:-1]
    footprints = obstacle_footprints(result)
    first = row_to_pose(result.fingertip_poses[0])
    violations = []
    try:
        for index, config in enumerate(np.asarray(result.trajectory)):
            motion = planar_motion(first, row_to_pose(result.fingertip_poses[index]))
            if footprints is not None:
                moved = move_planar(points, motion)
                inside = shapely.contains_xy(footprints, moved[:, 0], moved[:, 1])
                if inside.any():
                    violations.append(f"trajectory[{index}]: {int(inside.sum())} object points lie inside an obstacle")
            world.collision_world.set_object(move_planar(hull, motion), world.object_top_z)
            hits = world.collision_world.collisions(config, _core.ContactMode.SLIDING)
            hits = [pair for pair in hits if "object" in pair]
            if hits:
                violations.append(f"trajectory[{index}]: the arm meets the sliding object ({hits[0][0]})")
    finally:
        world.collision_world.clear_object()
    return violations


def check_object_motion(result: PlanResult) -> list[str]:
    """Check Eq. 2: the recorded object motion is the fingertip's planar motion.

    Args:
        result: the plan (array shapes already checked).

    Returns:
        At most one violation, with both motions.
    """
    expected = planar_motion(row_to_pose(result.fingertip_poses[0]), row_to_pose(result.fingertip_poses[-1]))
    recorded = (result.object_motion["x"], result.object_motion["y"], result.object_motion["yaw"])
    errors = (recorded[0] - expected[0], recorded[1] - expected[1], wrap_angle(recorded[2] - expected[2]))
    if max(abs(error) for error in errors) <= MOTION_TOLERANCE:
        return []
    return [
        "object_motion: (x, y, yaw) = ({:.6f}, {:.6f}, {:.6f}) but the fingertip moves the object by "
        "({:.6f}, {:.6f}, {:.6f}) from trajectory[0] to trajectory[{}] (Eq. 2)".format(
            *recorded, *expected, len(result.trajectory) - 1
        )
    ]


def check_graspability(result: PlanResult, table: SupportSurface) -> list[str]:
    """Check the final object pose (paper IV-C.1): ``u >= u*``, ``u`` as recorded, CoM on the table.

    Args:
        result: the plan.
        table: the support surface built from ``result.table``.

    Returns:
        Violations with the numbers.
    """
    violations = []
    u, outside, edge = overhang(table, result.moved_object_xy())
    if not outside.any():
        violations.append("final object pose: no object point overhangs the table")
    standoff = result.params.get("grasp_standoff", 0.0)
    held = u
    if edge is not None and standoff > 0.0:
        beyond = float((np.asarray(result.grasp["pose"][:2], dtype=float) - edge[0]) @ edge[1])
        if beyond < standoff - MOTION_TOLERANCE:
            violations.append(f"grasp.pose: {beyond:.4f} m beyond the table edge, less than grasp_standoff {standoff}")
        held = u - max(0.0, beyond - standoff)
    motion = result.object_motion
    com = np.asarray(result.object["com_xy"], dtype=float)
    moved_com = move_planar(com, (motion["x"], motion["y"], motion["yaw"]))
    end = Ending(held, table.edge_margin(moved_com))  # the overhang the hand holds
    if not end.overhangs(result.params["u_star"], STEP_SLACK):
        violations.append(f"final object pose: overhang held by the hand {held:.6f} m < u_star {result.params['u_star']}")
    if abs(u - result.overhang_m) > MOTION_TOLERANCE:
        violations.append(f"overhang_m: recorded {result.overhang_m:.6f} m, recomputed {u:.6f} m")
    # The data layer's centroid (the planner receives it from there too); recomputed, not trusted.
    centroid = area_centroid(np.asarray(result.object["points"], dtype=float)[:, :2])
    if float(np.linalg.norm(com - centroid)) > MOTION_TOLERANCE:
        violations.append(f"object.com_xy: ({com[0]:.4f}, {com[1]:.4f}) is not the area centroid of the object's "
                          f"points ({centroid[0]:.4f}, {centroid[1]:.4f})")
    if end.com_margin <= 0.0:
        violations.append(f"final object pose: centre of mass ({moved_com[0]:.4f}, {moved_com[1]:.4f}) is off the table")
    elif not end.com_inside(result.params.get("com_margin", 0.0), MOTION_TOLERANCE):
        violations.append(f"final object pose: centre of mass {end.com_margin:.4f} m inside the table edge, "
                          f"less than com_margin {result.params['com_margin']}")
    elif result.params.get("support_hull", False):
        margin = support_margin(table, result.moved_object_xy(), moved_com)
        if margin < result.params["support_margin"] - MOTION_TOLERANCE:
            violations.append(f"final object pose: centre of mass {margin:.4f} m inside the hull of the object's part on "
                              f"the table, less than support_margin {result.params['support_margin']} (support_hull): "
                              "it may tip over the edge when the finger lets go")
    return violations


def check_support(result: PlanResult, table: SupportSurface) -> list[str]:
    """With ``com_supported`` (beyond the paper), the centre of mass lies on the table at every waypoint
    (Eq. 2 from the first). Plans without the parameter (the paper's check: the final pose only) pass.

    Returns:
        At most one violation: the first waypoint off, and by how much.
    """
    if not result.params.get("com_supported", False):
        return []
    com = np.asarray(result.object["com_xy"], dtype=float)
    first = row_to_pose(result.fingertip_poses[0])
    for index, row in enumerate(result.fingertip_poses):
        moved = move_planar(com, planar_motion(first, row_to_pose(row)))
        margin = table.edge_margin(moved)
        if margin < -MOTION_TOLERANCE:
            return [f"trajectory[{index}]: centre of mass ({moved[0]:.4f}, {moved[1]:.4f}) {-margin:.4f} m off the table "
                    f"(com_supported)"]
    return []


def check_turning(result: PlanResult, given_start: bool = False) -> list[str]:
    """Check the bounds on turning and on the first contact that the plan's parameters claim:
    ``|yaw| <= max_object_yaw``, every step's turn within ``max_yaw_rate`` times its fingertip travel
    (when > 0), and, unless the start was ``given_start``, the first contact within ``contact_radius`` of
    the closest point to the centre of mass (when > 0). Parameters a plan does not record are the
    paper's (no bound).

    Returns:
        Violations with the numbers.
    """
    params = result.params
    violations = []
    yaw = abs(result.object_motion["yaw"])
    if yaw > params.get("max_object_yaw", math.pi) + MOTION_TOLERANCE:
        violations.append(f"object_motion: turns the object {yaw:.6f} rad > max_object_yaw {params['max_object_yaw']}")
    poses = [row_to_pose(row) for row in result.fingertip_poses]
    rate = params.get("max_yaw_rate", 0.0)
    if rate > 0:
        for index in range(1, len(poses)):
            x, y, turn = planar_motion(poses[index - 1], poses[index])
            travel = float(np.linalg.norm(poses[index][:2, 3] - poses[index - 1][:2, 3]))
            if abs(turn) > rate * travel + MOTION_TOLERANCE:
                violations.append(f"trajectory[{index - 1}]->[{index}]: turns {abs(turn):.6f} rad over {travel:.6f} m, "
                                  f"more than max_yaw_rate {rate} rad/m")
    radius = params.get("contact_radius", 0.0)
    if radius > 0 and poses and not given_start:
        com = np.asarray(result.object["com_xy"], dtype=float)
        closest = float(np.min(np.linalg.norm(np.asarray(result.object["points"])[:, :2] - com, axis=1)))
        contact = float(np.linalg.norm(poses[0][:2, 3] - com))
        if contact > closest + radius + CONTACT_SLACK_M:
            violations.append(f"trajectory[0]: first contact {contact:.4f} m from the centre of mass, beyond the closest "
                              f"point ({closest:.4f} m) + contact_radius {radius}")
    return violations


def check_timing(result: PlanResult, world: PlanWorld) -> list[str]:
    """Check the timing block against its own limits: times from 0, strictly increasing, rest at both
    ends, recorded velocities and accelerations and the finite differences of positions within the
    joint limits, and the fingertip speed within its cap while sliding and near the object's top.

    Returns:
        Violations naming ``timing.<segment>`` and the numbers; none for a plan without timing.
    """
    from ..plan.timing import NEAR_TABLE_M

    if result.timing is None:
        return []
    limits = result.timing["limits"]
    vmax = np.asarray(limits["joint_velocity"], dtype=float)
    amax = np.asarray(limits["joint_acceleration"], dtype=float)
    tip_max = float(limits["fingertip_speed"])
    violations = []
    for name, path in (("trajectory", np.asarray(result.trajectory)), ("approach", np.asarray(result.grasp["approach"]))):
        block = result.timing[name]
        times = np.asarray(block["time_from_start"], dtype=float)
        velocities = np.asarray(block["velocities"], dtype=float)
        accelerations = np.asarray(block["accelerations"], dtype=float)
        label = f"timing.{name}"
        if len(times) != len(path) or not len(path):
            violations.append(f"{label}: {len(times)} times for {len(path)} waypoints")
            continue
        if len(path) == 1:  # a plan from a state that grasps at once: one waypoint, at rest at t = 0
            if abs(times[0]) > 1e-12 or np.abs(velocities).max() > 1e-9:
                violations.append(f"{label}: its one waypoint must be at t = 0 and at rest")
            continue
        dt = np.diff(times)
        if abs(times[0]) > 1e-12 or np.any(dt <= 0):
            violations.append(f"{label}: time_from_start must start at 0 and increase strictly")
            continue
        if max(np.abs(velocities[0]).max(), np.abs(velocities[-1]).max()) > 1e-9:
            violations.append(f"{label}: the first and last velocities must be zero")
        with np.errstate(over="ignore"):  # a position of 1e308 moves at inf x the limit, and is reported so
            excess = max(np.max(np.abs(velocities) / vmax), np.max(np.abs(np.diff(path, axis=0)) / dt[:, None] / vmax))
        if excess > 1.0 + TIMING_SLACK:
            violations.append(f"{label}: a joint moves at {excess:.4f} x its velocity limit")
        if np.max(np.abs(accelerations) / amax) > 1.0 + TIMING_SLACK:
            violations.append(f"{label}: a joint accelerates at {np.max(np.abs(accelerations) / amax):.4f} x its limit")
        # The trajectory's recorded poses are checked against forward kinematics in check_sliding_path.
        tips = np.asarray(result.fingertip_poses)[:, :3] if name == "trajectory" else world.approach_tips
        capped = np.ones(len(path), bool) if name == "trajectory" else tips[:, 2] <= world.object_top_z + NEAR_TABLE_M
        intervals = capped[:-1] | capped[1:]
        speeds = np.linalg.norm(np.diff(tips, axis=0), axis=1)[intervals] / dt[intervals]
        if speeds.size and speeds.max() > tip_max * (1.0 + TIMING_SLACK):
            violations.append(f"{label}: the fingertip moves at {speeds.max():.4f} m/s > fingertip_speed {tip_max}")
    return violations


