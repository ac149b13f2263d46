"""The robot of a scene or a plan: its description (the plan JSON's ``robot`` block), the C++ robot model
built from it (cached and shared: it is immutable), the one builder of collision worlds, and where on the
table the robot reaches (check-scene)."""

from __future__ import annotations

import functools
import json
import math
import re
import warnings
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np
import shapely

from .. import _core
from .._limits import MAX_ROBOT_FILE_BYTES, read_regular_file
from ..errors import InputError, MeshWarning
from ..world.scenes import Scene, package_search_dirs
from ..transforms import homogeneous, rotation_from_rpy, yawed_pose
from .config import PlannerConfig


def base_pose_matrix(base_pose) -> np.ndarray:
    """Convert a scene's robot mount ``[x, y, z, roll, pitch, yaw]`` (URDF rpy convention) to 4x4.

    Args:
        base_pose: 6 numbers (m, rad).

    Returns:
        (4, 4) homogeneous matrix.
    """
    x, y, z, roll, pitch, yaw = (float(value) for value in base_pose)
    return homogeneous(rotation_from_rpy(roll, pitch, yaw), (x, y, z))


def robot_description(scene: Scene) -> dict[str, Any]:
    """The robot and hand keys of a scene as stored in the plan JSON's ``robot`` block.

    Returns:
        ``{"urdf", "attach", "base_pose" (4x4), "base_link", "fixed_joints", "package_dirs",
        "tip_link", "tip_offset" (4x4), "grasp_link", "grasp_offset" (4x4), "contact_links",
        "gripper_joints" ({name: [open, closed]}, their open values also in "fixed_joints")}``.
    """
    return {
        "urdf": str(scene.urdf_path),
        "attach": [str(path) for path in scene.attach],
        "base_pose": base_pose_matrix(scene.base_pose),
        "base_link": scene.base_link,
        # A gripper joint is held open while planning.
        "fixed_joints": {**scene.fixed_joints, **{name: opened for name, (opened, _) in scene.hand.gripper_joints.items()}},
        "package_dirs": [str(path) for path in scene.package_dirs],
        "tip_link": scene.hand.tip_link,
        "tip_offset": base_pose_matrix(scene.hand.tip_offset),
        "grasp_link": scene.hand.grasp_link,
        "grasp_offset": base_pose_matrix(scene.hand.grasp_offset),
        "contact_links": list(scene.hand.contact_links),
        "gripper_joints": {name: list(values) for name, values in scene.hand.gripper_joints.items()},
    }


def merge_urdf(urdf: Path, attach: list[Path]) -> str:
    """The URDF text of ``urdf`` with the links and joints of every ``attach`` file appended.

    Args:
        urdf: the robot's URDF file.
        attach: URDF files whose links and joints join the robot (e.g. a finger on the flange).

    Raises:
        InputError: a file cannot be read, is not a regular file, is larger than
            :data:`~slideplan._limits.MAX_ROBOT_FILE_BYTES` or is not a ``<robot>`` document, naming it
            (and an attached one's field, ``robot.attach[i]``).
    """
    if not attach:
        try:
            return read_regular_file(urdf, MAX_ROBOT_FILE_BYTES, "the URDF").decode()
        except UnicodeDecodeError as error:
            raise InputError(f"not UTF-8 text ({error})", source=str(urdf)) from None
    robot = _urdf_root(urdf)
    for index, path in enumerate(attach):
        robot.extend(list(_urdf_root(path, f"robot.attach[{index}]")))
    return ElementTree.tostring(robot, encoding="unicode")


def _urdf_root(path: Path, field: str = "") -> ElementTree.Element:
    """The ``<robot>`` element of a URDF file (see :func:`merge_urdf`)."""
    try:
        element = ElementTree.fromstring(read_regular_file(path, MAX_ROBOT_FILE_BYTES, "the URDF", field))
    except ElementTree.ParseError as error:
        raise InputError(f"not a URDF ({error})", source=str(path), field=field) from None
    if element.tag != "robot":
        raise InputError(f"not a URDF (root element <{element.tag}>, expected <robot>)", source=str(path), field=field)
    return element


def search_dirs(description: dict[str, Any]) -> list[str]:
    """Where the ``package://`` URIs of a robot block resolve: its own ``package_dirs``, then this
    machine's (:func:`~slideplan.world.scenes.package_search_dirs`; a plan records only its scene's own)."""
    return [str(entry) for entry in package_search_dirs(tuple(Path(entry) for entry in description["package_dirs"]))]


def build_robot(description: dict[str, Any]):
    """Build the C++ robot model from a :func:`robot_description` (or a plan's ``robot`` block).

    Args:
        description: the robot block.

    Returns:
        ``_core.RobotModel``.

    Raises:
        ValueError: naming the file and the key, from the reader or the core.

    Warns:
        MeshWarning: for each hand mesh checked as its triangles (``RobotModel.collision_meshes``).
    """
    urdf = Path(description["urdf"])
    attach = [Path(path) for path in description["attach"]]
    text = merge_urdf(urdf, attach)
    try:
        robot = _core.RobotModel.from_string(
            text,
            source=str(urdf),
            directory=str(urdf.parent),
            tip_link=description["tip_link"],
            base_pose=np.asarray(description["base_pose"], dtype=float),
            base_link=description["base_link"],
            tip_offset=np.asarray(description["tip_offset"], dtype=float),
            fixed_joints=dict(description["fixed_joints"]),
            package_dirs=search_dirs(description),
        )
    except ValueError as error:
        message = str(error)
        for name in description.get("gripper_joints", {}):  # held at its open value, but written in [hand]
            message = message.replace(f"[robot] fixed_joints.{name}:", f"[hand] gripper_joints.{name} (open):")
        raise ValueError(_blame_fragment(message, urdf, attach)) from None
    exact = [f"'{link}' ({Path(mesh).name}: hull {hull_ratio:.2f} x its volume)"
             for link, mesh, hull_ratio, is_exact in robot.collision_meshes if is_exact]
    if exact:  # one warning per robot model, however many meshes
        warnings.warn(f"{len(exact)} hand mesh(es) checked as their triangles, since a convex hull would fill a concavity "
                      f"of the hand: {', '.join(exact)}; exact, but slower than a hull (convex or primitive collision "
                      "shapes plan faster)", MeshWarning, stacklevel=2)
    return robot


def _blame_fragment(message: str, urdf: Path, attach: list[Path]) -> str:
    """The core's message about the merged URDF, naming the attached file instead of ``urdf`` when the
    link or joint it names comes from that file (the core sees one document)."""
    named = set(re.findall(r"\[([^\]]+)\]|'([^']+)'", message))
    named = {name for pair in named for name in pair if name}
    for path in attach:
        elements = _urdf_root(path)  # read by merge_urdf already
        if named & {element.get("name") for element in elements if element.tag in ("link", "joint")}:
            return message.replace(f"{urdf}:", f"{path} (attached to {urdf.name}):", 1)
    return message


@functools.lru_cache(maxsize=16)
def _cached_robot(key: str):
    return build_robot(json.loads(key))


def plan_robot(description: dict[str, Any]):
    """Return the C++ robot model of a plan's ``robot`` block, cached: parsing the URDF and its
    meshes is not free. The model is immutable, so plans in any number of threads share it
    (docs/design.md 9).

    Args:
        description: a :func:`robot_description` (or a plan's ``robot`` block).

    Returns:
        ``_core.RobotModel``.

    Raises:
        InputError: naming the file and the key, if it cannot be loaded.
    """
    try:
        return _cached_robot(json.dumps(description, sort_keys=True, default=lambda value: value.tolist()))
    except (ValueError, RuntimeError) as error:
        raise InputError(f"cannot load robot ({error})", source=str(description["urdf"]), field="robot") from None


def collision_world(robot, table_polygon, table_height: float, obstacles: list[dict[str, Any]], contact_links):
    """The one builder of a ``_core.CollisionWorld``: the robot, the table, the obstacles (plan JSON
    entries, :func:`core_obstacles`); the contact links may touch the object.

    Args:
        robot: ``_core.RobotModel``.
        table_polygon: (n, 2) table vertices; table_height: its top (m).
        obstacles: ``Obstacle.to_dict()`` entries. contact_links: the hand's contact links.
    """
    return _core.CollisionWorld(robot, _core.SupportSurface(np.asarray(table_polygon, dtype=float), float(table_height)),
                                core_obstacles(obstacles), list(contact_links))


def scene_collision_world(scene: Scene):
    """The scene's robot, table and obstacles as a ``_core.CollisionWorld`` (:func:`collision_world`)."""
    return collision_world(robot_model(scene), scene.table.vertices, scene.table.height,
                           [obstacle.to_dict() for obstacle in scene.obstacles], scene.hand.contact_links)


def table_reach(scene: Scene, thickness: float, config: PlannerConfig | None = None, *, grid: int = 5,
                yaws: int = 8) -> float:
    """The share of the table where the contact frame reaches a thin object's top
    (:func:`table_reach_map`'s points reached). What the start roots need: near 0, the robot stands
    where it cannot slide.

    Returns:
        A fraction in [0, 1].
    """
    _, reached = table_reach_map(scene, thickness, config, grid=grid, yaws=yaws)
    return float(reached.mean()) if reached.size else 0.0


def table_reach_map(scene: Scene, thickness: float, config: PlannerConfig | None = None, *, grid: int = 5,
                    yaws: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Where on the table the contact frame reaches a thin object's top: on a ``grid`` x ``grid``
    lattice over the table's bounding box (the points inside the table), the fingertip at pitch
    ``beta0`` and the middle of the depth band, at any of ``yaws`` headings (the slide leaves the
    heading free), by a configuration free of collisions but the finger's.

    Args:
        scene: the scene.
        thickness: the object's (m).
        config: planner parameters (``beta0``, ``dz_min``, ``dz_max``); the scene's hand's by default.

    Returns:
        The lattice points inside the table, (n, 2), and whether each is reached, (n,) bool.
    """
    config = (config or PlannerConfig.for_scene(scene)).resolved(scene)
    robot = robot_model(scene)
    world = scene_collision_world(scene)
    depth = scene.table.height + thickness - 0.5 * (config.dz_min + config.dz_max)
    low, high = scene.table.vertices.min(axis=0), scene.table.vertices.max(axis=0)
    lattice = [low + (high - low) * np.array([i + 0.5, j + 0.5]) / grid for i in range(grid) for j in range(grid)]
    inside = np.array([point for point in lattice if scene.table.polygon.contains(shapely.Point(point))]).reshape(-1, 2)

    def reaches(point: np.ndarray) -> bool:
        for yaw in np.linspace(-math.pi, math.pi, yaws, endpoint=False):
            target = homogeneous(np.asarray(_core.contact_rotation(float(yaw), config.beta0)), (*point, depth))
            joints = robot.ik(target, rng_seed=0, options=_core.contact_ik_options(robot))
            if joints is not None and world.is_valid(joints):
                return True
        return False

    return inside, np.array([reaches(point) for point in inside], dtype=bool)


def robot_model(scene: Scene):
    """Return the scene's C++ robot model (:func:`plan_robot` of its :func:`robot_description`).

    Raises:
        InputError: naming the scene file and the key, if the robot cannot be loaded.
    """
    try:
        return plan_robot(robot_description(scene))
    except InputError as error:
        raise InputError(error.problem, source=scene.source or error.source, field="robot") from None


def core_obstacles(entries: list[dict[str, Any]]) -> list:
    """Plan JSON obstacle entries (``Obstacle.to_dict()``; ``shape`` box, cylinder or object, box if
    absent as in older plans) as the C++ core's obstacles."""
    obstacles = []
    for entry in entries:
        shape = entry.get("shape", "box")
        if shape == "box":
            obstacles.append(_core.BoxObstacle(yawed_pose(entry["center"], entry["yaw"]), np.asarray(entry["size"], dtype=float)))
        elif shape == "cylinder":
            obstacles.append(_core.CylinderObstacle(yawed_pose(entry["center"], 0.0), entry["radius"], entry["height"]))
        else:
            obstacles.append(_core.PrismObstacle(np.asarray(entry["polygon"], dtype=float), entry["bottom"], entry["height"]))
    return obstacles
