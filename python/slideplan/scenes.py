"""Scenes: the table, the robot and its mount, and obstacles, read from TOML (DESIGN.md sec. 5)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._fields import Fields, read_toml
from .errors import InputError
from .geometry import SupportSurface
from .paths import data_dir, find_data_file

DEFAULT_URDF_NAME = "wam_t42.urdf"
DEFAULT_TIP_LINK = "fingertip_contact"
DEFAULT_CONTACT_LINKS = ("t42_finger1_proximal", "t42_finger1_distal")


def default_urdf_path() -> Path:
    """Return the bundled WAM + T42 URDF, ``data/robots/wam_t42.urdf``."""
    return data_dir() / "robots" / DEFAULT_URDF_NAME


@dataclass(frozen=True, eq=False)
class BoxObstacle:
    """An axis-aligned-in-yaw box on or above the table.

    Attributes:
        center: (3,) box centre in the world frame (m).
        size: (3,) full extents along the box's x, y, z (m), each > 0.
        yaw: rotation about the world z axis (rad).
    """

    center: np.ndarray
    size: np.ndarray
    yaw: float = 0.0


@dataclass(eq=False)
class Scene:
    """Everything about the world the planner needs besides the object.

    Attributes:
        name: a label (the file name without suffix for loaded scenes).
        table: the support surface.
        urdf_path: the robot description.
        base_pose: (6,) robot base pose in the world: x, y, z, roll, pitch, yaw (m, rad).
        tip_link: the URDF link whose frame is the fingertip contact frame ``F``.
        contact_links: finger links allowed to penetrate the table and object (the
            virtual penetration that stands for the finger's compliance).
        obstacles: boxes to avoid.
        source: the file the scene was read from ("" if built in code).
    """

    name: str
    table: SupportSurface
    urdf_path: Path = field(default_factory=default_urdf_path)
    base_pose: np.ndarray = field(default_factory=lambda: np.zeros(6))
    tip_link: str = DEFAULT_TIP_LINK
    contact_links: tuple[str, ...] = DEFAULT_CONTACT_LINKS
    obstacles: tuple[BoxObstacle, ...] = ()
    source: str = ""

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
    points = circle.raw("points", 100)
    if isinstance(points, bool) or not isinstance(points, int) or points < 3:
        raise InputError(f"expected an integer >= 3, got {points!r}", source=fields.source, field=circle.field("points"))
    return SupportSurface.circle(circle.numbers("center", 2), circle.number("radius", positive=True), points, height)


def _resolve_urdf(robot: Fields, scene_dir: Path) -> Path:
    if not robot.has("urdf"):
        return default_urdf_path()
    urdf = Path(robot.string("urdf"))
    candidates = [urdf] if urdf.is_absolute() else [scene_dir / urdf, data_dir() / "robots" / urdf]
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    raise InputError(
        f"file not found (looked for {', '.join(str(candidate) for candidate in candidates)})",
        source=robot.source,
        field=robot.field("urdf"),
    )


def _read_obstacle(obstacle: Fields) -> BoxObstacle:
    size = obstacle.numbers("size", 3)
    if np.any(size <= 0):
        raise InputError(f"extents must be > 0, got {size.tolist()}", source=obstacle.source, field=obstacle.field("size"))
    return BoxObstacle(obstacle.numbers("center", 3), size, obstacle.number("yaw", 0.0))


def load_scene(name_or_path: str | Path) -> Scene:
    """Read a scene file.

    Format (TOML, metres and radians)::

        [table]
        polygon = [[x, y], ...]          # or: circle = { center = [x, y], radius = r, points = 100 }
        height = 0.0                     # optional, z of the table top
        [robot]                          # optional
        urdf = "wam_t42.urdf"            # relative to the scene file's directory, then data/robots/
        base_pose = [x, y, z, roll, pitch, yaw]       # default all zero
        tip_link = "fingertip_contact"
        contact_links = ["t42_finger1_proximal", "t42_finger1_distal"]
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
    path = find_data_file(name_or_path, "scenes")
    fields = Fields(read_toml(path), source=str(path), allowed={"table", "robot", "obstacles"})
    table = _read_table(fields)
    robot = fields.table("robot", allowed={"urdf", "base_pose", "tip_link", "contact_links"})
    robot = robot or Fields({}, source=fields.source, prefix="robot", allowed=set())
    obstacles = fields.array_of_tables("obstacles", allowed={"center", "size", "yaw"})
    return Scene(
        name=path.stem,
        table=table,
        urdf_path=_resolve_urdf(robot, path.parent),
        base_pose=robot.numbers("base_pose", 6, np.zeros(6)),
        tip_link=robot.string("tip_link", DEFAULT_TIP_LINK),
        contact_links=robot.strings("contact_links", DEFAULT_CONTACT_LINKS),
        obstacles=tuple(_read_obstacle(obstacle) for obstacle in obstacles),
        source=str(path),
    )
