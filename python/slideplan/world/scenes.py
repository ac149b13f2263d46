"""Scenes: the table, the robot and its mount, and obstacles, read from TOML (docs/design.md sec. 5)."""

from __future__ import annotations

import os
import site
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
import shapely.geometry

from .._fields import Fields, read_toml
from .._limits import MAX_SCENE_MAGNITUDE
from ..errors import InputError, require_type
from .geometry import SupportSurface
from ..parameters import BY_NAME as PARAMETERS_BY_NAME
from ..parameters import HAND_NAMES
from ..paths import data_dir, find_data_file
from ..transforms import move_planar

ROBOT_KEYS = {"urdf", "attach", "base_pose", "base_link", "fixed_joints", "package_dirs"}
LEGACY_HAND_KEYS = ("tip_link", "contact_links")  # once in [robot], now in [hand]; still read there
HAND_KEYS = {"tip_link", "tip_offset", "grasp_link", "grasp_offset", "contact_links", "gripper_joints", "params"}


def default_robot_file() -> Path:
    """The robot and hand of scenes that do not describe their own: ``data/robots/default.toml``."""
    return data_dir() / "robots" / "default.toml"


@dataclass(frozen=True, eq=False)
class BoxObstacle:
    """A box (rotated about z only) on or above the table.

    Attributes:
        center: (3,) box centre in the world frame (m).
        size: (3,) full extents along the box's x, y, z (m), each > 0.
        yaw: rotation about the world z axis (rad).
    """

    center: np.ndarray
    size: np.ndarray
    yaw: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """The plan JSON entry."""
        return {"shape": "box", "center": np.asarray(self.center, float), "size": np.asarray(self.size, float), "yaw": float(self.yaw)}


@dataclass(frozen=True, eq=False)
class CylinderObstacle:
    """An upright cylinder standing on the table: a can, a mug.

    Attributes:
        center: (3,) centre of the cylinder (m); it stands on the table, so z = table height + height / 2.
        radius: (m), > 0.
        height: (m), > 0.
    """

    center: np.ndarray
    radius: float
    height: float

    def to_dict(self) -> dict[str, Any]:
        """The plan JSON entry."""
        return {"shape": "cylinder", "center": np.asarray(self.center, float), "radius": float(self.radius),
                "height": float(self.height)}


@dataclass(frozen=True, eq=False)
class ObjectObstacle:
    """Another thin object lying on the table, as a prism over its convex footprint.

    Attributes:
        name: its label.
        polygon: (n, 2) convex footprint in the world frame, counter-clockwise (m).
        bottom: z of its underside, the table top (m).
        height: its thickness (m).
    """

    name: str
    polygon: np.ndarray
    bottom: float
    height: float

    def to_dict(self) -> dict[str, Any]:
        """The plan JSON entry."""
        return {"shape": "object", "name": self.name, "polygon": np.asarray(self.polygon, float),
                "bottom": float(self.bottom), "height": float(self.height)}


Obstacle = BoxObstacle | CylinderObstacle | ObjectObstacle


def obstacle_footprint(entry: dict[str, Any]):
    """An obstacle's footprint on the table and its bottom height.

    Args:
        entry: an obstacle's plan JSON entry (``Obstacle.to_dict()``; no ``shape``: a box).

    Returns:
        (shapely polygon in world xy, z of the obstacle's bottom).
    """
    shape = entry.get("shape", "box")
    if shape == "box":
        corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * np.asarray(entry["size"][:2]) / 2
        motion = (*entry["center"][:2], entry["yaw"])
        return shapely.Polygon(move_planar(corners, motion)), entry["center"][2] - entry["size"][2] / 2
    if shape == "cylinder":
        return shapely.Point(entry["center"][:2]).buffer(entry["radius"], quad_segs=32), entry["center"][2] - entry["height"] / 2
    return shapely.Polygon(entry["polygon"]), entry["bottom"]


@dataclass(frozen=True, eq=False)
class Hand:
    """The hand: which frames touch, grasp and may penetrate (docs/design.md 3 and 5, ``[hand]``).

    Attributes:
        tip_link: the link carrying the contact frame ``F``.
        tip_offset: (6,) ``F`` in that link's frame: x, y, z, roll, pitch, yaw (m, rad; URDF rpy).
            ``X_F`` is the contact line, ``Z_F`` points from the fingertip into the object.
        grasp_link: the link carrying the grasp frame ``H_g``.
        grasp_offset: (6,) ``H_g`` in that link's frame; ``z`` is the approach direction and ``y``
            the fingers' closing axis.
        contact_links: links that may touch (virtually penetrate) the table and the object while
            sliding: the compliant finger.
        params: this hand's planner parameter defaults (``beta0``, ``dz_min``, ``dz_max``,
            ``u_star``, ...), below any parameter the user sets.
        gripper_joints: the URDF joints that close the hand (revolute or prismatic; their mimic
            joints follow), each as ``(open, closed)``: held at ``open`` while planning, and closed
            to ``closed``, where its finger reaches the grasp plane (``y = 0`` of ``H_g``), when
            execution grasps. Empty: nothing closes (a rigid finger).
    """

    tip_link: str
    tip_offset: np.ndarray
    grasp_link: str
    grasp_offset: np.ndarray
    contact_links: tuple[str, ...]
    params: dict[str, float] = field(default_factory=dict)
    gripper_joints: dict[str, tuple[float, float]] = field(default_factory=dict)


@dataclass(eq=False)
class Scene:
    """Everything about the world the planner needs besides the object.

    Attributes:
        name: a label (the file name without suffix for loaded scenes).
        table: the support surface.
        urdf_path: the robot description.
        attach: URDF files whose links and joints join the robot's (e.g. a finger on a flange).
        base_pose: (6,) world pose of the URDF root link: x, y, z, roll, pitch, yaw (m, rad).
        base_link: root of the planned chain ("" : the URDF root); joints above it are held.
        fixed_joints: joints off the planned chain held at a value (m or rad); mimic joints follow.
            Other joints off the chain are held at 0 (clamped into their limits).
        package_dirs: the scene's own directories where ``package://NAME/...`` resolves first (absolute;
            :func:`package_search_dirs` adds this machine's).
        uris: the ``package://`` URIs the scene named its robot files by, by resolved path (a scene
            written from this one names them so again, and opens on another machine).
        hand: the contact and grasp frames and the contact links.
        obstacles: boxes, cylinders and other thin objects: the arm avoids them, the sliding object
            does not overlap them.
        source: the file the scene was read from ("" if built in code).
    """

    name: str
    table: SupportSurface
    urdf_path: Path
    base_pose: np.ndarray
    hand: Hand
    attach: tuple[Path, ...] = ()
    base_link: str = ""
    fixed_joints: dict[str, float] = field(default_factory=dict)
    package_dirs: tuple[Path, ...] = ()
    obstacles: tuple[Obstacle, ...] = ()
    source: str = ""
    uris: dict[Path, str] = field(default_factory=dict)

    def footprints(self, object_top: float):
        """The union of the footprints of the obstacles reaching below ``object_top`` (shapely), or None."""
        shapes = [shape for shape, bottom in (obstacle_footprint(o.to_dict()) for o in self.obstacles) if bottom < object_top]
        return shapely.union_all(shapes) if shapes else None

    @property
    def tip_link(self) -> str:
        """The link of the contact frame (``hand.tip_link``)."""
        return self.hand.tip_link

    @property
    def contact_links(self) -> tuple[str, ...]:
        """The links that may touch table and object while sliding (``hand.contact_links``)."""
        return self.hand.contact_links

    @classmethod
    def default(cls) -> Scene:
        """Return the built-in ``square`` scene."""
        return load_scene("square")


def _read_table(fields: Fields) -> SupportSurface:
    table = fields.table("table", allowed={"polygon", "circle", "height"}, required=True)
    height = table.number("height", 0.0)
    if table.has("polygon") == table.has("circle"):
        raise InputError("give exactly one of 'polygon' and 'circle'", source=fields.source, field="table")
    if table.has("polygon"):
        return SupportSurface.from_vertices(
            table.xy_points("polygon"), height, source=fields.source, field=table.field("polygon")
        )
    circle = table.table("circle", allowed={"center", "radius", "points"})
    return SupportSurface.circle(
        circle.numbers("center", 2), circle.number("radius", positive=True), circle.raw("points", 100), height,
        source=fields.source, field=table.field("circle"),
    )


def package_search_dirs(extra=()) -> tuple[Path, ...]:
    """Where ``package://NAME/...`` URIs resolve, first match wins.

    Args:
        extra: the scene's ``package_dirs`` (already absolute).

    Returns:
        ``extra``, then each entry of ``ROS_PACKAGE_PATH``, then the ``share`` directories of
        installed Python packages (``<prefix>/share`` and ``<site-packages>/cmeel.prefix/share``,
        where e.g. ``example-robot-data`` installs), then the site-packages directories
        themselves. Only existing directories are kept.
    """
    ros = [Path(entry) for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if entry]
    sites = [Path(entry) for entry in [*site.getsitepackages(), site.getusersitepackages(), *sys.path] if entry]
    shares = [Path(sys.prefix) / "share", *(entry / "cmeel.prefix" / "share" for entry in sites)]
    ordered = dict.fromkeys(path for path in [*extra, *ros, *shares, *sites] if path.is_dir())
    return tuple(ordered)


def _resolve_robot_file(text: str, *, source: str, field: str, scene_dir: Path, package_dirs: tuple[Path, ...]) -> Path:
    """A URDF named in a scene: ``package://NAME/...``, else a path relative to the scene's directory,
    then to ``data/robots``; absolute (a plan records it, and is opened from anywhere)."""
    from .. import _core

    if text.startswith("package://"):
        try:
            return Path(_core.resolve_uri(text, str(scene_dir), [str(path) for path in package_dirs])).absolute()
        except ValueError as error:
            raise InputError(_missing_in_package(text, package_dirs) or str(error), source=source, field=field) from None
    urdf = Path(text)
    candidates = [urdf] if urdf.is_absolute() else [scene_dir / urdf, data_dir() / "robots" / urdf]
    for candidate in candidates:
        if candidate.is_file():
            return Path(os.path.normpath(candidate.absolute()))
    raise InputError(
        f"file not found (looked for {', '.join(str(candidate) for candidate in candidates)})", source=source, field=field
    )


def _missing_in_package(uri: str, package_dirs: tuple[Path, ...]) -> str | None:
    """For a ``package://NAME/REL`` that does not resolve, where NAME is though REL is not in it (a mistyped
    file, not a missing package), or None if no search directory has NAME."""
    name, _, inside = uri.removeprefix("package://").partition("/")
    for directory in package_dirs:
        for package in (directory / name, directory):  # as the resolver looks: share/NAME, or NAME itself
            if package.name == name and package.is_dir():
                return f"{uri}: package '{name}' is at {package}, but it has no file {inside}"
    return None


def _read_obstacle(obstacle: Fields, table: SupportSurface, scene_dir: Path) -> Obstacle:
    """One [[obstacles]] entry: a box (default), a cylinder standing on the table, or a thin object."""
    shape = obstacle.string("shape", "box")
    if shape == "box":
        obstacle.only({"shape", "center", "size", "yaw"})
        size = obstacle.numbers("size", 3, positive=True)
        return BoxObstacle(obstacle.numbers("center", 3), size, obstacle.number("yaw", 0.0))
    if shape == "cylinder":
        obstacle.only({"shape", "center", "radius", "height"})
        height = obstacle.number("height", positive=True)
        x, y = obstacle.numbers("center", 2)
        return CylinderObstacle(np.array([x, y, table.height + height / 2]), obstacle.number("radius", positive=True), height)
    if shape == "object":
        from .objects import load_object

        obstacle.only({"shape", "object", "pose"})
        spec = obstacle.string("object")
        path = scene_dir / spec
        spec = str(path) if path.is_file() else spec
        pose = obstacle.numbers("pose", 3) if obstacle.has("pose") else None
        try:
            thin = load_object(spec, table_height=table.height, pose=pose)
        except InputError as error:
            inner = f": {error.field}" if error.field else ""  # the object file's own field, e.g. thickness
            raise InputError(error.problem, source=obstacle.source, field=f"{obstacle.field('object')} ({spec}{inner})") from None
        hull = shapely.MultiPoint(thin.points[:, :2]).convex_hull
        if hull.geom_type != "Polygon":
            raise InputError("the object's footprint has no area", source=obstacle.source, field=obstacle.field("object"))
        ring = shapely.geometry.polygon.orient(hull, 1.0).exterior.coords[:-1]
        return ObjectObstacle(thin.name, np.array(ring), table.height, thin.thickness)
    raise InputError(f"unknown shape {shape!r} (expected box, cylinder or object)", source=obstacle.source,
                     field=obstacle.field("shape"))


def _read_offset(fields: Fields, key: str) -> np.ndarray:
    """An ``[x, y, z, roll, pitch, yaw]`` offset (default: identity)."""
    return fields.numbers(key, 6, np.zeros(6))


def _read_fixed_joints(robot: Fields) -> dict[str, float]:
    joints = robot.raw("fixed_joints", {})
    if not isinstance(joints, dict):
        raise InputError(f"expected a table of joint = value, got {joints!r}", source=robot.source, field=robot.field("fixed_joints"))
    values = Fields(joints, source=robot.source, prefix=robot.field("fixed_joints"), allowed=set(joints), bound=robot.bound)
    return {name: values.number(name) for name in joints}


def _read_package_dirs(robot: Fields, scene_dir: Path) -> tuple[Path, ...]:
    if not robot.has("package_dirs"):
        return ()
    dirs = tuple(scene_dir / entry for entry in robot.strings("package_dirs"))
    for entry in dirs:
        if not entry.is_dir():
            raise InputError(f"no such directory: {entry}", source=robot.source, field=robot.field("package_dirs"))
    return dirs


def _read_gripper_joints(hand: Fields, robot: Fields) -> dict[str, tuple[float, float]]:
    joints = hand.raw("gripper_joints", {})
    if not isinstance(joints, dict):
        raise InputError(f"expected a table of joint = [open, closed], got {joints!r}", source=hand.source,
                         field=hand.field("gripper_joints"))
    values = Fields(joints, source=hand.source, prefix=hand.field("gripper_joints"), allowed=set(joints), bound=hand.bound)
    read = {}
    for name in joints:
        opened, closed = values.numbers(name, 2)
        if opened == closed:
            raise InputError(f"open and closed are both {opened!r}: the joint would not move", source=hand.source,
                             field=values.field(name))
        if robot.has("fixed_joints") and name in robot.raw("fixed_joints"):
            raise InputError(f"also held in {robot.field('fixed_joints')}: a gripper joint is held at its open value",
                             source=hand.source, field=values.field(name))
        read[name] = (float(opened), float(closed))
    return read


def _read_hand(hand: Fields, robot: Fields) -> Hand:
    params = hand.table("params", allowed=set(HAND_NAMES))
    return Hand(
        tip_link=hand.string("tip_link"),
        tip_offset=_read_offset(hand, "tip_offset"),
        grasp_link=hand.string("grasp_link"),
        grasp_offset=_read_offset(hand, "grasp_offset"),
        contact_links=hand.strings("contact_links"),
        params={name: _hand_param(params, name) for name in HAND_NAMES if params and params.has(name)},
        gripper_joints=_read_gripper_joints(hand, robot),
    )


def _hand_param(params: Fields, name: str):
    """A [hand] params value of the registry's type (its bounds are PlannerConfig's to check)."""
    kind = PARAMETERS_BY_NAME[name].kind
    if kind == "real":
        return params.number(name)
    value = params.raw(name)
    if kind == "bool" and not isinstance(value, bool):
        raise InputError(f"expected true or false, got {value!r}", source=params.source, field=params.field(name))
    if kind == "int" and (isinstance(value, bool) or not isinstance(value, int)):
        raise InputError(f"expected an integer, got {value!r}", source=params.source, field=params.field(name))
    return value


def _robot_and_hand(fields: Fields) -> tuple[Fields, Fields]:
    """The scene's [robot] and [hand], completed from data/robots/default.toml.

    A scene that names no URDF gets the default robot and hand, key by key under its own; a scene
    with its own URDF describes its own hand. The older ``[robot] tip_link / contact_links`` are
    read as [hand] keys.
    """
    given = fields.table("robot", allowed=ROBOT_KEYS | set(LEGACY_HAND_KEYS))  # a table without unknown keys
    fields.table("hand", allowed=HAND_KEYS)
    robot, hand = dict(fields.raw("robot", {})), dict(fields.raw("hand", {}))
    for key in LEGACY_HAND_KEYS:
        if key in robot:
            (given.string if key == "tip_link" else given.strings)(key)  # errors name [robot], where it is written
            if key in hand:
                raise InputError("given in both [robot] and [hand]; keep the [hand] one", source=fields.source, field=f"robot.{key}")
            hand[key] = robot.pop(key)
    if "urdf" not in robot:
        defaults = read_toml(default_robot_file())
        robot = {**defaults["robot"], **robot}
        hand = {**defaults["hand"], **hand}
    return (
        Fields(robot, source=fields.source, prefix="robot", allowed=ROBOT_KEYS, bound=fields.bound),
        Fields(hand, source=fields.source, prefix="hand", allowed=HAND_KEYS, bound=fields.bound),
    )


def load_scene(name_or_path: str | Path) -> Scene:
    """Read a scene file.

    Format (TOML, metres and radians, none beyond :data:`~slideplan._limits.MAX_SCENE_MAGNITUDE` in
    magnitude)::

        [table]
        polygon = [[x, y], ...]          # or: circle = { center = [x, y], radius = r, points = 100 }
        height = 0.0                     # optional, z of the table top
        [robot]                          # optional
        urdf = "wam_t42.urdf"            # relative to the scene file's directory, then data/robots/;
                                         # or package://NAME/... (see package_search_dirs)
        attach = ["finger.urdf"]         # optional: URDF files whose links and joints join the robot
        package_dirs = ["share"]         # optional, relative to the scene file
        base_pose = [x, y, z, roll, pitch, yaw]       # world pose of the URDF root, default all zero
        base_link = "panda_link0"        # optional: root of the planned chain
        fixed_joints = { panda_finger_joint1 = 0.02 } # optional: joints off the chain held at a value
        [hand]                           # optional (see Hand)
        tip_link = "fingertip_contact"
        tip_offset = [x, y, z, roll, pitch, yaw]      # optional
        grasp_link = "t42_grasp"
        grasp_offset = [x, y, z, roll, pitch, yaw]    # optional
        contact_links = ["t42_finger1_proximal", "t42_finger1_distal"]
        gripper_joints = { t42_finger2_base = [0.0, 1.01] }   # optional: joint = [open, closed]
        params = { beta0 = 1.0, dz_min = 0.005, dz_max = 0.025, u_star = 0.02 }   # optional
        [[obstacles]]                    # optional, repeatable
        center = [x, y, z]
        size = [sx, sy, sz]              # full extents
        yaw = 0.0                        # optional

    Args:
        name_or_path: a built-in scene name (``square``, ``round``, ``triangle``, ``long``)
            or a TOML file.

    Returns:
        The scene.

    Raises:
        InputError: "file: field: what is wrong" for an unknown name, a missing file,
            bad TOML, or any unknown, missing or mistyped field.
    """
    require_type(name_or_path, (str, os.PathLike), "name_or_path", "a scene name or a file path")
    path = find_data_file(name_or_path, "scenes")
    # Every length and angle within MAX_SCENE_MAGNITUDE: a robot's workspace, not 1e308.
    fields = Fields(read_toml(path), source=str(path), allowed={"table", "robot", "hand", "obstacles"}, bound=MAX_SCENE_MAGNITUDE)
    table = _read_table(fields)
    robot, hand = _robot_and_hand(fields)
    obstacles = fields.array_of_tables(
        "obstacles", allowed={"shape", "center", "size", "yaw", "radius", "height", "object", "pose"}
    )
    package_dirs = tuple(entry.absolute() for entry in _read_package_dirs(robot, path.parent))
    attach = robot.strings("attach") if robot.has("attach") else ()
    uris: dict[Path, str] = {}

    def resolve(text: str, field: str) -> Path:
        resolved = _resolve_robot_file(text, source=str(path), field=field, scene_dir=path.parent,
                                       package_dirs=package_search_dirs(package_dirs))
        if text.startswith("package://"):
            uris[resolved] = text
        return resolved

    return Scene(
        name=path.stem,
        uris=uris,
        table=table,
        urdf_path=resolve(robot.string("urdf"), robot.field("urdf")),
        attach=tuple(resolve(text, f"{robot.field('attach')}[{index}]") for index, text in enumerate(attach)),
        base_pose=robot.numbers("base_pose", 6, np.zeros(6)),
        base_link=robot.string("base_link") if robot.has("base_link") else "",
        fixed_joints=_read_fixed_joints(robot),
        package_dirs=package_dirs,
        hand=_read_hand(hand, robot),
        obstacles=tuple(_read_obstacle(obstacle, table, path.parent) for obstacle in obstacles),
        source=str(path),
    )


def robot_toml(scene: Scene, directory: Path | None = None, base_pose=None) -> list[str]:
    """The scene's ``[robot]`` and ``[hand]`` sections as TOML lines, so a scene file written elsewhere
    (e.g. by ``slideplan perceive``) plans with the same robot and hand, on this machine or another:
    robot files named by ``package://`` as the scene named them, bundled ones by name, others (and
    ``package_dirs``) relative to ``directory`` (absolute without one).

    Args:
        scene: a loaded scene.
        directory: where the written file will be.
        base_pose: the mount to write instead of the scene's (6 numbers).

    Returns:
        The lines, without a trailing blank line.
    """

    def text(value: str) -> str:
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'

    def numbers(values) -> str:
        return "[" + ", ".join(repr(float(value)) for value in values) + "]"

    def strings(values) -> str:
        return "[" + ", ".join(text(str(value)) for value in values) + "]"

    def located(path: Path) -> str:
        return os.path.relpath(path.absolute(), directory.absolute()) if directory is not None else str(path.absolute())

    def reference(path: Path) -> str:
        # A bundled file by its name (load_scene also looks in data/robots/), so the scene file can move.
        bundled = data_dir() / "robots" / path.name
        if path in scene.uris:
            return scene.uris[path]
        return path.name if bundled.is_file() and bundled.resolve() == path.resolve() else located(path)

    mount = scene.base_pose if base_pose is None else base_pose
    robot = ["[robot]", f"urdf = {text(reference(scene.urdf_path))}", f"base_pose = {numbers(mount)}"]
    if scene.attach:
        robot.append(f"attach = {strings(reference(path) for path in scene.attach)}")
    if scene.package_dirs:
        robot.append(f"package_dirs = {strings(located(path) for path in scene.package_dirs)}")
    if scene.base_link:
        robot.append(f"base_link = {text(scene.base_link)}")
    if scene.fixed_joints:
        robot.append("fixed_joints = { " + ", ".join(f"{text(name)} = {value!r}" for name, value in scene.fixed_joints.items()) + " }")
    hand = scene.hand
    lines = robot + [
        "",
        "[hand]",
        f"tip_link = {text(hand.tip_link)}",
        f"tip_offset = {numbers(hand.tip_offset)}",
        f"grasp_link = {text(hand.grasp_link)}",
        f"grasp_offset = {numbers(hand.grasp_offset)}",
        f"contact_links = {strings(hand.contact_links)}",
    ]
    if hand.gripper_joints:
        lines.append("gripper_joints = { " + ", ".join(f"{text(name)} = {numbers(values)}"
                                                       for name, values in hand.gripper_joints.items()) + " }")
    if hand.params:
        lines.append("params = { " + ", ".join(f"{name} = {str(value).lower() if isinstance(value, bool) else repr(value)}"
                                               for name, value in hand.params.items()) + " }")
    return lines

