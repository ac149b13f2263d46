"""Execute a plan in physics: a MuJoCo replay of the whole arm with a compliant finger, then grasp and lift.

:func:`execute` builds a MuJoCo model from the plan alone (its ``robot`` block, table and object
cloud), drives the arm along the plan's trajectory under joint position control, and reports where
the object really ends against Eq. 2's prediction, and whether the side grasp then lifts it.

The model (docs/execution.md gives the numbers and why):

- **Robot**: the plan's URDF (with its ``attach`` fragments), imported by MuJoCo, mounted at
  ``base_pose``. Every body is gravity compensated (as the WAM's own controller does) and each arm
  joint follows its reference through a PD position servo whose gains give every joint the same
  closed-loop bandwidth (:attr:`ExecutionSettings.servo_bandwidth_hz`, critically damped) at the
  start configuration's inertia. The reference is read ahead by kv/kp, which equals velocity
  feed-forward to first order.
- **Finger compliance**: the first contact link gets a passive slide joint (stiffness
  :attr:`ExecutionSettings.finger_stiffness`) along the world vertical as seen from the finger at the
  planned pitch ``beta0``; a spherical pad whose lowest point is the contact frame ``F`` is the only
  geometry of the contact links that touches anything while sliding. The planned contact depth
  ``z_s - z_F`` is thus the spring's compression, and the normal force is ``k * depth``: 2-6 N for the
  T42's band [1, 3] cm at 200 N/m.
- **Object**: boxes on a square grid (:attr:`ExecutionSettings.cell_size`), each the bounding box of
  its cell's part of the point cloud's footprint (:func:`object_boxes`), one rigid body of uniform
  density, so table friction is spread over the footprint.
- **Table**: the polygon as a 5 cm thick prism, one convex mesh per triangle of a constrained
  Delaunay triangulation when it is not convex.
- **Grasp**: the hand's fingers (the bodies hanging on the grasp link's parent) get hinge joints about
  the grasp frame's x axis, position-servoed closed with a capped torque.

Phases: slide along ``trajectory``; settle; follow ``grasp.approach`` (lift, transfer, approach);
close the hand; lift 5 cm; hold 1 s.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable
from xml.etree import ElementTree

import numpy as np
import shapely
from shapely.geometry import Polygon

from .errors import InputError
from .geometry import SupportSurface
from .planning import PlanResult, build_robot, merge_urdf
from .timing import TimingOptions, parameterize, resolve_limits, time_path
from .transforms import move_planar, quaternion_from_matrix, rotation_2d, row_to_pose, wrap_angle
from .verify import contact_angles, overhang

EXECUTION_SCHEMA = "slideplan.execution/1"
MESH_SUFFIXES = (".stl", ".obj")  # what MuJoCo reads from a URDF
STAGES = ("slide", "release", "grasp", "simulation")

_ROBOT_CONTYPE, _ROBOT_CONAFFINITY = 2, 1  # robot geoms touch the world, not each other
_WORLD_CONTYPE, _WORLD_CONAFFINITY = 1, 3  # table and object touch everything
_TABLE_THICKNESS = 0.05
_PAD_RADIUS = 0.006
_SETTLE_S = 0.3
_CLOSE_S = 0.8
_LIFTED_FRACTION = 0.5  # lifted: the object rose at least half the lift height and stays there
_FELL_DROP_M = 0.01  # fell: the object's centre is this far below its resting height
_SAMPLE_EVERY = 5  # steps between normal-force samples
_FINGER_RANGE = (-0.2, 1.6)  # closing hinges (rad): open a little, closed well past the grasp plane
_CLOSE_TARGET_RAD = 1.5  # beyond any contact (hinge range [-0.2, 1.6]): the capped torque squeezes
_NO_FORCE_N = 0.1  # below this mean normal force the finger does not press at all
_ARENA_BYTES = 128 << 20  # a 20 cm plate has ~500 contacts with the table; MuJoCo's default arena drops them


@dataclass(frozen=True)
class ExecutionSettings:
    """Physical parameters of an execution (defaults: docs/execution.md).

    The three limits time, with :func:`slideplan.timing.parameterize` (TOPP-RA), the slide and the
    approach of a plan without a ``timing`` block, and the lift of every plan.

    Attributes:
        tip_speed: fingertip speed cap (m/s) while sliding, on the approach within
            :data:`slideplan.timing.NEAR_TABLE_M` of the object's top, and while lifting.
        joint_velocity: joint speed cap (rad/s); the URDF's lower limits win.
        joint_acceleration: joint acceleration cap (rad/s^2), every joint.
        finger_stiffness: stiffness of the finger's vertical compliance (N/m).
        finger_damping: damping of that compliance (N s/m).
        contact_depth: None follows the plan's depths; a number presses this deep (m) at every
            waypoint instead (the stress setting uses ``dz_min``; 0 does not press at all).
        torsional_friction: torsional friction coefficient of the fingertip pad (m).
        pad_friction: sliding friction coefficient between the pad (and the fingers) and the object.
        table_friction: sliding friction coefficient between object and table.
        object_density: density of the object (kg/m^3).
        cell_size: side of the object's boxes (m).
        servo_bandwidth_hz: closed-loop bandwidth of the arm's joint servos (Hz).
        grip_torque: closing torque of each finger (N m).
        close_speed: speed of the fingers' closing target (rad/s).
        lift_height: lift of the hand after closing (m).
        hold_s: hold time after the lift (s).
        timestep: simulation step (s).
        position_tolerance: a slide succeeds within this position error (m)...
        yaw_tolerance: ... and this yaw error (rad) of Eq. 2.
    """

    tip_speed: float = 0.05
    joint_velocity: float = 1.0
    joint_acceleration: float = 2.0
    finger_stiffness: float = 200.0
    finger_damping: float = 4.0
    contact_depth: float | None = None
    torsional_friction: float = 0.01
    pad_friction: float = 1.0
    table_friction: float = 0.4
    object_density: float = 1000.0
    cell_size: float = 0.0125
    servo_bandwidth_hz: float = 15.0
    grip_torque: float = 0.5
    close_speed: float = 1.5
    lift_height: float = 0.05
    hold_s: float = 1.0
    timestep: float = 0.001
    position_tolerance: float = 0.005
    yaw_tolerance: float = math.radians(3.0)

    def __post_init__(self) -> None:
        for item in dataclasses.fields(self):
            value = getattr(self, item.name)
            if item.name == "contact_depth" and value is None:
                continue
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                raise InputError(f"expected a finite number, got {value!r}", field=item.name)
            if item.name != "contact_depth" and value <= 0:
                raise InputError(f"must be > 0, got {value!r}", field=item.name)


@dataclass
class Execution:
    """What happened when a plan was executed (:func:`execute`).

    Attributes:
        success: the object ended within tolerance of Eq. 2, stayed on the table and was lifted.
        failed_stage: None, or where it failed: ``"slide"`` (the object did not follow the finger),
            ``"release"`` (it fell off the table), ``"grasp"`` (not lifted) or ``"simulation"``
            (the simulation went unstable; poses are then None).
        failure: one line saying what went wrong ("" on success).
        predicted_motion: Eq. 2's ``{x, y, yaw}`` from the plan.
        actual_motion: the object's measured planar motion after the slide (same convention), or None.
        position_error_m: distance between the measured and predicted centre of mass, or None.
        yaw_error_deg: measured minus predicted yaw (degrees, wrapped), or None.
        overhang_m: overhang ``u`` at the measured pose, or None.
        com_margin_m: signed distance of the measured centre of mass inside the table edge, or None.
        planned_com_margin_m: the same at the planned final pose.
        normal_force_n: mean, min and max fingertip normal force while sliding (N).
        lifted: the grasp lifted the object and held it.
        tip_path_m: the plan's fingertip path length (m).
        yaw_travel_deg: the plan's total fingertip yaw travel (degrees).
        sim_time_s: simulated time (s).
        wall_time_s: wall time of the simulation (s).
        settings: the :class:`ExecutionSettings` used.
    """

    success: bool
    failed_stage: str | None
    failure: str
    predicted_motion: dict[str, float]
    actual_motion: dict[str, float] | None
    position_error_m: float | None
    yaw_error_deg: float | None
    overhang_m: float | None
    com_margin_m: float | None
    planned_com_margin_m: float
    normal_force_n: dict[str, float]
    lifted: bool
    tip_path_m: float
    yaw_travel_deg: float
    sim_time_s: float
    wall_time_s: float
    settings: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Return the report as JSON-ready dicts, ``schema`` first (no NaN anywhere)."""
        return {"schema": EXECUTION_SCHEMA, **dataclasses.asdict(self)}

    def to_json(self, indent: int | None = None) -> str:
        """Return the report as JSON text.

        Args:
            indent: passed to :func:`json.dumps`.
        """
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    def summary(self) -> str:
        """One line: the verdict and the numbers."""
        if self.failed_stage == "simulation":
            return f"failed: {self.failure}"
        verdict = "ok" if self.success else f"failed at {self.failed_stage}: {self.failure}"
        return (
            f"{verdict}; Eq. 2 error {1000 * self.position_error_m:.1f} mm / {self.yaw_error_deg:.1f} deg, "
            f"overhang {100 * self.overhang_m:.1f} cm, CoM {1000 * self.com_margin_m:.1f} mm inside the table, "
            f"normal force {self.normal_force_n['mean']:.1f} N, lifted {'yes' if self.lifted else 'no'} "
            f"({self.sim_time_s:.1f} s simulated in {self.wall_time_s:.1f} s)"
        )


class _Unstable(Exception):
    """The simulation produced NaN or MuJoCo reset it (bad accelerations)."""


# ----------------------------------------------------------------------------- timing


def _timing_options(settings: ExecutionSettings, urdf_velocity) -> TimingOptions:
    """The limits under which :mod:`slideplan.timing` times what an execution times itself.

    Args:
        settings: its ``tip_speed``, ``joint_velocity`` and ``joint_acceleration`` are the limits.
        urdf_velocity: (dof,) the URDF's ``<limit velocity>``; 0 or less (missing) sets no limit.

    Returns:
        The options, joint velocity ``min(URDF, settings.joint_velocity)`` per joint.
    """
    urdf_velocity = np.asarray(urdf_velocity, dtype=float)
    velocity = np.minimum(np.where(urdf_velocity > 0, urdf_velocity, np.inf), settings.joint_velocity)
    return TimingOptions(joint_acceleration=settings.joint_acceleration, fingertip_speed=settings.tip_speed,
                         joint_velocity=velocity)


def _reference(path: np.ndarray, times: np.ndarray, t: float) -> np.ndarray:
    """Joint reference at time ``t`` by linear interpolation (held at the ends)."""
    if t >= times[-1]:
        return path[-1]
    index = int(np.searchsorted(times, t, side="right")) - 1
    index = max(0, min(index, len(times) - 2))
    span = times[index + 1] - times[index]
    fraction = 0.0 if span <= 0 else (t - times[index]) / span
    return path[index] + fraction * (path[index + 1] - path[index])


# ----------------------------------------------------------------------------- plan features


def path_features(result: PlanResult) -> tuple[float, float]:
    """Fingertip path length and total yaw travel of a plan's sliding trajectory.

    Args:
        result: a solved plan.

    Returns:
        ``(path_m, yaw_travel_rad)``.
    """
    poses = [row_to_pose(row) for row in result.fingertip_poses]
    positions = np.array([pose[:3, 3] for pose in poses])
    yaws = [contact_angles(pose)[0] for pose in poses]
    path = float(np.sum(np.linalg.norm(np.diff(positions, axis=0), axis=1))) if len(poses) > 1 else 0.0
    travel = float(sum(abs(wrap_angle(b - a)) for a, b in zip(yaws, yaws[1:])))
    return path, travel


# ----------------------------------------------------------------------------- model


def _urdf_for_mujoco(robot: dict[str, Any]) -> str:
    """The plan's URDF (with attachments), mesh paths made absolute and MuJoCo's compiler options set.

    Raises:
        InputError: unreadable URDF, a mesh that does not exist or that MuJoCo cannot read.
    """
    from . import _core

    urdf = Path(robot["urdf"])
    try:
        text = merge_urdf(urdf, [Path(path) for path in robot["attach"]])
        root = ElementTree.fromstring(text)
    except (ValueError, ElementTree.ParseError) as error:
        raise InputError(str(error), field="robot.urdf") from None
    for link in root.iter("link"):
        for kind in ("collision", "visual"):
            for element in link.iter(kind):
                for mesh in element.iter("mesh"):
                    uri = mesh.get("filename", "")
                    try:
                        path = _core.resolve_uri(uri, str(urdf.parent), list(robot["package_dirs"]))
                    except ValueError as error:
                        raise InputError(
                            f"link {link.get('name')!r}: {kind} mesh {uri!r} not found ({error})", source=str(urdf)
                        ) from None
                    if kind == "collision" and Path(path).suffix.lower() not in MESH_SUFFIXES:
                        raise InputError(
                            f"link {link.get('name')!r}: collision mesh {uri!r} is {Path(path).suffix or 'untyped'}; "
                            f"MuJoCo reads {' and '.join(MESH_SUFFIXES)}",
                            source=str(urdf),
                        )
                    mesh.set("filename", path)
    # Keep fixed-joint links as bodies: the contact links and fingers get joints of their own.
    extension = ElementTree.SubElement(root, "mujoco")
    ElementTree.SubElement(extension, "compiler", fusestatic="false", strippath="false", discardvisual="true")
    return ElementTree.tostring(root, encoding="unicode")


def _table_pieces(polygon: Polygon) -> list[np.ndarray]:
    """Convex pieces of the table polygon: itself if convex, else its constrained Delaunay triangles."""
    if polygon.convex_hull.area - polygon.area <= 1e-9 * polygon.area:
        return [np.asarray(polygon.exterior.coords)[:-1]]
    triangles = shapely.constrained_delaunay_triangles(polygon)
    return [np.asarray(piece.exterior.coords)[:-1] for piece in triangles.geoms]


def cloud_footprint(points: np.ndarray) -> Polygon | shapely.MultiPolygon:
    """The outline of a top-surface point cloud: a morphological closing of its points.

    Each point is widened by the cloud's spacing (90th percentile of the nearest-neighbour
    distances of up to 500 of its points; boundary samples are denser than the grid inside), which
    joins neighbours on a grid, and the union is shrunk back by the same amount, so concavities and
    holes wider than 2 spacings stay open.

    Args:
        points: (N, 3) cloud.

    Returns:
        The footprint polygon(s), world frame.
    """
    xy = np.asarray(points, dtype=float)[:, :2]
    sample = xy[:: max(1, len(xy) // 500)]
    distances = np.linalg.norm(sample[:, None, :] - xy[None, :, :], axis=2)
    distances[distances == 0] = np.inf
    radius = max(float(np.percentile(distances.min(axis=1), 90)), 1e-4)
    return shapely.unary_union(shapely.buffer(shapely.points(xy), radius, quad_segs=4)).buffer(-radius, quad_segs=4)


def object_boxes(points: np.ndarray, cell_size: float) -> np.ndarray:
    """Boxes tiling the footprint of a top-surface point cloud on a square grid.

    Each grid cell that meets the footprint (:func:`cloud_footprint`) becomes the bounding box of
    its part of the footprint, so the boxes cover the whole outline (the fingertip finds the object
    wherever the plan touches it) and overfill only where an edge crosses a cell diagonally.

    Args:
        points: (N, 3) cloud.
        cell_size: grid spacing (m).

    Returns:
        (K, 4) boxes ``[centre x, centre y, half width x, half width y]``, K >= 1.
    """
    xy = np.asarray(points, dtype=float)[:, :2]
    footprint = cloud_footprint(points)
    low, high = xy.min(axis=0), xy.max(axis=0)
    counts = np.maximum(np.ceil((high - low) / cell_size).astype(int), 1)
    corner = (low + high) / 2 - counts * cell_size / 2
    cells = shapely.box(*np.stack(np.meshgrid(
        *(corner[axis] + cell_size * np.arange(counts[axis]) for axis in (0, 1))), axis=-1).reshape(-1, 2).T,
        *(np.stack(np.meshgrid(*(corner[axis] + cell_size * np.arange(1, counts[axis] + 1) for axis in (0, 1))),
                   axis=-1).reshape(-1, 2).T))
    parts = shapely.intersection(cells, footprint)
    parts = parts[shapely.area(parts) > 1e-3 * cell_size**2]
    bounds = shapely.bounds(parts)  # (K, 4): xmin, ymin, xmax, ymax
    boxes = np.column_stack([(bounds[:, :2] + bounds[:, 2:]) / 2, (bounds[:, 2:] - bounds[:, :2]) / 2])
    if len(boxes):
        return boxes
    return np.array([[*((low + high) / 2), *np.maximum((high - low) / 2, 1e-3)]])


@dataclass
class _Model:
    """The compiled model and the indices the run needs."""

    model: Any
    data: Any
    arm_qpos: np.ndarray  # qpos addresses of the plan's joints
    arm_dofs: np.ndarray
    arm_actuators: np.ndarray
    spring_qpos: int
    spring_joint: int
    finger_actuators: list[int]
    finger_meet: np.ndarray  # closing angle at which each finger's far end reaches the grasp plane (rad)
    hand_geoms: np.ndarray  # contact-link geoms that only touch things once the finger is lifted
    pad_geom: int
    tip_body: int
    object_body: int
    object_geoms: set
    table_geoms: set


def _build_model(result: PlanResult, settings: ExecutionSettings) -> _Model:
    """Build the MuJoCo model of a plan (module docstring).

    Raises:
        InputError: the URDF cannot be imported, naming what MuJoCo complained about.
    """
    import mujoco

    robot = result.robot
    urdf_source = str(robot["urdf"])
    try:
        spec = mujoco.MjSpec.from_string(_urdf_for_mujoco(robot))
        spec.compile()
    except ValueError as error:
        raise InputError(f"MuJoCo cannot import the URDF: {' '.join(str(error).split())}", source=urdf_source) from None
    names = {body.name for body in spec.bodies}
    for key in ("tip_link", "grasp_link"):
        if robot[key] not in names:
            raise InputError(f"link {robot[key]!r} not in the URDF", field=f"robot.{key}")
    for link in robot["contact_links"]:
        if link not in names:
            raise InputError(f"link {link!r} not in the URDF", field="robot.contact_links")
    joint_names = {joint.name for joint in spec.joints}
    for joint in result.joint_names:
        if joint not in joint_names:
            raise InputError(f"joint {joint!r} not in the URDF", field="joint_names")

    # Kinematics at qpos0 (every joint 0) give the fixed transforms the new joints need.
    model0 = spec.compile()
    data0 = mujoco.MjData(model0)
    mujoco.mj_kinematics(model0, data0)

    def pose0(name: str) -> np.ndarray:
        body = model0.body(name).id
        pose = np.eye(4)
        pose[:3, :3] = data0.xmat[body].reshape(3, 3)
        pose[:3, 3] = data0.xpos[body]
        return pose

    # Mount: the planned chain's base link (default: the URDF root) at base_pose.
    root_body = spec.worldbody.first_body()
    base_link = robot["base_link"] or root_body.name
    mount = np.asarray(robot["base_pose"]) @ np.linalg.inv(pose0(base_link)) @ pose0(root_body.name)
    root_body.pos = mount[:3, 3]
    root_body.quat = _wxyz(mount[:3, :3])

    robot_bodies = [body for body in spec.bodies if body.name != "world"]
    for body in robot_bodies:
        body.gravcomp = 1.0  # the arm controller's gravity compensation
        for geom in body.geoms:
            geom.contype, geom.conaffinity = _ROBOT_CONTYPE, _ROBOT_CONAFFINITY
            # Soft finger pads: a contact patch resists twisting and tilting (torsional and rolling friction).
            geom.friction = [settings.pad_friction, settings.torsional_friction, settings.torsional_friction]
            geom.condim = 6

    # Finger compliance: a slide joint on the first contact link, along the world vertical seen from
    # the contact frame at pitch beta0, and a pad whose lowest point is the contact frame.
    from . import _core

    contact = set(robot["contact_links"])
    contact_root = next(
        name for name in robot["contact_links"] if spec.body(name).parent.name not in contact
    )
    tip_frame = pose0(robot["tip_link"]) @ np.asarray(robot["tip_offset"])
    up_in_tip = _core.contact_rotation(0.0, float(result.params["beta0"])).T @ np.array([0.0, 0.0, 1.0])
    up_world0 = tip_frame[:3, :3] @ up_in_tip
    root_pose = pose0(contact_root)
    spring = spec.body(contact_root).add_joint(
        name="slideplan_finger_compliance",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=root_pose[:3, :3].T @ up_world0,
        damping=settings.finger_damping,
        armature=0.002,
        limited=mujoco.mjtLimited.mjLIMITED_TRUE,
        range=[-0.01, float(result.params["dz_max"]) + 0.03],
    )
    spring.stiffness = [settings.finger_stiffness, 0.0, 0.0]
    tip_body_pose = pose0(robot["tip_link"])
    pad_world = tip_frame[:3, 3] + _PAD_RADIUS * up_world0
    pad = spec.body(robot["tip_link"]).add_geom(
        name="slideplan_pad",
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[_PAD_RADIUS, 0, 0],
        pos=tip_body_pose[:3, :3].T @ (pad_world - tip_body_pose[:3, 3]),
        contype=_ROBOT_CONTYPE,
        conaffinity=_ROBOT_CONAFFINITY,
        condim=6,
        priority=1,
        friction=[settings.pad_friction, settings.torsional_friction, 0.0001],
        solref=[0.004, 1],
        solimp=[0.3, 0.95, 0.001, 0.5, 2],
        mass=0.001,
        rgba=[0.9, 0.3, 0.2, 1],
    )

    # Fingers: the other bodies on the grasp link's parent with mass and geometry close about grasp x.
    grasp_frame = pose0(robot["grasp_link"]) @ np.asarray(robot["grasp_offset"])
    palm = spec.body(robot["grasp_link"]).parent
    fingers, meet = [], []
    for child in palm.bodies:
        tip = _subtree_far_point(model0, data0, child.name, pose0(child.name)[:3, 3])
        if tip is None or child.name == robot["grasp_link"] or model0.body(child.name).subtreemass[0] <= 1e-6:
            continue
        pivot = pose0(child.name)[:3, 3]
        axis_world = grasp_frame[:3, 0]
        # closing moves the far point towards the grasp frame's y = 0 plane
        side = float((tip - grasp_frame[:3, 3]) @ grasp_frame[:3, 1])
        motion = float(np.cross(axis_world, tip - pivot) @ grasp_frame[:3, 1])
        sign = -1.0 if side * motion > 0 else 1.0
        hinge = child.add_joint(
            name=f"slideplan_close_{child.name}",
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=pose0(child.name)[:3, :3].T @ (sign * axis_world),
            armature=0.002,
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            range=_FINGER_RANGE,
        )
        fingers.append(hinge.name)
        meet.append(_meeting_angle(pivot, tip, sign * axis_world, grasp_frame))

    # Arm servos (gains set after compiling, from the inertia) and the fingers' closing servos.
    for joint in result.joint_names:
        actuator = spec.add_actuator(name=f"servo_{joint}", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=1.0, kv=0.1)
    for joint, value in robot["fixed_joints"].items():
        actuator = spec.add_actuator(name=f"hold_{joint}", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=200.0, kv=5.0)
    for joint in fingers:
        actuator = spec.add_actuator(name=f"close_{joint}", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=20.0, kv=0.2)
        actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.forcerange = [-100.0, 100.0]  # stiff while sliding; capped to grip_torque when closing

    _add_world(spec, result, settings)
    spec.memory = _ARENA_BYTES
    spec.option.timestep = settings.timestep
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10
    spec.option.noslip_iterations = 10
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    try:
        model = spec.compile()
    except ValueError as error:
        raise InputError(f"MuJoCo cannot build the execution model: {' '.join(str(error).split())}", source=urdf_source) from None
    data = mujoco.MjData(model)

    arm_joints = [model.joint(name).id for name in result.joint_names]
    contact_bodies = {model.body(name).id for name in contact}
    hand_geoms = np.array(
        [index for index in range(model.ngeom) if model.geom_bodyid[index] in contact_bodies and index != model.geom(pad.name).id],
        dtype=int,
    )
    object_body = model.body("slideplan_object").id
    built = _Model(
        model=model,
        data=data,
        arm_qpos=np.array([model.jnt_qposadr[joint] for joint in arm_joints]),
        arm_dofs=np.array([model.jnt_dofadr[joint] for joint in arm_joints]),
        arm_actuators=np.array([model.actuator(f"servo_{name}").id for name in result.joint_names]),
        spring_qpos=int(model.jnt_qposadr[model.joint(spring.name).id]),
        spring_joint=model.joint(spring.name).id,
        finger_actuators=[model.actuator(f"close_{joint}").id for joint in fingers],
        finger_meet=np.array(meet),
        hand_geoms=hand_geoms,
        pad_geom=model.geom(pad.name).id,
        tip_body=model.body(robot["tip_link"]).id,
        object_body=object_body,
        object_geoms={index for index in range(model.ngeom) if model.geom_bodyid[index] == object_body},
        table_geoms={index for index in range(model.ngeom) if model.geom(index).name.startswith("slideplan_table_")},
    )
    for joint, value in robot["fixed_joints"].items():
        data.qpos[model.jnt_qposadr[model.joint(joint).id]] = value
        data.ctrl[model.actuator(f"hold_{joint}").id] = value
    _set_servo_gains(built, result.start_config, settings)
    return built


def _wxyz(rotation: np.ndarray) -> np.ndarray:
    """MuJoCo's (w, x, y, z) quaternion of a rotation matrix."""
    x, y, z, w = quaternion_from_matrix(rotation)
    return np.array([w, x, y, z])


def _meeting_angle(pivot: np.ndarray, tip: np.ndarray, axis: np.ndarray, grasp_frame: np.ndarray) -> float:
    """Closing angle about ``axis`` through ``pivot`` at which ``tip`` reaches the grasp frame's y = 0 plane."""
    axis = axis / np.linalg.norm(axis)
    arm = tip - pivot
    angles = np.linspace(0.0, _FINGER_RANGE[1], 321)
    turned = (np.outer(np.cos(angles), arm) + np.outer(np.sin(angles), np.cross(axis, arm))
              + np.outer(1.0 - np.cos(angles), axis * (axis @ arm)))  # Rodrigues
    side = (pivot + turned - grasp_frame[:3, 3]) @ grasp_frame[:3, 1]
    crossed = np.flatnonzero(np.sign(side) != np.sign(side[0]))
    return float(angles[crossed[0]] if len(crossed) else angles[-1])


def _subtree_far_point(model, data, body_name: str, pivot: np.ndarray) -> np.ndarray | None:
    """The geom centre farthest from ``pivot`` in a body's subtree, or None if it has no geoms."""
    root = model.body(body_name).id
    far, best = None, -1.0
    for geom in range(model.ngeom):
        body = model.geom_bodyid[geom]
        while body not in (root, 0):
            body = model.body_parentid[body]
        if body != root:
            continue
        centre = data.geom_xpos[geom]
        distance = float(np.linalg.norm(centre - pivot))
        if distance > best:
            far, best = centre.copy(), distance
    return far


def _add_world(spec, result: PlanResult, settings: ExecutionSettings) -> None:
    """Add the table prism and the object (boxes on a grid, one free body) to the spec."""
    import mujoco

    height = float(result.table["height"])
    table = SupportSurface.from_vertices(result.table["polygon"], height, field="table.polygon")
    for index, piece in enumerate(_table_pieces(table.polygon)):
        vertices = np.vstack([
            np.column_stack([piece, np.full(len(piece), height)]),
            np.column_stack([piece, np.full(len(piece), height - _TABLE_THICKNESS)]),
        ])
        spec.add_mesh(name=f"slideplan_table_{index}", uservert=vertices.ravel().tolist())
        spec.worldbody.add_geom(
            name=f"slideplan_table_{index}",
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=f"slideplan_table_{index}",
            contype=_WORLD_CONTYPE,
            conaffinity=_WORLD_CONAFFINITY,
            friction=[settings.table_friction, 0.005, 0.0001],
            rgba=[0.55, 0.45, 0.35, 1],
        )
    thickness = float(result.object["thickness"])
    com = np.asarray(result.object["com_xy"], dtype=float)
    boxes = object_boxes(np.asarray(result.object["points"]), settings.cell_size)
    body = spec.worldbody.add_body(name="slideplan_object", pos=[com[0], com[1], height + thickness / 2])
    body.add_freejoint(name="slideplan_object_free")
    for index, (x, y, half_x, half_y) in enumerate(boxes):
        body.add_geom(
            name=f"slideplan_object_{index}",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[half_x, half_y, thickness / 2],
            pos=[x - com[0], y - com[1], 0.0],
            density=settings.object_density,
            contype=_WORLD_CONTYPE,
            conaffinity=_WORLD_CONAFFINITY,
            friction=[settings.table_friction, 0.005, 0.0001],
            rgba=[0.2, 0.5, 0.8, 1],
        )
    spec.worldbody.add_light(pos=[0.5, 0, 2.0], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)


def _set_servo_gains(built: _Model, config: np.ndarray, settings: ExecutionSettings) -> None:
    """PD gains giving every arm joint the same bandwidth at the configuration's inertia (critical damping)."""
    import mujoco

    model, data = built.model, built.data
    data.qpos[built.arm_qpos] = config
    mujoco.mj_forward(model, data)
    inertia = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, inertia)
    omega = 2 * math.pi * settings.servo_bandwidth_hz
    for actuator, dof in zip(built.arm_actuators, built.arm_dofs):
        mass = inertia[dof, dof]
        kp, kv = mass * omega**2, 2 * mass * omega
        model.actuator_gainprm[actuator, 0] = kp
        model.actuator_biasprm[actuator, 1:3] = (-kp, -kv)


# ----------------------------------------------------------------------------- running


class _Runner:
    """Steps the simulation with the arm servoed along joint paths, checking for instability."""

    def __init__(self, built: _Model, settings: ExecutionSettings, on_frame: Callable[[], None] | None):
        self.built = built
        self.settings = settings
        self.on_frame = on_frame
        # Reading the reference kv/kp ahead is velocity feed-forward to first order.
        self.lead = 1.0 / (math.pi * settings.servo_bandwidth_hz)

    def follow(self, path: np.ndarray, times: np.ndarray, extra_s: float = 0.0, on_step=None) -> None:
        """Servo the arm along ``path`` at ``times`` (s from now), then hold its end for ``extra_s``.

        Raises:
            _Unstable: MuJoCo flagged bad accelerations or a state went non-finite.
        """
        import mujoco

        model, data = self.built.model, self.built.data
        start = data.time
        end = float(times[-1]) + extra_s
        step = 0
        while data.time - start < end - 1e-9:
            elapsed = data.time - start
            data.ctrl[self.built.arm_actuators] = _reference(path, times, elapsed + self.lead)
            if on_step is not None:
                on_step(elapsed, step)
            mujoco.mj_step(model, data)
            step += 1
            if data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0 or not np.isfinite(data.qacc).all():
                raise _Unstable(f"simulation unstable (bad accelerations) at t = {data.time:.3f} s")
            if data.warning[mujoco.mjtWarning.mjWARN_CNSTRFULL].number or data.warning[mujoco.mjtWarning.mjWARN_CONTACTFULL].number:
                raise _Unstable(f"simulation out of contact memory at t = {data.time:.3f} s (contacts were dropped)")
            if self.on_frame is not None:
                self.on_frame()

    def object_pose(self) -> tuple[np.ndarray, float, float]:
        """The object's centre of mass xy, yaw and height."""
        data = self.built.data
        body = self.built.object_body
        rotation = data.xmat[body].reshape(3, 3)
        return data.xpos[body][:2].copy(), math.atan2(rotation[1, 0], rotation[0, 0]), float(data.xpos[body][2])

    def robot_bodies_on_table(self) -> list[str]:
        """Names of the robot bodies touching the table now (e.g. a closing finger it stopped)."""
        model, data = self.built.model, self.built.data
        names = set()
        for index in range(data.ncon):
            geoms = (int(data.contact[index].geom1), int(data.contact[index].geom2))
            for geom, other in (geoms, geoms[::-1]):
                if other in self.built.table_geoms and model.geom_bodyid[geom] != self.built.object_body:
                    names.add(model.body(model.geom_bodyid[geom]).name)
        return sorted(names)

    def pad_normal_force(self) -> float:
        """Total normal force between the fingertip pad and the object (N)."""
        import mujoco

        model, data = self.built.model, self.built.data
        total = 0.0
        wrench = np.zeros(6)
        pad, object_geoms = self.built.pad_geom, self.built.object_geoms
        for index in range(data.ncon):
            contact = data.contact[index]
            pair = (int(contact.geom1), int(contact.geom2))
            if pad in pair and (pair[0] in object_geoms or pair[1] in object_geoms):
                mujoco.mj_contactForce(model, data, index, wrench)
                total += abs(wrench[0])
        return total


def _enable_hand_collisions(built: _Model, enabled: bool) -> None:
    """Let the contact links' own geoms touch the world (grasping) or not (sliding: the pad only)."""
    model = built.model
    model.geom_contype[built.hand_geoms] = _ROBOT_CONTYPE if enabled else 0
    model.geom_conaffinity[built.hand_geoms] = _ROBOT_CONAFFINITY if enabled else 0


def _timing_of(timing: dict[str, Any] | None, key: str, length: int) -> np.ndarray | None:
    """``timing[key].time_from_start`` of a ``slideplan.plan/2`` timing block, if it fits the path."""
    if not timing or key not in timing:
        return None
    times = np.asarray(timing[key].get("time_from_start", []), dtype=float)
    if times.shape != (length,) or not np.all(np.isfinite(times)) or np.any(np.diff(times) < 0):
        raise InputError(f"expected {length} non-decreasing times", field=f"timing.{key}.time_from_start")
    return times - times[0]


def execute(
    result: PlanResult,
    settings: ExecutionSettings | None = None,
    *,
    timing: dict[str, Any] | None = None,
    video: str | Path | None = None,
    video_fps: int = 20,
    video_size: tuple[int, int] = (480, 640),
    progress: Callable[[float], None] | None = None,
) -> Execution:
    """Execute a plan in MuJoCo: slide, let go, approach, grasp, lift and hold (module docstring).

    Args:
        result: a solved plan.
        settings: physical parameters (default :class:`ExecutionSettings`).
        timing: a ``slideplan.plan/2`` ``timing`` block; its ``trajectory`` and ``approach``
            ``time_from_start`` are followed (default: the plan's own ``timing`` attribute). A
            segment it lacks is timed by :func:`slideplan.timing.parameterize` under the limits
            of ``settings`` (:class:`ExecutionSettings`).
        video: write a rendering here: ``.mp4`` or ``.gif``, or ``.png`` for a strip of 6 frames.
        video_fps: frames per simulated second of the video.
        video_size: (height, width) of a frame in pixels.
        progress: called with the simulated time (s) every simulated tenth of a second, e.g. to show
            a progress line (the CLI's ``execute`` does, on runs longer than two seconds).

    Returns:
        The report. An unstable simulation is a report with ``failed_stage == "simulation"``.

    Raises:
        InputError: the plan is not solved, or its robot cannot be imported (naming the element),
            or a mesh is missing, or the timing block does not fit the plan, or TOPP-RA finds no
            timing of a segment this function times itself.
    """
    if result.status != "solved":
        raise InputError(f"plan status is {result.status!r}: only solved plans can be executed", field="status")
    settings = settings or ExecutionSettings()
    timing = timing if timing is not None else getattr(result, "timing", None)
    if video is not None and Path(video).suffix.lower() not in (".mp4", ".gif", ".png"):
        raise InputError(f"expected a .mp4, .gif or .png file, got {str(video)!r}", field="--video")
    os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering without a display
    import mujoco

    wall_start = time.perf_counter()
    built = _build_model(result, settings)
    model, data = built.model, built.data
    trajectory = np.asarray(result.trajectory, dtype=float)
    approach = np.asarray(result.grasp["approach"], dtype=float)
    slide_times = _timing_of(timing, "trajectory", len(trajectory))
    approach_times = _timing_of(timing, "approach", len(approach))
    core_robot = build_robot(result.robot)
    options = _timing_options(settings, core_robot.velocity_limits)
    if slide_times is None or approach_times is None:
        own = parameterize(result, options)
        slide_times = own["trajectory"]["time_from_start"] if slide_times is None else slide_times
        approach_times = own["approach"]["time_from_start"] if approach_times is None else approach_times
    tips = np.asarray(result.fingertip_poses)[:, :3]

    top = float(result.table["height"]) + float(result.object["thickness"])
    depths = top - tips[:, 2]
    table = SupportSurface.from_vertices(result.table["polygon"], float(result.table["height"]), field="table.polygon")
    motion = result.object_motion
    predicted = (float(motion["x"]), float(motion["y"]), float(motion["yaw"]))
    com0 = np.asarray(result.object["com_xy"], dtype=float)
    planned_com = move_planar(com0, predicted)
    tip_path, yaw_travel = path_features(result)

    frames: list[np.ndarray] = []
    renderer, camera = None, None
    if video is not None:
        renderer = mujoco.Renderer(model, *video_size)
        # Shadows and reflections are most of a software-rendered frame's cost (22 ms of 40 at 640x480).
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION):
            renderer.scene.flags[flag] = False
        camera = mujoco.MjvCamera()
        camera.lookat[:] = [*(com0 + np.asarray(table.polygon.centroid.coords[0])) / 2, table.height + 0.1]
        camera.distance, camera.azimuth, camera.elevation = 1.1, 210.0, -30.0

    def after_step() -> None:
        if renderer is not None and data.time * video_fps >= len(frames):
            renderer.update_scene(data, camera)
            frames.append(renderer.render().copy())
        if progress is not None and data.time >= reported[0] + 0.1:
            reported[0] = data.time
            progress(data.time)

    reported = [0.0]
    runner = _Runner(built, settings, after_step if renderer is not None or progress is not None else None)
    report = dict(
        success=False, failed_stage=None, failure="", predicted_motion=dict(zip(("x", "y", "yaw"), predicted)),
        actual_motion=None, position_error_m=None, yaw_error_deg=None, overhang_m=None, com_margin_m=None,
        planned_com_margin_m=table.edge_margin(planned_com), normal_force_n={"mean": 0.0, "min": 0.0, "max": 0.0},
        lifted=False, tip_path_m=tip_path, yaw_travel_deg=math.degrees(yaw_travel),
        settings=dataclasses.asdict(settings),
    )

    def fail(stage: str, message: str) -> None:
        if report["failed_stage"] is None:
            report["failed_stage"], report["failure"] = stage, message

    # Start pressed: the arm at the start configuration, the finger spring compressed by the planned depth.
    _enable_hand_collisions(built, False)
    data.qpos[built.arm_qpos] = trajectory[0]
    data.qpos[built.spring_qpos] = max(depths[0], 0.0)
    mujoco.mj_forward(model, data)
    forces: list[float] = []

    def during_slide(elapsed: float, step: int) -> None:
        if settings.contact_depth is not None:
            planned = float(np.interp(elapsed, slide_times, depths))
            model.qpos_spring[built.spring_qpos] = planned - settings.contact_depth
        if step % _SAMPLE_EVERY == 0 and 0 < elapsed < slide_times[-1]:
            forces.append(runner.pad_normal_force())

    def during_approach(elapsed: float, step: int) -> None:
        if step % _SAMPLE_EVERY == 0 and data.xpos[built.tip_body][2] > top + 0.02:
            _enable_hand_collisions(built, True)

    try:
        if settings.contact_depth is not None:
            model.qpos_spring[built.spring_qpos] = depths[0] - settings.contact_depth
        runner.follow(trajectory, slide_times, _SETTLE_S, during_slide)
        model.qpos_spring[built.spring_qpos] = 0.0
        if forces:
            report["normal_force_n"] = {"mean": float(np.mean(forces)), "min": float(np.min(forces)), "max": float(np.max(forces))}
        com1, yaw1, _ = runner.object_pose()
        actual = (*(com1 - rotation_2d(yaw1) @ com0), yaw1)
        report["actual_motion"] = dict(zip(("x", "y", "yaw"), map(float, actual)))
        report["position_error_m"] = float(np.linalg.norm(com1 - planned_com))
        report["yaw_error_deg"] = math.degrees(wrap_angle(yaw1 - predicted[2]))
        report["overhang_m"] = overhang(table, move_planar(np.asarray(result.object["points"])[:, :2], actual))[0]
        report["com_margin_m"] = table.edge_margin(com1)
        if report["normal_force_n"]["mean"] < _NO_FORCE_N:
            fail("slide", f"no normal force at the fingertip (mean {report['normal_force_n']['mean']:.2f} N): "
                          "the finger does not press, the object does not follow")
        elif report["position_error_m"] > settings.position_tolerance or abs(report["yaw_error_deg"]) > math.degrees(settings.yaw_tolerance):
            fail("slide", f"the object ends {1000 * report['position_error_m']:.1f} mm / {report['yaw_error_deg']:.1f} deg "
                          "from Eq. 2's pose")

        rest_z = float(result.table["height"]) + float(result.object["thickness"]) / 2
        if len(approach):
            runner.follow(approach, approach_times, _SETTLE_S, during_approach)
        _enable_hand_collisions(built, True)
        if runner.object_pose()[2] < rest_z - _FELL_DROP_M:
            fail("release", f"the object fell off the table when the finger let go "
                            f"(CoM {1000 * report['com_margin_m']:.1f} mm inside the edge)")
        grasp_config = np.asarray(result.grasp["config"], dtype=float)
        lift_target = np.asarray(core_robot.frame_pose(grasp_config, result.robot["tip_link"], result.robot["tip_offset"]))
        lift_target[2, 3] += settings.lift_height
        lift_config = core_robot.ik(lift_target, seed=grasp_config, rng_seed=0)
        # Close: the finger's flexure stiffens (the hand squeezes with the closing servos), torque capped.
        model.jnt_stiffness[built.spring_joint] *= 50.0
        for actuator in built.finger_actuators:
            model.actuator_forcerange[actuator] = (-settings.grip_torque, settings.grip_torque)
        # The fingers close at the hand's speed and meet at the grasp plane together: a step lets the light
        # fingers strike a thin object so hard that it flies out, and a finger arriving first (the
        # straight one under a splayed one) lifts the object off the table before the other holds it.
        ramp_s = float(built.finger_meet.max()) / settings.close_speed

        def closing(elapsed: float, step: int) -> None:
            fraction = elapsed / ramp_s
            data.ctrl[built.finger_actuators] = fraction * built.finger_meet if fraction < 1.0 else _CLOSE_TARGET_RAD

        runner.follow(grasp_config[None, :], np.zeros(1), ramp_s + _CLOSE_S, closing)
        on_table = runner.robot_bodies_on_table()
        if lift_config is None:
            fail("grasp", f"no inverse kinematics for the {100 * settings.lift_height:.0f} cm lift")
        else:
            lift = np.linspace(grasp_config, np.asarray(lift_config), 20)
            lift_tips = np.array([np.asarray(core_robot.fk(config))[:3, 3] for config in lift])
            # The lift is not in the plan: timed here, the fingertip capped all the way (it holds the object).
            capped = np.ones(len(lift), dtype=bool)
            lift_times = time_path(lift, lift_tips, capped, resolve_limits(result, options), "lift")["time_from_start"]
            runner.follow(lift, lift_times, settings.hold_s)
            report["lifted"] = runner.object_pose()[2] >= rest_z + _LIFTED_FRACTION * settings.lift_height
            if not report["lifted"]:
                blocked = f" ({', '.join(on_table)} stopped by the table when closing)" if on_table else ""
                fail("grasp", f"the grasp did not lift the object{blocked}")
    except _Unstable as error:
        report.update(actual_motion=None, position_error_m=None, yaw_error_deg=None, overhang_m=None,
                      com_margin_m=None, lifted=False, failed_stage="simulation", failure=str(error))
    finally:
        if renderer is not None:
            renderer.close()
    report["success"] = report["failed_stage"] is None
    execution = Execution(sim_time_s=float(data.time), wall_time_s=time.perf_counter() - wall_start, **report)
    if video is not None:
        write_video(frames, Path(video), video_fps)
    return execution


def write_video(frames: list[np.ndarray], path: Path, fps: int) -> None:
    """Write rendered frames as MP4 or GIF, or a PNG strip of 6 evenly spaced frames.

    Args:
        frames: (H, W, 3) uint8 images.
        path: output file; its suffix picks the format.
        fps: frames per second.
    """
    import imageio.v2 as imageio

    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = path.suffix.lower()
    if suffix == ".png":
        picks = np.linspace(0, len(frames) - 1, min(6, len(frames))).round().astype(int)
        imageio.imwrite(path, np.concatenate([frames[index] for index in picks], axis=1))
    elif suffix == ".gif":
        imageio.mimsave(path, frames, duration=1000 / fps, loop=0)
    else:
        with imageio.get_writer(path, fps=fps, codec="libx264", quality=7, macro_block_size=8) as writer:
            for frame in frames:
                writer.append_data(frame)
