"""The MuJoCo model of a plan: the robot from its URDF with a compliant finger and closing fingers,
the table, and the object as boxes on a grid (the package docstring says why each is so)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np

from ..errors import InputError
from ..plan.robot import merge_urdf, plan_robot, robot_description, search_dirs
from ..plan.result import PlanResult
from .mjscene import add_camera
from ..transforms import quaternion_wxyz
from . import contacts as contact_models
from .contacts import ContactModel
from .convex import convex_parts
from .settings import ExecutionSettings
from .bodies import TABLE_THICKNESS, add_world, cloud_footprint, object_boxes

MESH_SUFFIXES = (".stl", ".obj")  # what MuJoCo reads from a URDF
DEPTH_CAMERA = "slideplan_depth"
BELIEVED_CAMERA = "slideplan_believed"

_PAD_RADIUS = 0.006
_ARENA_BYTES = 128 << 20  # a 20 cm plate has ~500 contacts with the table; MuJoCo's default arena drops them


def _urdf_for_mujoco(robot: dict[str, Any]) -> str:
    """The plan's URDF (with attachments), mesh paths made absolute and MuJoCo's compiler options set.

    Raises:
        InputError: unreadable URDF, a mesh that does not exist or that MuJoCo cannot read.
    """
    from .. import _core

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
                        path = _core.resolve_uri(uri, str(urdf.parent), search_dirs(robot))
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
    # Keep fixed-joint links as bodies: the first contact link gets a compliance joint of its own.
    extension = ElementTree.SubElement(root, "mujoco")
    ElementTree.SubElement(extension, "compiler", fusestatic="false", strippath="false", discardvisual="true")
    return ElementTree.tostring(root, encoding="unicode")


@dataclass(frozen=True)
class Rig:
    """What :func:`build_model` reads of a plan, for a robot that has no plan yet (the simulated robot
    of ``slideplan ros sim``): the robot, table and object, the hand's ``beta0`` and depth band, and the
    configuration the servo gains are set at, and the scene's obstacles. The attribute names are a plan's."""

    robot: dict[str, Any]
    joint_names: list[str]
    params: dict[str, float]
    table: dict[str, Any]
    object: dict[str, Any]
    start_config: np.ndarray
    obstacles: list[dict[str, Any]]

    @classmethod
    def for_scene(cls, scene, obj, config, joint_names: list[str], start_config) -> Rig:
        """A scene's robot and table, ``obj`` (a :class:`~slideplan.world.objects.ThinObject`) and
        ``config``'s hand parameters (a :class:`~slideplan.plan.config.PlannerConfig`)."""
        return cls(robot=robot_description(scene), joint_names=list(joint_names),
                   params={"beta0": config.beta0, "dz_min": config.dz_min, "dz_max": config.dz_max},
                   table={"polygon": np.array(scene.table.vertices, dtype=float), "height": float(scene.table.height)},
                   object={"thickness": float(obj.thickness), "points": obj.points, "com_xy": obj.centroid_xy},
                   start_config=np.asarray(start_config, dtype=float),
                   obstacles=[obstacle.to_dict() for obstacle in scene.obstacles])


@dataclass(frozen=True)
class _GripperKind:
    kp: float  # servo stiffness (N m/rad or N/m): holds the hand open while sliding
    overshoot: float  # how far past closed the squeezing target lies (rad or m): kp * overshoot > the grip


_REVOLUTE, _PRISMATIC = _GripperKind(kp=20.0, overshoot=0.5), _GripperKind(kp=4000.0, overshoot=0.02)
_HOLD_OPEN_LIMIT = 100.0  # N m or N: the open hand is stiff while sliding
_MIMIC_TIME_CONSTANT = 0.004  # s, as the fingertip pad's contact (MuJoCo's default 0.02 let finger 1 of the T42 yield 1 cm)


@dataclass(frozen=True)
class Gripper:
    """The hand's closing joints (``[hand] gripper_joints``) as MuJoCo drives them: position servos
    that hold them open while sliding, then close them together (every joint reaches ``closed``, its
    finger at the grasp plane, at the same moment: a finger arriving first pushes a thin object off
    the table) and squeeze past it with the grip force capped."""

    actuators: np.ndarray
    opened: np.ndarray
    closed: np.ndarray
    prismatic: np.ndarray  # per joint: prismatic (m) rather than revolute (rad)
    limits: np.ndarray  # (n, 2) each joint's range (a squeeze into MuJoCo's soft limit would pass it)

    def __len__(self) -> int:
        return len(self.actuators)

    def ramp_s(self, settings: ExecutionSettings) -> float:
        """How long closing takes at the hand's speeds (s)."""
        speeds = np.where(self.prismatic, settings.close_speed_linear, settings.close_speed)
        return float(np.max(np.abs(self.closed - self.opened) / speeds, initial=0.0))

    def target(self, fraction: float) -> np.ndarray:
        """The servo targets ``fraction`` of the way from open to closed; at 1, past closed (squeezing:
        the grip is capped) as far as the joint's limits allow."""
        if fraction >= 1.0:
            overshoot = np.where(self.prismatic, _PRISMATIC.overshoot, _REVOLUTE.overshoot)
            return np.clip(self.closed + np.sign(self.closed - self.opened) * overshoot, self.limits[:, 0], self.limits[:, 1])
        return self.opened + max(fraction, 0.0) * (self.closed - self.opened)

    def grip(self, model, settings: ExecutionSettings, closing: bool) -> None:
        """Cap the servos' force at the grip (closing) or hold the hand stiffly (open). The grip is what
        the fingers press with: the joint's own friction (the URDF's, e.g. the Z1 jaw's 1 N m) comes on top."""
        friction = model.dof_frictionloss[model.jnt_dofadr[model.actuator_trnid[self.actuators, 0]]]
        limit = np.where(self.prismatic, settings.grip_force, settings.grip_torque) + friction if closing else _HOLD_OPEN_LIMIT
        limit = np.broadcast_to(limit, len(self))
        model.actuator_forcerange[self.actuators] = np.column_stack([-limit, limit])


@dataclass
class Model:
    """The compiled model and the indices the run needs."""

    model: Any
    data: Any
    arm_qpos: np.ndarray  # qpos addresses of the plan's joints
    arm_dofs: np.ndarray
    arm_actuators: np.ndarray
    spring_qpos: int
    spring_joint: int
    gripper: Gripper
    hand_geoms: np.ndarray  # contact-link geoms that only touch things once the finger is lifted
    robot_groups: tuple[int, int]  # (contype, conaffinity) of a robot geom that touches things
    contacts: ContactModel
    pad_geom: int
    object_body: int
    object_geoms: set
    table_geoms: set


def build_model(result: PlanResult | Rig, settings: ExecutionSettings, *, world_object=None, camera=None,
                believed=None, contacts: ContactModel | None = None) -> Model:
    """Build the MuJoCo model of a plan (the package docstring).

    Args:
        result: the plan (robot, table; the object too unless ``world_object`` is given), or a
            :class:`Rig`.
        settings: physical parameters.
        world_object: the object as it really is (a :class:`~slideplan.world.objects.ThinObject`), when the
            plan's is a perception of it; None: the plan's.
        camera: a :class:`~slideplan.perception.camera.Camera` to add as the fixed camera ``slideplan_depth``
            (the closed loop's depth camera), or None.
        believed: where the loop believes that camera is, added as ``slideplan_believed`` (what the robot
            should look like: :mod:`slideplan.perception.calibration`), or None.
        contacts: the contact geometry and solver options (:mod:`.contacts`); None: ``contacts.ACTIVE``.

    Raises:
        InputError: the URDF cannot be imported, naming what MuJoCo complained about.
    """
    import mujoco

    contacts = contacts or contact_models.ACTIVE[0]
    robot = result.robot
    spec, joint_names = _imported_urdf(result)
    concave = _exact_mesh_geoms(spec, robot)
    zero = _AtZero(spec)
    for body, geom in concave:
        _split_into_convex_parts(spec, zero.model, body, geom)
    _mount(spec, robot, zero)
    _dress_robot(spec, settings, contacts.groups)
    spring, pad = _add_compliance(spec, result, settings, zero, contacts.groups)
    gripper_joints = dict(robot["gripper_joints"])
    kinds, limits = _gripper_joints(spec, gripper_joints, joint_names, zero.model)
    _add_actuators(spec, result.joint_names, robot["fixed_joints"], gripper_joints, kinds)
    _add_world(spec, result, settings, world_object, camera, contacts)
    if believed is not None:
        add_camera(spec, BELIEVED_CAMERA, believed)
    try:
        model = spec.compile()
    except ValueError as error:
        raise InputError(f"MuJoCo cannot build the execution model: {' '.join(str(error).split())}",
                         source=str(robot["urdf"])) from None
    gripper = Gripper(
        actuators=np.array([model.actuator(f"close_{joint}").id for joint in gripper_joints], dtype=int),
        opened=np.array([values[0] for values in gripper_joints.values()], dtype=float),
        closed=np.array([values[1] for values in gripper_joints.values()], dtype=float),
        prismatic=np.array([kinds[joint] is _PRISMATIC for joint in gripper_joints], dtype=bool),
        limits=np.array([limits[joint] for joint in gripper_joints], dtype=float).reshape(-1, 2),
    )
    built = _indexed(model, mujoco.MjData(model), result, spring.name, pad.name, gripper, contacts)
    _set_start(built, robot["fixed_joints"], gripper_joints, settings, result.start_config)
    return built


def _imported_urdf(result: PlanResult | Rig) -> tuple[Any, set[str]]:
    """The plan's URDF as MuJoCo imports it, checked to have the plan's links and joints, and its joints' names.

    Raises:
        InputError: MuJoCo cannot import it, or a link or joint the plan names is not in it.
    """
    import mujoco

    robot = result.robot
    try:
        spec = mujoco.MjSpec.from_string(_urdf_for_mujoco(robot))
        spec.compile()
    except ValueError as error:
        raise InputError(f"MuJoCo cannot import the URDF: {' '.join(str(error).split())}", source=str(robot["urdf"])) from None
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
    return spec, joint_names


def _exact_mesh_geoms(spec, robot: dict[str, Any]) -> list[tuple[Any, Any]]:
    """The (body, geom) of the hand meshes the planner checks as their triangles, each named: MuJoCo would
    collide their hulls, which fill the concavity the object enters (convex.py), so each becomes its convex parts."""
    import mujoco

    exact = {(link, str(Path(mesh).resolve())) for link, mesh, _, is_exact in plan_robot(robot).collision_meshes if is_exact}
    concave = []
    for body in spec.bodies:
        for index, geom in enumerate(body.geoms):
            if geom.type == mujoco.mjtGeom.mjGEOM_MESH and (body.name, str(Path(spec.mesh(geom.meshname).file).resolve())) in exact:
                geom.name = f"slideplan_concave_{body.name}_{index}"
                concave.append((body, geom))
    return concave


class _AtZero:
    """The imported robot compiled, its kinematics at qpos0 (every joint 0): the fixed transforms the new joints need."""

    def __init__(self, spec) -> None:
        import mujoco

        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        mujoco.mj_kinematics(self.model, self.data)

    def pose(self, name: str) -> np.ndarray:
        """The 4x4 world pose of body ``name``."""
        body = self.model.body(name).id
        pose = np.eye(4)
        pose[:3, :3] = self.data.xmat[body].reshape(3, 3)
        pose[:3, 3] = self.data.xpos[body]
        return pose


def _mount(spec, robot: dict[str, Any], zero: _AtZero) -> None:
    """Place the robot: the planned chain's base link (default: the URDF root) at base_pose."""
    root_body = spec.worldbody.first_body()
    base_link = robot["base_link"] or root_body.name
    mount = np.asarray(robot["base_pose"]) @ np.linalg.inv(zero.pose(base_link)) @ zero.pose(root_body.name)
    root_body.pos = mount[:3, 3]
    root_body.quat = quaternion_wxyz(mount[:3, :3])


def _dress_robot(spec, settings: ExecutionSettings, groups) -> None:
    """Gravity compensation and soft contacts on every robot body."""
    for body in (body for body in spec.bodies if body.name != "world"):
        body.gravcomp = 1.0  # the arm controller's gravity compensation
        for geom in body.geoms:
            geom.contype, geom.conaffinity = groups.robot
            # Soft finger pads: a contact patch resists twisting and tilting (torsional and rolling friction).
            geom.friction = [settings.pad_friction, settings.torsional_friction, settings.torsional_friction]
            geom.condim = 6


def _add_compliance(spec, result: PlanResult | Rig, settings: ExecutionSettings, zero: _AtZero, groups) -> tuple[Any, Any]:
    """Finger compliance: a slide joint on the first contact link, along the world vertical seen from
    the contact frame at pitch beta0, and a pad whose lowest point is the contact frame.

    Returns:
        The joint and the pad geom (specs).
    """
    import mujoco

    from .. import _core

    robot = result.robot
    contact = set(robot["contact_links"])
    contact_root = next(
        name for name in robot["contact_links"] if spec.body(name).parent.name not in contact
    )
    tip_frame = zero.pose(robot["tip_link"]) @ np.asarray(robot["tip_offset"])
    up_in_tip = _core.contact_rotation(0.0, float(result.params["beta0"])).T @ np.array([0.0, 0.0, 1.0])
    up_world0 = tip_frame[:3, :3] @ up_in_tip
    root_pose = zero.pose(contact_root)
    spring = spec.body(contact_root).add_joint(
        name="slideplan_finger_compliance",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=root_pose[:3, :3].T @ up_world0,
        damping=settings.finger_damping,
        armature=0.002,
        limited=mujoco.mjtLimited.mjLIMITED_TRUE,
        range=[-0.01, float(result.params["dz_max"]) + 0.03],
    )
    spring.stiffness = [settings.spring_stiffness(float(result.params["dz_min"]), float(result.params["dz_max"])), 0.0, 0.0]
    tip_body_pose = zero.pose(robot["tip_link"])
    pad_world = tip_frame[:3, 3] + _PAD_RADIUS * up_world0
    pad = spec.body(robot["tip_link"]).add_geom(
        name="slideplan_pad",
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[_PAD_RADIUS, 0, 0],
        pos=tip_body_pose[:3, :3].T @ (pad_world - tip_body_pose[:3, 3]),
        contype=groups.robot[0],
        conaffinity=groups.robot[1],
        condim=6,
        priority=1,
        friction=[settings.pad_friction, settings.torsional_friction, 0.0001],
        solref=[0.004, 1],
        solimp=[0.3, 0.95, 0.001, 0.5, 2],
        mass=0.001,
        rgba=[0.9, 0.3, 0.2, 1],
    )
    return spring, pad


def _gripper_joints(spec, gripper_joints: dict[str, Any], joint_names: set[str], model0):
    """The hand's own closing joints ([hand] gripper_joints) checked; their mimic joints follow (MuJoCo's
    import makes each mimic an equality constraint, made stiff here).

    Returns:
        Per gripper joint: its _GripperKind, and its range (unlimited: infinite).

    Raises:
        InputError: a joint not in the URDF, neither revolute nor prismatic, or whose open and closed
            values are outside its limits.
    """
    import mujoco

    for equality in spec.equalities:  # a mimic is geared to its joint: MuJoCo's default coupling is soft
        equality.solref = [_MIMIC_TIME_CONSTANT, 1.0]
    kinds = {int(mujoco.mjtJoint.mjJNT_HINGE): _REVOLUTE, int(mujoco.mjtJoint.mjJNT_SLIDE): _PRISMATIC}
    kind_of, limits = {}, {}
    for joint, (opened, closed) in gripper_joints.items():
        field = f"hand.gripper_joints.{joint}"
        if joint not in joint_names:
            raise InputError(f"joint {joint!r} not in the URDF", field=field)
        index = model0.joint(joint).id
        if int(model0.jnt_type[index]) not in kinds:
            raise InputError(f"joint {joint!r} is neither revolute nor prismatic", field=field)
        kind_of[joint] = kinds[int(model0.jnt_type[index])]
        low, high = model0.jnt_range[index] if model0.jnt_limited[index] else (-np.inf, np.inf)
        if not (low <= min(opened, closed) and max(opened, closed) <= high):
            raise InputError(f"[open, closed] = [{opened}, {closed}] is outside the joint's limits [{low}, {high}]", field=field)
        limits[joint] = (low, high)
    return kind_of, limits


def _add_actuators(spec, arm_joints: list[str], fixed_joints: dict[str, float], gripper_joints: dict[str, Any],
                   kinds: dict[str, _GripperKind]) -> None:
    """Arm servos (gains set after compiling, from the inertia), the fixed joints' holds and the fingers' closing servos."""
    import mujoco

    for joint in arm_joints:
        actuator = spec.add_actuator(name=f"servo_{joint}", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=1.0, kv=0.1)
    for joint in fixed_joints:
        if joint in gripper_joints:  # its own closing servo below
            continue
        actuator = spec.add_actuator(name=f"hold_{joint}", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=200.0, kv=5.0)
    for joint in gripper_joints:
        kp = kinds[joint].kp
        actuator = spec.add_actuator(name=f"close_{joint}", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=kp, kv=0.01 * kp)
        actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.forcerange = [-_HOLD_OPEN_LIMIT, _HOLD_OPEN_LIMIT]  # stiff while sliding; capped when closing


def _add_world(spec, result: PlanResult | Rig, settings: ExecutionSettings, world_object, camera,
               contacts: ContactModel) -> None:
    """The table and the object (the plan's, or ``world_object``), the depth camera if any, and the
    simulation's options."""
    if world_object is None:
        points, com = np.asarray(result.object["points"]), np.asarray(result.object["com_xy"], dtype=float)
    else:
        points, com = world_object.points, np.asarray(world_object.centroid_xy, dtype=float)
    add_world(spec, result, settings, points, com, contacts)
    if camera is not None:
        add_camera(spec, DEPTH_CAMERA, camera)
    spec.memory = _ARENA_BYTES
    spec.option.timestep = settings.timestep
    contacts.apply(spec)


def _indexed(model, data, result: PlanResult | Rig, spring: str, pad: str, gripper: Gripper,
             contacts: ContactModel) -> Model:
    """The compiled model with the indices the run needs (``spring`` and ``pad`` the compliance joint's and pad's names)."""
    arm_joints = [model.joint(name).id for name in result.joint_names]
    contact_bodies = {model.body(name).id for name in result.robot["contact_links"]}
    pad_geom = model.geom(pad).id
    hand_geoms = np.array(
        [index for index in range(model.ngeom) if model.geom_bodyid[index] in contact_bodies and index != pad_geom],
        dtype=int,
    )
    object_body = model.body("slideplan_object").id
    return Model(
        model=model,
        data=data,
        arm_qpos=np.array([model.jnt_qposadr[joint] for joint in arm_joints]),
        arm_dofs=np.array([model.jnt_dofadr[joint] for joint in arm_joints]),
        arm_actuators=np.array([model.actuator(f"servo_{name}").id for name in result.joint_names]),
        spring_qpos=int(model.jnt_qposadr[model.joint(spring).id]),
        spring_joint=model.joint(spring).id,
        gripper=gripper,
        hand_geoms=hand_geoms,
        robot_groups=contacts.groups.robot,
        contacts=contacts,
        pad_geom=pad_geom,
        object_body=object_body,
        object_geoms={index for index in range(model.ngeom) if model.geom_bodyid[index] == object_body},
        table_geoms={index for index in range(model.ngeom) if model.geom(index).name.startswith("slideplan_table_")},
    )


def _set_start(built: Model, fixed_joints: dict[str, float], gripper_joints: dict[str, Any], settings: ExecutionSettings,
               start_config) -> None:
    """The start state: fixed joints where the robot description holds them, the hand open, the arm's
    armature and its servo gains at ``start_config``."""
    model, data = built.model, built.data
    for joint, value in fixed_joints.items():
        data.qpos[model.jnt_qposadr[model.joint(joint).id]] = value
        if joint not in gripper_joints:
            data.ctrl[model.actuator(f"hold_{joint}").id] = value
    data.ctrl[built.gripper.actuators] = built.gripper.opened
    model.dof_armature[built.arm_dofs] += settings.joint_armature
    set_servo_gains(built, start_config, settings)


def _split_into_convex_parts(spec, model0, body, geom) -> None:
    """Replace a mesh geom by one geom per convex part of its mesh (placed as ``model0`` placed it)."""
    import mujoco

    compiled = model0.geom(geom.name)
    mesh = int(model0.geom_dataid[compiled.id])
    vertices = model0.mesh_vert[model0.mesh_vertadr[mesh]:model0.mesh_vertadr[mesh] + model0.mesh_vertnum[mesh]]
    faces = model0.mesh_face[model0.mesh_faceadr[mesh]:model0.mesh_faceadr[mesh] + model0.mesh_facenum[mesh]]
    for index, part in enumerate(convex_parts(vertices, faces)):
        name = f"{geom.name}_part{index}"
        spec.add_mesh(name=name, uservert=part.ravel().tolist())
        body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, pos=compiled.pos, quat=compiled.quat,
                      rgba=geom.rgba)
    spec.delete(geom)


def set_servo_gains(built: Model, config: np.ndarray, settings: ExecutionSettings) -> None:
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



def enable_hand_collisions(built: Model, enabled: bool) -> None:
    """Let the contact links' own geoms touch the world (grasping) or not (sliding: the pad only)."""
    model = built.model
    model.geom_contype[built.hand_geoms] = built.robot_groups[0] if enabled else 0
    model.geom_conaffinity[built.hand_geoms] = built.robot_groups[1] if enabled else 0

