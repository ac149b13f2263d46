"""Thin objects: top-surface point clouds ``P_o`` built from outlines or loaded from files."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import plyfile
import shapely
import shapely.affinity
from shapely.geometry import Polygon

from .._fields import Fields, as_number, as_numbers, as_xy_points, read_toml
from ..errors import InputError, require_type
from .geometry import SupportSurface, area_centroid, simple_polygon_vertices
from ..paths import find_data_file
from ..transforms import move_planar, rotation_2d

CLOUD_SUFFIXES = (".ply", ".npy", ".csv", ".pcd")
DEFAULT_THICKNESS = 0.004  # m; a few mm, like the paper's objects
SYMMETRY_TOLERANCE_M = 0.0005  # a turn moving no outline point further than this leaves it as it was
_MAX_SAMPLES = 2_000_000  # guards against a resolution typo (e.g. 5e-6) eating all memory


@dataclass(frozen=True, eq=False)
class ThinObject:
    """A thin flat object lying on the table, as the planner sees it.

    Build it with :meth:`from_outline`, :meth:`from_points` or :func:`load_object`.

    Attributes:
        points: (N, 3) top-surface point cloud ``P_o`` in the world frame (read-only).
        thickness: object thickness (m): the top surface is at ``z_table + thickness``.
        name: a label for plots and logs.
        outline: the object's outline in the world frame (for plots), None for clouds.
    """

    points: np.ndarray
    thickness: float
    name: str = ""
    outline: Polygon | None = None

    def __post_init__(self) -> None:
        """Refuse what the planner cannot take, for an object built directly rather than by a loader
        (an (N, 2) cloud reached the core as an IndexError)."""
        points = self.points
        if not (isinstance(points, np.ndarray) and points.ndim == 2 and points.shape[1] == 3 and len(points) >= 3
                and points.dtype.kind == "f" and np.isfinite(points).all()):
            raise InputError(f"expected an (N, 3) float array of finite numbers, N >= 3, got "
                             f"{type(points).__name__} {np.shape(points)}", field="points")
        as_number(self.thickness, source="", field="thickness", positive=True)

    @classmethod
    def from_outline(
        cls,
        outline: Polygon,
        *,
        thickness: float,
        table_height: float,
        pose,
        resolution: float = 0.005,
        name: str = "",
    ) -> ThinObject:
        """Sample the top surface of a flat object with the given outline, placed on the table.

        The cloud is a square grid of spacing ``resolution`` inside the outline (holes
        respected) plus points every ``resolution`` along every boundary ring.

        Args:
            outline: the outline in the object frame (origin near its centroid, so the
                pose puts the object's middle at (x, y)).
            thickness: object thickness (m), > 0.
            table_height: z of the table top (m).
            pose: (x, y, yaw): rotate by yaw about the object-frame origin, then translate.
            resolution: sample spacing (m), > 0.
            name: a label.

        Returns:
            The object, with ``z = table_height + thickness`` for every point.

        Raises:
            InputError: non-positive thickness/resolution, non-finite pose or height,
                an invalid or empty outline, or a resolution so fine the cloud would be huge.
        """
        thickness = as_number(thickness, source="", field="thickness", positive=True)
        table_height = as_number(table_height, source="", field="table_height")
        resolution = as_number(resolution, source="", field="resolution", positive=True)
        pose = as_numbers(pose, 3, source="", field="pose")
        if not isinstance(outline, Polygon) or not outline.is_valid or outline.area <= 0:
            raise InputError("expected a valid shapely Polygon with area > 0", field="outline")
        xy = move_planar(_sample_outline(outline, resolution), pose)
        points = np.column_stack([xy, np.full(len(xy), table_height + thickness)])
        points.setflags(write=False)
        return cls(points, thickness, name, place_outline(outline, pose))

    @classmethod
    def from_points(cls, points, *, table_height: float, name: str = "", source: str = "") -> ThinObject:
        """Use a top-surface point cloud where it lies.

        Args:
            points: (N, 3) array-like, N >= 3, world frame.
            table_height: z of the table top (m); thickness = mean z - table_height.
            name: a label.
            source: the file the cloud came from, for error messages.

        Returns:
            The object (no outline).

        Raises:
            InputError: wrong shape, fewer than 3 points, NaN/inf, or a cloud whose mean
                z is not above the table top.
        """
        cloud = checked_cloud(points, source=source)
        table_height = as_number(table_height, source="", field="table_height")
        mean_z = float(cloud[:, 2].mean())
        if mean_z <= table_height:
            raise InputError(
                f"cloud lies below the table top (mean z {mean_z:.6g} m <= table height {table_height:.6g} m)",
                source=source,
                field="points",
            )
        cloud.setflags(write=False)
        return cls(cloud, mean_z - table_height, name)

    @cached_property
    def centroid_xy(self) -> np.ndarray:
        """The centre of mass of the object as a uniform plate: the area centroid of the region its
        points cover (:func:`slideplan.world.geometry.area_centroid`), not their mean.

        Returns:
            (2,) array.
        """
        return area_centroid(self.points[:, :2])

    @cached_property
    def symmetry_turns(self) -> np.ndarray:
        """The turns about the centre of mass that leave the footprint where it was, every degree in
        [0, 2 pi) (rad; 0 always, 4 for a square, all 360 for a disc): a turn a camera cannot see, so
        neither a tracking error nor a drift. Within ``SYMMETRY_TOLERANCE_M`` of the outline (the convex
        hull of a cloud without one)."""
        # Convex, unlike the tracker's concave outline: its jags at the points' spacing leave a disc's cloud 1 turn of 360.
        outline = self.outline if self.outline is not None else shapely.MultiPoint(self.points[:, :2]).convex_hull
        boundary = outline.boundary
        samples = shapely.get_coordinates(shapely.segmentize(boundary, 0.005))
        centre = np.asarray(self.centroid_xy, dtype=float)
        turns = np.radians(np.arange(360.0))
        cos, sin = np.cos(turns)[:, None], np.sin(turns)[:, None]
        local = samples - centre
        x = centre[0] + cos * local[:, 0] - sin * local[:, 1]
        y = centre[1] + sin * local[:, 0] + cos * local[:, 1]
        off = shapely.distance(shapely.points(x, y), boundary).max(axis=1)
        return turns[off <= SYMMETRY_TOLERANCE_M]

    def moved(self, motion) -> ThinObject:
        """The same object moved on the table by a planar motion in the world frame (Eq. 2's form).

        Args:
            motion: (x, y, yaw): ``p' = R(yaw) p + (x, y)``, e.g. a plan's ``object_motion`` values
                or the difference between a tracked pose and the planned one.

        Returns:
            A new object (points, outline) at the moved pose, same thickness and name.

        Raises:
            InputError: a motion that is not 3 finite numbers (field ``motion``).
        """
        motion = as_numbers(motion, 3, source="", field="motion")
        xy = move_planar(self.points[:, :2], motion)
        points = np.column_stack([xy, self.points[:, 2]])
        points.setflags(write=False)
        outline = None if self.outline is None else place_outline(self.outline, motion)
        return ThinObject(points, self.thickness, self.name, outline)


def place_outline(outline: Polygon, pose) -> Polygon:
    """Apply a planar pose ``R(yaw) p + (x, y)`` to an outline (same map as :func:`~slideplan.transforms.move_planar`).

    Args:
        outline: the outline in the object frame.
        pose: (x, y, yaw).

    Returns:
        The outline in the world frame.
    """
    x, y, yaw = pose
    rotation = rotation_2d(yaw)
    return shapely.affinity.affine_transform(outline, [*rotation.ravel(), x, y])


def _sample_outline(outline: Polygon, resolution: float) -> np.ndarray:
    """Grid points strictly inside ``outline`` plus points along its rings, as (N, 2)."""
    rings = [outline.exterior, *outline.interiors]
    expected = outline.area / resolution**2 + sum(ring.length for ring in rings) / resolution
    if expected > _MAX_SAMPLES:
        min_x, min_y, max_x, max_y = outline.bounds
        raise InputError(
            f"the outline ({max_x - min_x:.3g} x {max_y - min_y:.3g} m) sampled every {resolution:g} m would give "
            f"about {expected:.3g} points (limit {_MAX_SAMPLES}): is it in metres?",
            field="resolution",
        )
    min_x, min_y, max_x, max_y = outline.bounds
    # Centre the grid on the bounding box, so a symmetric outline gets a symmetric
    # sample and its centroid_xy is exact.
    axes = []
    for low, high in ((min_x, max_x), (min_y, max_y)):
        steps = math.floor((high - low) / resolution)
        axes.append(0.5 * (low + high) + (np.arange(steps + 1) - 0.5 * steps) * resolution)
    grid_x, grid_y = (axis.ravel() for axis in np.meshgrid(*axes))
    inside = shapely.contains_xy(outline, grid_x, grid_y)
    boundary = [
        shapely.get_coordinates(shapely.line_interpolate_point(ring, np.arange(0.0, ring.length, resolution)))
        for ring in rings
    ]
    return np.vstack([np.column_stack([grid_x[inside], grid_y[inside]]), *boundary])


def checked_cloud(points, *, source: str) -> np.ndarray:
    """Return ``points`` as a fresh (N, 3) float array with N >= 3, all finite.

    Raises:
        InputError: naming ``source`` and what is wrong.
    """
    def fail(problem: str) -> InputError:
        return InputError(problem, source=source, field="" if source else "points")

    if np.iscomplexobj(points):  # np.array(..., dtype=float) would drop the imaginary parts with a warning
        raise fail("expected an (N, 3) array of real numbers, got complex values")
    try:
        cloud = np.array(points, dtype=float)
    except (TypeError, ValueError):
        raise fail("expected an (N, 3) array of numbers") from None
    if cloud.size == 0:
        raise fail("point cloud is empty")
    if cloud.ndim != 2 or cloud.shape[1] != 3:
        raise fail(f"expected an (N, 3) array of x, y, z, got shape {cloud.shape}")
    if len(cloud) < 3:
        raise fail(f"point cloud needs at least 3 points, got {len(cloud)}")
    if not np.all(np.isfinite(cloud)):
        raise fail(f"point cloud has {np.count_nonzero(~np.isfinite(cloud).all(axis=1))} points with NaN or inf")
    return cloud


def _read_ply(path: Path) -> np.ndarray:
    ply = plyfile.PlyData.read(str(path))
    if "vertex" not in ply:
        raise InputError("no 'vertex' element", source=str(path), field="vertex")
    vertex = ply["vertex"]
    for axis in "xyz":
        if axis not in vertex.data.dtype.names:
            raise InputError("missing vertex property", source=str(path), field=f"vertex.{axis}")
    return np.column_stack([vertex[axis] for axis in "xyz"])


def _read_npy(path: Path) -> np.ndarray:
    return np.load(path, allow_pickle=False)


def _is_numeric_row(line: str) -> bool:
    try:
        [float(cell) for cell in line.split(",")]
    except ValueError:
        return False
    return True


def _read_csv(path: Path) -> np.ndarray:
    rows = [line for line in path.read_text().splitlines() if line.strip()]
    if rows and not _is_numeric_row(rows[0]):
        rows = rows[1:]  # a header line such as "x,y,z"
    if not rows:
        return np.empty((0, 3))
    return np.loadtxt(rows, delimiter=",", ndmin=2)


_PCD_TYPES = {("F", 4): "<f4", ("F", 8): "<f8", ("I", 1): "i1", ("I", 2): "<i2", ("I", 4): "<i4", ("I", 8): "<i8",
              ("U", 1): "u1", ("U", 2): "<u2", ("U", 4): "<u4", ("U", 8): "<u8"}  # PCL writes little-endian


def _read_pcd(path: Path) -> np.ndarray:
    """Read x, y, z of a PCL ``.pcd`` file (ascii or binary; binary_compressed is not supported)."""
    raw = path.read_bytes()
    header, offset = {}, 0
    while True:
        end = raw.find(b"\n", offset)
        if end < 0:
            raise ValueError("no DATA line in the header")
        words = raw[offset:end].decode("ascii", errors="replace").split()
        offset = end + 1
        if words and not words[0].startswith("#"):
            header[words[0].upper()] = words[1:]
            if words[0].upper() == "DATA":
                break
    names = header.get("FIELDS", [])
    if not all(axis in names for axis in "xyz"):
        raise ValueError(f"FIELDS {' '.join(names)} lack x, y or z")
    counts = [int(count) for count in header.get("COUNT", ["1"] * len(names))]
    points = int(header.get("POINTS", ["0"])[0])
    kind = header["DATA"][0] if header["DATA"] else ""
    if kind == "ascii":
        columns = np.cumsum([0, *counts])
        table = np.loadtxt(raw[offset:].decode("ascii").splitlines(), ndmin=2)
        return np.column_stack([table[:, columns[names.index(axis)]] for axis in "xyz"])
    if kind != "binary":
        raise ValueError(f"DATA {kind} is not supported (save as ascii or binary)")
    dtype = np.dtype([(name, _PCD_TYPES[(kind_, int(size))], (count,)) if count > 1 else (name, _PCD_TYPES[(kind_, int(size))])
                      for name, kind_, size, count in zip(names, header["TYPE"], header["SIZE"], counts)])
    record = np.frombuffer(raw, dtype=dtype, count=points, offset=offset)
    return np.column_stack([record[axis].astype(float) for axis in "xyz"])


_CLOUD_READERS = {".ply": _read_ply, ".npy": _read_npy, ".csv": _read_csv, ".pcd": _read_pcd}


def load_point_cloud(path: str | Path) -> np.ndarray:
    """Read a top-surface point cloud (world frame).

    Args:
        path: a ``.ply`` (ascii or binary, vertex properties x, y, z), ``.npy`` (N x 3),
            ``.csv`` (x,y,z rows, optionally one header line) or ``.pcd`` (PCL, ascii or
            binary, fields x, y, z) file.

    Returns:
        (N, 3) float array, N >= 3, all finite.

    Raises:
        InputError: naming the file: unknown format, missing or unreadable file,
            parse error, wrong shape, empty, or NaN/inf values.
    """
    path = Path(path)
    reader = _CLOUD_READERS.get(path.suffix.lower())
    if reader is None:
        raise InputError(
            f"unsupported point-cloud format {path.suffix!r} (expected one of {', '.join(CLOUD_SUFFIXES)})",
            source=str(path),
        )
    if not path.is_file():
        raise InputError("file not found", source=str(path))
    try:
        points = reader(path)
    except (OSError, ValueError, KeyError, plyfile.PlyParseError) as error:  # ValueError covers numpy's parse errors
        raise InputError(f"cannot read point cloud ({error})", source=str(path)) from None
    return checked_cloud(points, source=str(path))


def load_outline(path_or_name: str | Path) -> tuple[Polygon, float, str]:
    """Read an object outline.

    Args:
        path_or_name: a built-in object name (``data/objects/<name>.toml``, case-sensitive)
            or a TOML file with ``outline = [[x, y], ...]`` (object frame, m), optional
            ``holes = [[[x, y], ...], ...]``, ``thickness`` (default 0.004 m) and ``name``
            (default: the file name without suffix).

    Returns:
        (outline polygon, thickness, name).

    Raises:
        InputError: naming the file and field: unknown name/missing file, bad TOML,
            unknown/missing/mistyped field, invalid polygon or holes.
    """
    path = find_data_file(path_or_name, "objects")
    source = str(path)
    fields = Fields(read_toml(path), source=source, allowed={"name", "thickness", "outline", "holes"})
    exterior = simple_polygon_vertices(fields.xy_points("outline"), source=source, field="outline")
    hole_rings = fields.raw("holes", [])
    if not isinstance(hole_rings, list):
        raise InputError(f"expected a list of rings, got {hole_rings!r}", source=source, field="holes")
    holes = [
        simple_polygon_vertices(as_xy_points(ring, source=source, field=f"holes[{index}]"), source=source, field=f"holes[{index}]")
        for index, ring in enumerate(hole_rings)
    ]
    outline = Polygon(exterior, holes)
    if not outline.is_valid:
        raise InputError(
            f"holes must lie inside the outline without touching each other ({shapely.is_valid_reason(outline)})",
            source=source,
            field="holes",
        )
    thickness = fields.number("thickness", DEFAULT_THICKNESS, positive=True)
    return outline, thickness, fields.string("name", path.stem)


def load_object(
    spec: str | Path, *, table_height: float, pose=None, scale: float = 1.0, resolution: float = 0.005
) -> ThinObject:
    """Load an object given on the command line or in an experiment.

    Args:
        spec: a built-in object name, an outline TOML file, or a point-cloud file
            (``.ply``/``.npy``/``.csv``/``.pcd``, used where it lies).
        table_height: z of the table top (m).
        pose: (x, y, yaw) for an outline object (required); must be None for a cloud.
        scale: factor on the outline's x and y (not the thickness), e.g. 0.5 for the
            paper's half-scale experiments; outline objects only.
        resolution: sample spacing for outline objects (m).

    Returns:
        The object.

    Raises:
        InputError: anything wrong with the spec, the file, the pose or the scale.
    """
    require_type(spec, (str, os.PathLike), "spec", "an object name or a file path")
    source = str(spec)
    if Path(source).suffix.lower() in CLOUD_SUFFIXES:
        if pose is not None:
            raise InputError("a point-cloud object is used where it lies; do not give a pose", source=source, field="pose")
        if scale != 1.0:
            raise InputError("only outline objects can be scaled", source=source, field="scale")
        return ThinObject.from_points(
            load_point_cloud(source), table_height=table_height, name=Path(source).stem, source=source
        )
    outline, thickness, name = load_outline(spec)
    if pose is None:
        raise InputError("an outline object needs a pose (x, y, yaw)", source=source, field="pose")
    scale = as_number(scale, source=source, field="scale", positive=True)
    outline = shapely.affinity.scale(outline, scale, scale, origin=(0.0, 0.0))
    try:
        return ThinObject.from_outline(
            outline, thickness=thickness, table_height=table_height, pose=pose, resolution=resolution, name=name
        )
    except InputError as error:  # e.g. an outline too large to sample: say which object's
        raise InputError(error.problem, source=error.source or source, field=error.field) from None


def sample_pose_on_table(
    outline: Polygon, table: SupportSurface, rng: np.random.Generator, *, margin: float = 0.0, max_tries: int = 10000,
    avoid=None,
) -> tuple[float, float, float]:
    """Draw a random initial pose with the whole object on the table (paper Sec. V).

    The position of the object-frame origin is uniform over the table's bounding box and
    the yaw uniform in
    [-pi, pi); a pose is accepted when the posed outline lies inside the table shrunk by
    ``margin`` (rejection sampling, so the accepted poses are uniform over valid poses).

    Args:
        outline: the outline in the object frame.
        table: the support surface.
        rng: the random generator (seed it for reproducible poses).
        margin: keep the object at least this far (m) from the table edges, >= 0.
        max_tries: give up after this many rejected poses.
        avoid: a shapely geometry (e.g. obstacles' footprints) the object must not overlap.

    Returns:
        (x, y, yaw).

    Raises:
        InputError: a negative margin, or no valid pose (the object is larger than the table).
    """
    margin = as_number(margin, source="", field="margin")
    if margin < 0:
        raise InputError(f"must be >= 0, got {margin!r}", field="margin")
    usable = table.polygon.buffer(-margin, join_style="mitre") if margin > 0 else table.polygon
    if usable.is_empty or outline.area > usable.area:
        raise InputError(
            f"object (area {outline.area:.4g} m^2) is larger than the table (usable area {usable.area:.4g} m^2)",
            field="outline",
        )
    shapely.prepare(usable)
    min_x, min_y, max_x, max_y = table.polygon.bounds
    for _ in range(max_tries):
        pose = (float(rng.uniform(min_x, max_x)), float(rng.uniform(min_y, max_y)), float(rng.uniform(-math.pi, math.pi)))
        placed = place_outline(outline, pose)
        if usable.contains(placed) and (avoid is None or not placed.intersects(avoid)):
            return pose
    raise InputError(f"no pose with the whole object on the table found in {max_tries} tries", field="outline")
