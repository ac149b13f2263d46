"""From a scene point cloud to a scene and objects: the table plane, its outline, the thin objects on it.

The steps (docs/perception.md):

1. Planes (:mod:`slideplan.perception.planes`): RANSAC on a random subsample, repeated on the
   points left over, finds the large planes; the table is the highest one covering at least
   ``min_table_area``. It must be horizontal within ``max_tilt_deg``: a steeper one is a tilted
   table, or a cloud in the camera frame.
2. The table: the points within ``plane_tolerance`` of the plane, binned in an xy grid; the
   largest connected patch is the table top, its outline the convex hull of the points over
   it (simplified), its height the median height of its bare (object-free) points.
3. Objects: the mean height above the plane per grid cell, Gaussian-smoothed (sigma one
   cell: the sensor noise is of the order of the objects' thickness, so single points
   cannot tell object from table); connected cells at least ``min_height`` above the table
   are a cluster (SciPy's ``ndimage.label``); its thickness is the median height of its
   inner points; clusters thicker than ``max_thickness`` are clutter (box obstacles), the
   others thin objects, whose points are those near the cluster where a less smoothed
   height (sigma half a cell, so thin parts survive) is above half their thickness.

Needs the ``perception`` extra (scikit-learn; SciPy for the grid filters).
"""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import MultiPoint, Polygon

from .._fields import as_number, as_seed
from ..errors import InputError
from ..world.geometry import SupportSurface, area_centroid
from ..world.objects import checked_cloud
from .planes import default_cell_size, find_table_plane, known_plane
from ..world.scenes import BoxObstacle, Scene, load_scene

_MAX_GRID_CELLS = 1e7  # a 9 m square table at 3 mm cells; beyond it the height grids take gigabytes
_DETECTION_SIGMA = 1.0  # cells; averages ~15 points per cell at the default cell size
_EDGE_SIGMA = 0.5  # cells
_OUTLINE_TOLERANCE = 0.001  # m; the outline's simplification moves it at most this much


@dataclass(eq=False)
class PerceivedObject:
    """A thin object found on the table.

    Attributes:
        points: (N, 3) top-surface cloud, world frame: the measured xy of the object's
            points, z = table height + thickness (the noise averaged out).
        thickness: median height of the object's inner points above the table (m).
        footprint: the grid cells the object covers, as a polygon (world frame; for plots
            and overlap checks).
        centroid_xy: (2,) centre of mass: the area centroid of ``points``
            (:func:`slideplan.world.geometry.area_centroid`).
        yaw: direction of the principal axis of ``points`` (rad, in (-pi/2, pi/2]);
            meaningless for objects with equal second moments (discs, squares). For the
            pose of a known outline use :func:`slideplan.perception.registration.register_outline`.
    """

    points: np.ndarray
    thickness: float
    footprint: Polygon
    centroid_xy: np.ndarray
    yaw: float


@dataclass(eq=False)
class Perception:
    """What :func:`perceive` found.

    Attributes:
        table: the table top (outline and height).
        tilt_deg: angle between the table plane's normal and the world z axis (deg).
        objects: the thin objects, largest first.
        obstacles: clutter on the table (clusters thicker than ``max_thickness``) as boxes.
        warnings: things a user should know, e.g. a cluster that looks like touching objects.
        cell_size: the xy grid used (m).
        plane: the table plane z = a x + b y + c found, ``(a, b, c)`` (the next :func:`perceive` of the
            same fixed camera can take it instead of searching again).
    """

    table: SupportSurface
    tilt_deg: float
    objects: list[PerceivedObject]
    obstacles: list[BoxObstacle] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    cell_size: float = 0.0
    plane: tuple[float, float, float] | None = None

    @property
    def edge_uncertainty(self) -> float:
        """How far the true edges may lie from the perceived ones (m): the table outline is the hull
        of sampled points (up to half a cell inside the edge) simplified by _OUTLINE_TOLERANCE, and an
        object's edge is placed to within half a cell; an overhang measured between the two may
        be off by their sum."""
        return self.cell_size + _OUTLINE_TOLERANCE

    def scene(self, robot_scene: Scene | str | Path = "square") -> Scene:
        """The perceived scene: this table and these obstacles, with another scene's robot.

        Args:
            robot_scene: a scene, built-in scene name or scene TOML whose robot (URDF, mount, links) is used.

        Returns:
            The scene.
        """
        # Everything robot-side (URDF, attachments, mount, held joints, hand) as perception_files.scene_toml writes it.
        robot_side = robot_scene if isinstance(robot_scene, Scene) else load_scene(robot_scene)
        return replace(robot_side, name="perceived", table=self.table, obstacles=tuple(self.obstacles), source="")


class _Grid:
    """An xy grid over a box, mapping points to cells.

    Raises:
        InputError: (from ``problem``) more than ``_MAX_GRID_CELLS`` cells, before any is allocated.
    """

    def __init__(self, xy: np.ndarray, cell: float, problem: _Problem) -> None:
        self.cell = cell
        self.origin = xy.min(axis=0) - 2 * cell
        extent = xy.max(axis=0) - xy.min(axis=0)
        cells = np.prod(np.ceil(extent / cell) + 7)
        if cells > _MAX_GRID_CELLS:
            raise problem(f"the table plane's points span {extent[0]:.4g} x {extent[1]:.4g} m: {cells:.3g} grid cells of "
                          f"{cell:g} m (limit {_MAX_GRID_CELLS:.0e}); slideplan reads metres: is the cloud in millimetres?")
        self.shape = tuple((np.ceil((xy.max(axis=0) - self.origin) / cell) + 3).astype(int))

    def covers(self, xy: np.ndarray) -> np.ndarray:
        """(N,) bool: which points fall inside the grid."""
        return np.all((xy > self.origin) & (xy < self.origin + np.array(self.shape) * self.cell), axis=1)

    def index(self, xy: np.ndarray) -> np.ndarray:
        """(N, 2) integer cell indices of points inside the grid (see :meth:`covers`)."""
        return np.floor((xy - self.origin) / self.cell).astype(np.int64)

    def accumulate(self, cells: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
        """Per-cell sum of ``weights`` (or count) as a 2-D float array (filters keep their input's dtype)."""
        flat = np.ravel_multi_index((cells[:, 0], cells[:, 1]), self.shape)
        return np.bincount(flat, weights, minlength=self.shape[0] * self.shape[1]).reshape(self.shape).astype(float)

    def centers(self, mask: np.ndarray) -> np.ndarray:
        """(k, 2) xy of the centres of a mask's cells, in row-major order."""
        return self.origin + (np.column_stack(np.nonzero(mask)) + 0.5) * self.cell

    def polygon(self, mask: np.ndarray):
        """Union of the cells of a mask, as a shapely geometry."""
        i, j = np.nonzero(mask)
        low = self.origin + np.column_stack([i, j]) * self.cell
        return shapely.union_all(shapely.box(low[:, 0], low[:, 1], low[:, 0] + self.cell, low[:, 1] + self.cell))


def perceive(
    points,
    *,
    max_tilt_deg: float = 5.0,
    plane_tolerance: float = 0.008,
    min_table_area: float = 0.04,
    min_height: float = 0.002,
    max_thickness: float = 0.03,
    min_object_area: float = 4e-4,
    cell_size: float | None = None,
    table_plane=None,
    seed: int = 0,
    source: str = "",
) -> Perception:
    """Find the table and the thin objects on it in a world-frame scene cloud (z up).

    Args:
        points: (N, 3) array-like, world frame, z up (m); all finite.
        max_tilt_deg: largest accepted angle between the table plane and the horizontal (deg).
        plane_tolerance: distance from the plane (along z) within which a point belongs to
            it (m); about 3 times the sensor's depth noise.
        min_table_area: a plane must cover at least this much (m^2) to be a table candidate.
        min_height: a cluster must stand at least this high above the table (m); objects
            thinner than this (or than about twice the depth noise) are not found.
        max_thickness: clusters thicker than this are clutter (box obstacles), not thin objects (m).
        min_object_area: smaller clusters are dropped as noise (m^2).
        cell_size: xy grid cell (m); default twice the mean point spacing on the table.
        table_plane: ``(a, b, c)`` of a table plane z = a x + b y + c known from an earlier cloud of the
            same camera (:attr:`Perception.plane`): no RANSAC search (most of the time of a call); it is
            searched for anyway when it holds too few of the points (the camera moved).
        seed: seed of the RANSAC sampling.
        source: the file the points came from, for error messages.

    Returns:
        The perception.

    Raises:
        InputError: a setting that is not a positive number (or ``max_thickness <=
            min_height``), empty cloud, NaN/inf points, no large plane, a table plane tilted more
            than ``max_tilt_deg`` (a tilted table or a camera-frame cloud), or no object on
            the table.
    """
    try:
        for module in ("sklearn", "scipy.ndimage"):  # imported here so a missing extra is named before any work
            importlib.import_module(module)
    except ImportError as error:
        raise ImportError(f"perceive needs the perception extra (pip install 'slideplan[perception]'): {error}") from None

    seed = as_seed(seed)
    _check_settings({"max_tilt_deg": max_tilt_deg, "plane_tolerance": plane_tolerance, "min_table_area": min_table_area,
                     "min_height": min_height, "max_thickness": max_thickness, "min_object_area": min_object_area},
                    cell_size)
    cloud = checked_cloud(points, source=source)
    problem = _Problem(source)
    plane = known_plane(cloud, table_plane, plane_tolerance)
    if plane is None:
        plane = find_table_plane(cloud, plane_tolerance, min_table_area, max_tilt_deg, seed, problem)
    a, b, c = plane.coefficients
    heights = cloud[:, 2] - (a * cloud[:, 0] + b * cloud[:, 1] + c)
    on_plane = np.abs(heights) < plane_tolerance
    grid = _Grid(cloud[on_plane, :2], cell_size or default_cell_size(cloud[on_plane, :2]), problem)
    table_mask, skipped = _table_top(grid, cloud, heights, on_plane, min_height, max_thickness, min_table_area,
                                     min_object_area)
    over = _OverTable(grid, cloud, heights, table_mask, plane_tolerance)
    thin, obstacles, occupied = _clusters(grid, over, table_mask, plane.coefficients, min_height, max_thickness,
                                          min_object_area)
    if not thin:
        clutter = f" ({len(obstacles)} clutter clusters thicker than {max_thickness:g} m)" if obstacles else ""
        raise problem(f"no object on the table: nothing between {min_height:g} and {max_thickness:g} m above the table plane{clutter}")
    table, offset = _table_surface(grid, cloud, heights, on_plane & over.mask, occupied, over.xy, plane.coefficients)
    warnings = [f"{skipped} larger table patch(es) at the same height with no object on them were passed over"] \
        if skipped else []
    objects = _thin_objects(thin, over, offset, table.height, min_height, grid, warnings)
    if not objects:
        raise problem(f"no object on the table: nothing between {min_height:g} and {max_thickness:g} m above the table plane")
    return Perception(table, plane.tilt_deg, objects, obstacles, warnings, grid.cell,
                      tuple(float(value) for value in plane.coefficients))


def _check_settings(settings: dict[str, float], cell_size: float | None) -> None:
    """Raise InputError for a perceive() setting that is not a positive number, or max_thickness <= min_height."""
    for name, value in settings.items():
        as_number(value, source="", field=name, positive=True)
    if cell_size is not None:
        as_number(cell_size, source="", field="cell_size", positive=True)
    if settings["max_thickness"] <= settings["min_height"]:
        raise InputError(f"must be > min_height ({settings['min_height']:g}), got {settings['max_thickness']!r}",
                         field="max_thickness")


def _table_top(grid: _Grid, cloud: np.ndarray, heights: np.ndarray, on_plane: np.ndarray, min_height: float,
               max_thickness: float, min_table_area: float, min_object_area: float) -> tuple[np.ndarray, int]:
    """The cells of the table top, and how many larger patches of the plane were passed over.

    Two tables at one height are one plane: the table is the largest of its patches with something thin on it.
    """
    in_grid = grid.covers(cloud[:, :2])
    thin_cells = grid.accumulate(grid.index(cloud[in_grid & (heights > min_height) & (heights <= max_thickness), :2])) > 0
    tables = _table_masks(grid, cloud[on_plane, :2], min_table_area)
    skipped = next((i for i, mask in enumerate(tables) if _holds_an_object(mask & thin_cells, grid.cell, min_object_area)), 0)
    return tables[skipped], skipped


class _OverTable:
    """Everything at or above the plane over the table: the table top, the objects, the clutter.

    Attributes:
        mask: (N,) which of the cloud's points these are.
        xy, heights, cells: their xy, heights above the plane and grid cells.
        smoothed: the detection field, the heights smoothed per cell.
        edge_field: a less smoothed field (more noise, but thin parts such as a crescent's tips survive)
            for the edges; ``edge_at_point`` is it at each point.
    """

    def __init__(self, grid: _Grid, cloud: np.ndarray, heights: np.ndarray, table_mask: np.ndarray,
                 plane_tolerance: float) -> None:
        from scipy import ndimage

        self.mask = grid.covers(cloud[:, :2]) & (heights > -plane_tolerance)
        self.mask[self.mask] = table_mask[tuple(grid.index(cloud[self.mask, :2]).T)]
        self.xy, self.heights = cloud[self.mask, :2], heights[self.mask]
        self.cells = grid.index(self.xy)
        self.smoothed = _smoothed_heights(grid, self.cells, self.heights, _DETECTION_SIGMA)
        self.edge_field = _smoothed_heights(grid, self.cells, self.heights, _EDGE_SIGMA)
        self.edge_at_point = ndimage.map_coordinates(self.edge_field, ((self.xy - grid.origin) / grid.cell - 0.5).T, order=1)


_RIM_CELLS = 2  # cells around clutter whose smoothed heights slope down to the table: neither clutter nor object


def _clusters(grid: _Grid, over: _OverTable, table_mask: np.ndarray, coefficients: np.ndarray, min_height: float,
              max_thickness: float, min_object_area: float) -> tuple[list[tuple], list[BoxObstacle], np.ndarray]:
    """The clusters over the table large enough to count.

    Returns:
        The thin ones as (cells, top, member points, cells near it, inner smoothed heights); the thick
        ones as box obstacles; the cells they all cover.
    """
    from scipy import ndimage

    clusters, count = ndimage.label(table_mask & (over.smoothed > min_height), structure=np.ones((3, 3)))
    # A point belongs to the nearest cluster within 2 cells: the detection blur erodes thin
    # parts and corners, the edge field (in _thin_objects) decides which of these points are the object's.
    distance, nearest = ndimage.distance_transform_edt(clusters == 0, return_indices=True)
    near_cluster = np.where(distance <= 2, clusters[tuple(nearest)], 0)
    cluster_of_point = near_cluster[tuple(over.cells.T)]
    thin, obstacles = [], []
    occupied = np.zeros_like(table_mask)
    for label in range(1, count + 1):
        mask = clusters == label
        if mask.sum() * grid.cell**2 < min_object_area:
            continue
        occupied |= mask
        inner = ndimage.binary_erosion(mask)
        inner = inner if inner.any() else mask
        members = cluster_of_point == label
        inner_members = members & inner[tuple(over.cells.T)]
        top = float(np.median(over.heights[inner_members if inner_members.any() else members]))
        if top > max_thickness:
            # A thin object lying against the clutter joins its cluster: split off each flat part that stands
            # clear of the clutter's rim (the smoothing's slope), large enough to count once eroded.
            thick = mask & (over.smoothed > max_thickness)
            parts, found = ndimage.label(mask & ~ndimage.binary_dilation(thick, iterations=_RIM_CELLS),
                                         structure=np.ones((3, 3)))
            for part in range(1, found + 1):
                cells = parts == part
                core = ndimage.binary_erosion(cells)
                if core.sum() * grid.cell**2 < min_object_area:
                    continue
                near = ndimage.binary_dilation(cells, iterations=2)
                part_members = members & near[tuple(over.cells.T)]
                on_core = part_members & core[tuple(over.cells.T)]
                if not on_core.any():
                    continue
                part_top = float(np.median(over.heights[on_core]))
                if min_height < part_top <= max_thickness:
                    thin.append((int(cells.sum()), part_top, part_members, near & (near_cluster == label),
                                 over.smoothed[core]))
                    members = members & ~part_members
            obstacles.append(_box_obstacle(over.xy[members], over.heights[members], coefficients, grid.cell))
        else:
            thin.append((int(mask.sum()), top, members, near_cluster == label, over.smoothed[inner]))
    return thin, obstacles, occupied


def _table_surface(grid: _Grid, cloud: np.ndarray, heights: np.ndarray, on_table: np.ndarray, occupied: np.ndarray,
                   over_xy: np.ndarray, coefficients: np.ndarray) -> tuple[SupportSurface, float]:
    """The table top, and its height above the plane at its bare points (away from anything on it, so the objects do
    not lift it)."""
    from scipy import ndimage

    bare = on_table.copy()
    bare[bare] = ~ndimage.binary_dilation(occupied, iterations=2)[tuple(grid.index(cloud[bare, :2]).T)]
    # None bare (the objects cover the table): all its plane points, lifted a little by the objects' edges.
    offset = float(np.median(heights[bare] if bare.any() else heights[on_table]))
    # Hull of everything over the table: objects and clutter hide the table under them.
    hull = _convex_hull(over_xy).simplify(_OUTLINE_TOLERANCE)
    center = hull.centroid
    a, b, c = coefficients
    table = SupportSurface.from_vertices(
        np.asarray(hull.exterior.coords), a * center.x + b * center.y + c + offset, field="table outline"
    )
    return table, offset


def _thin_objects(thin: list[tuple], over: _OverTable, offset: float, table_height: float, min_height: float,
                  grid: _Grid, warnings: list[str]) -> list[PerceivedObject]:
    """The thin clusters that are objects, largest first; a warning appended for one that looks like touching objects."""
    objects = []
    for _, top, members, near, inner_heights in sorted(thin, key=lambda item: -item[0]):
        if top - offset < min_height:  # stray points lifted the smoothed field, the cluster is table
            continue
        # The object's edge is where the edge field crosses half way from the table to its top.
        half = 0.5 * (top + offset)
        low, high = np.percentile(inner_heights, [5, 95]) - offset
        if high - low > max(0.002, 0.5 * (top - offset)):
            warnings.append(
                f"object {len(objects)} has parts at different heights ({1000 * low:.1f} to {1000 * high:.1f} mm): "
                "probably touching objects, reported as one"
            )
        footprint = grid.polygon(near & (over.edge_field > half))
        # A point of the object lies at its top's height: flying pixels over it do not (within the
        # larger of half the thickness and three times the top's noise, a robust sigma from its MAD).
        band = max(top - half, 3 * 1.4826 * float(np.median(np.abs(inner_heights - np.median(inner_heights)))))
        own = (over.heights > half) & (over.heights < top + band)
        kept = over.xy[members & own & (over.edge_at_point > half)]
        if len(kept) < 3 or _convex_hull(kept).area <= 0.0:
            continue  # a cluster with no top of its own (noise lifted the smoothed field): not an object
        objects.append(_thin_object(kept, top - offset, table_height, footprint))
    return objects


class _Problem:
    """Makes the InputErrors of one perceive() call, naming the file or the argument."""

    def __init__(self, source: str) -> None:
        self.source = source

    def __call__(self, problem: str) -> InputError:
        return InputError(problem, source=self.source, field="" if self.source else "points")


def _table_masks(grid: _Grid, xy: np.ndarray, min_area: float) -> list[np.ndarray]:
    """Per connected patch of the plane's points covering at least ``min_area`` (and always the
    largest), the cells inside its convex hull, largest first.

    The hull, not the patch: objects and clutter hide the table under them, and a tall box's
    shadow can reach the table's edge, so the patch has holes and bays that are table.
    """
    from scipy import ndimage

    support = grid.accumulate(grid.index(xy)) > 0
    labels, _ = ndimage.label(ndimage.binary_closing(support), structure=np.ones((3, 3)))  # closing bridges dropouts
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    order = np.argsort(-sizes, kind="stable")
    keep = [label for rank, label in enumerate(order) if sizes[label] > 0 and (rank == 0 or sizes[label] * grid.cell**2 >= min_area)]
    all_cells = grid.centers(np.ones(grid.shape, dtype=bool)).T
    return [shapely.contains_xy(_convex_hull(grid.centers(labels == label)).buffer(0.5 * grid.cell), *all_cells)
            .reshape(grid.shape) for label in keep]


def _holds_an_object(thin_cells: np.ndarray, cell: float, min_area: float) -> bool:
    """Whether cells holding points at an object's height join into a patch of ``min_area``: a flying
    pixel fills one cell, an object many that touch."""
    from scipy import ndimage

    labels, count = ndimage.label(thin_cells, structure=np.ones((3, 3)))
    return count > 0 and np.bincount(labels.ravel())[1:].max() * cell**2 >= min_area


def _smoothed_heights(grid: _Grid, cells: np.ndarray, heights: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian-weighted mean height per cell (0 where there are no points near).

    Args:
        grid: the grid.
        cells: (N, 2) the points' cells.
        heights: (N,) their heights above the plane.
        sigma: the Gaussian's standard deviation, in cells.
    """
    from scipy import ndimage

    height_sum = ndimage.gaussian_filter(grid.accumulate(cells, heights), sigma, mode="constant", truncate=2.0)
    count = ndimage.gaussian_filter(grid.accumulate(cells), sigma, mode="constant", truncate=2.0)
    return np.where(count > 1e-9, height_sum / np.maximum(count, 1e-9), 0.0)


def _convex_hull(xy: np.ndarray) -> Polygon:
    """The convex hull of many points (a table's tens of thousands): from qhull's vertices, since
    shapely would first build one geometry per point (most of a perceive call's time). Not used for an
    object's few hundred points (ThinObject.symmetry_turns): qhull drops vertices shapely keeps on nearly
    straight edges, and those hulls' samples, hence the turns found, would move."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        xy = xy[ConvexHull(xy).vertices]
    except QhullError:  # flat or too few points: shapely's hull says what it is
        pass
    return MultiPoint(xy).convex_hull


def _thin_object(xy: np.ndarray, thickness: float, table_height: float, footprint) -> PerceivedObject:
    """A perceived object: flat cloud at the table height + thickness, centroid and principal axis."""
    centroid = area_centroid(xy)
    covariance = np.cov((xy - xy.mean(axis=0)).T)
    eigenvalues, eigenvectors = np.linalg.eigh(covariance)
    major = eigenvectors[:, int(np.argmax(eigenvalues))]
    yaw = math.atan2(major[1], major[0])
    yaw = yaw - math.pi if yaw > math.pi / 2 else yaw + math.pi if yaw <= -math.pi / 2 else yaw
    points = np.column_stack([xy, np.full(len(xy), table_height + thickness)])
    return PerceivedObject(points, thickness, footprint, centroid, yaw)


def _box_obstacle(xy: np.ndarray, heights: np.ndarray, coefficients: np.ndarray, cell: float) -> BoxObstacle:
    """The box around a clutter cluster: the minimum rotated rectangle of its upper half, up to its 98th height percentile.

    The upper half only: the cluster's cells also hold table points around the clutter's foot.
    """
    top = float(np.percentile(heights, 98))
    upper = MultiPoint(xy[heights > 0.5 * top])
    rectangle = upper.minimum_rotated_rectangle
    if not isinstance(rectangle, Polygon):  # its upper points on a line or in one spot: a box a cell thick
        rectangle = upper.buffer(0.5 * cell, cap_style="square").minimum_rotated_rectangle
    corners = np.asarray(rectangle.exterior.coords)[:4]
    sides = np.diff(np.vstack([corners, corners[:1]]), axis=0)
    length = np.linalg.norm(sides, axis=1)
    yaw = math.atan2(sides[0, 1], sides[0, 0])
    center = corners.mean(axis=0)
    base = coefficients @ (center[0], center[1], 1.0)
    return BoxObstacle(np.array([center[0], center[1], base + 0.5 * top]), np.array([length[0], length[1], top]), yaw)
