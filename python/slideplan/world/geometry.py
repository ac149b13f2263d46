"""The support surface (table top, a simple polygon at a height), the area centroid of a cloud, and how a slide
leaves an object for the grasp (its overhang and centre-of-mass margin: :class:`Ending`)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import math

import numpy as np
import shapely
from shapely.geometry import Polygon

from .. import _core
from .._fields import as_number, as_numbers
from ..errors import InputError

_MIN_AREA = 1e-8  # m^2; anything smaller is a degenerate table, not a real one


def _signed_area(vertices: np.ndarray) -> float:
    """Shoelace area: positive for counter-clockwise vertices."""
    x, y = vertices[:, 0], vertices[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _check_vertex_count(count: int, fail) -> None:
    if count > _core.SupportSurface.MAX_VERTICES:
        raise fail(f"polygon has {count} vertices, at most {_core.SupportSurface.MAX_VERTICES} (simplify the outline)")


def simple_polygon_vertices(vertices, *, source: str = "", field: str = "vertices") -> np.ndarray:
    """Validate the vertices of a simple polygon (one ring, no holes).

    Args:
        vertices: (n, 2) array-like, either winding; a repeated closing vertex is dropped.
        source: file the vertices came from, for error messages.
        field: name of the field/argument holding the vertices, for error messages.

    Returns:
        (n, 2) float array, counter-clockwise, without a repeated closing vertex.

    Raises:
        InputError: not an (n, 2) array of numbers, fewer than 3 vertices, NaN/inf,
            a degenerate (area <= 1e-8 m^2) or a self-intersecting polygon.
    """
    def fail(problem: str) -> InputError:
        return InputError(problem, source=source, field=field)

    try:
        points = np.array(vertices, dtype=float)
    except (TypeError, ValueError):
        raise fail("expected an (n, 2) array of numbers") from None
    if points.ndim != 2 or points.shape[1] != 2:
        raise fail(f"expected an (n, 2) array of vertices, got shape {points.shape}")
    if not np.all(np.isfinite(points)):
        raise fail("vertices must be finite (found NaN or inf)")
    given = len(points)
    if len(points) > 1 and np.array_equal(points[0], points[-1]):
        points = points[:-1]  # a closing vertex repeating the first
    if len(points) < 3:
        closing = f" (the last repeats the first, closing the ring: {len(points)} distinct)" if given > len(points) else ""
        raise fail(f"polygon needs at least 3 vertices, got {given}{closing}")
    _check_vertex_count(len(points), fail)
    polygon = Polygon(points)
    # Check collinear/coincident vertices before validity: GEOS would call them
    # self-intersecting, which is true but less helpful.
    if polygon.convex_hull.area <= _MIN_AREA:
        raise fail("polygon is degenerate (zero area: vertices are collinear or coincident)")
    if not polygon.is_valid:
        reason = shapely.is_valid_reason(polygon)
        if "self-intersection" in reason.lower():
            raise fail(f"polygon is self-intersecting ({reason})")
        raise fail(f"polygon is not simple ({reason})")
    if polygon.area <= _MIN_AREA:
        raise fail(f"polygon is degenerate (area {polygon.area:.3g} m^2 <= {_MIN_AREA:g})")
    return points if _signed_area(points) > 0 else points[::-1].copy()


@dataclass(frozen=True, eq=False)
class SupportSurface:
    """A flat support surface: the table polygon ``Q`` at height ``z_table`` (paper Sec. IV).

    Build it with :meth:`from_vertices` or :meth:`circle`, which validate the input;
    the constructor itself trusts its arguments.

    Attributes:
        vertices: (n, 2) polygon vertices, counter-clockwise, without a repeated
            closing vertex (read-only array).
        height: z of the table top in the world frame (m).
    """

    vertices: np.ndarray
    height: float = 0.0

    @classmethod
    def from_vertices(
        cls, vertices, height: float = 0.0, *, source: str = "", field: str = "vertices"
    ) -> SupportSurface:
        """Validate a simple polygon and normalise it to counter-clockwise order.

        Args:
            vertices: (n, 2) array-like, either winding; a repeated closing vertex is dropped.
            height: z of the table top (m).
            source: file the vertices came from, for error messages.
            field: name of the field/argument holding the vertices, for error messages.

        Returns:
            The support surface.

        Raises:
            InputError: see :func:`simple_polygon_vertices`; or a non-finite height.
        """
        points = simple_polygon_vertices(vertices, source=source, field=field)
        points.setflags(write=False)
        return cls(points, as_number(height, source=source, field="height"))

    @classmethod
    def circle(
        cls, center, radius: float, points: int = 100, height: float = 0.0, *, source: str = "", field: str = ""
    ) -> SupportSurface:
        """A round table approximated by a regular polygon (the paper uses 100 edge points).

        Args:
            center: (x, y) of the centre (m).
            radius: circumradius (m), > 0.
            points: number of vertices, >= 3.
            height: z of the table top (m).
            source: file the circle came from, for error messages.
            field: name of the field holding the circle (e.g. ``table.circle``), for error messages.

        Returns:
            The support surface.

        Raises:
            InputError: bad centre, radius or point count (more than ``MAX_VERTICES`` is refused
                before anything is allocated).
        """
        prefix = f"{field}." if field else ""
        center_xy = as_numbers(center, 2, source=source, field=prefix + "center")
        radius = as_number(radius, source=source, field=prefix + "radius", positive=True)
        if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 3:
            raise InputError(f"expected an integer >= 3, got {points!r}", source=source, field=prefix + "points")
        _check_vertex_count(points, lambda problem: InputError(problem, source=source, field=prefix + "points"))
        angles = 2.0 * np.pi * np.arange(points) / points
        vertices = center_xy + radius * np.column_stack([np.cos(angles), np.sin(angles)])
        return cls.from_vertices(vertices, height)

    @cached_property
    def polygon(self) -> Polygon:
        """The table polygon as a (prepared, hence fast to query) shapely Polygon."""
        polygon = Polygon(self.vertices)
        shapely.prepare(polygon)
        return polygon

    @property
    def area(self) -> float:
        """Area of the table polygon (m^2)."""
        return self.polygon.area

    def edge_margin(self, xy) -> float:
        """Signed distance of a point inside the table edge (m; negative outside): how far a centre of
        mass is from tipping over (``com_margin``).

        Args:
            xy: (2,) point.
        """
        point = shapely.Point(np.asarray(xy, dtype=float))
        distance = float(self.polygon.exterior.distance(point))
        return distance if self.polygon.contains(point) else -distance

    def contains(self, xy) -> np.ndarray:
        """Test which points lie strictly inside the polygon (points on an edge do not).

        Args:
            xy: (N, 2) array-like of points (a single (2,) point is accepted too).

        Returns:
            (N,) bool array (a bool array of shape () for a single point).

        Raises:
            InputError: ``xy`` does not have 2 columns.
        """
        points = np.asarray(xy, dtype=float)
        if points.shape[-1:] != (2,):
            raise InputError(f"expected (N, 2) points, got shape {points.shape}", field="xy")
        return shapely.contains_xy(self.polygon, points[..., 0], points[..., 1])


def area_centroid(xy) -> np.ndarray:
    """The centre of mass of a uniform thin plate known by points of its top surface: the area centroid
    of the region they cover, whatever their density (a mean of the points leans towards where they are
    denser: the bundled outlines' boundary rings put the crescent's mean 3.2 mm off its centroid).

    The region is the union of the Delaunay triangles of the points whose longest edge is at most one
    and a half times the local point spacing at its corners (the mean distance to a point's 6 nearest
    neighbours: a grid's diagonals stay, gaps of two spacings go), an alpha shape: it follows concave
    outlines and holes wider than that. Clouds over 20,000 points are thinned to one point per 1 mm cell
    first. Computed in C++ (``_core.area_centroid``, Qhull and nanoflann, without the GIL). The one place
    the centre of mass is computed: objects, perception, and through them the planner and execution (the
    verifier re-derives it on purpose from the plan's points).

    Args:
        xy: (N, 2) points, N >= 1.

    Returns:
        (2,) area centroid; the points' mean for a cloud that covers no area.

    Raises:
        InputError: ``xy`` is not (N, 2) with N >= 1, or a point is not finite (field ``xy``).
    """
    points = np.ascontiguousarray(xy, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) == 0:
        raise InputError(f"expected (N, 2) points with N >= 1, got shape {points.shape}", field="xy")
    if not np.isfinite(points).all():
        raise InputError("a point is not finite", field="xy")
    return np.asarray(_core.area_centroid(points))


def _closest_edge(table: SupportSurface, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A point on the table edge closest to ``point`` and that edge's outward unit normal."""
    starts = table.vertices
    edges = np.roll(starts, -1, axis=0) - starts
    along = np.clip(np.einsum("ij,ij->i", point - starts, edges) / np.einsum("ij,ij->i", edges, edges), 0.0, 1.0)
    closest = int(np.argmin(np.linalg.norm(starts + along[:, None] * edges - point, axis=1)))
    direction = edges[closest] / np.linalg.norm(edges[closest])
    return starts[closest], np.array([direction[1], -direction[0]])  # right of the edge: outside for a CCW polygon


def overhang(table: SupportSurface, moved_xy: np.ndarray) -> tuple[float, np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """Overhang ``u`` of paper IV-C.1 for an object at its final pose.

    ``u`` is the largest distance, along the outward normal of the table edge closest to
    the centroid of the points outside the table (``P_out``), of a point of ``P_out``
    beyond that edge.

    Args:
        table: the support surface (vertices counter-clockwise).
        moved_xy: (N, 2) object points at the final pose.

    Returns:
        ``(u, outside, edge)``: u (m; 0 when no point is outside), the (N,) bool mask of ``P_out``,
        and that edge as (a point on it, its outward unit normal), or None when no point is outside.
    """
    outside = ~table.contains(moved_xy)
    if not outside.any():
        return 0.0, outside, None
    out_points = moved_xy[outside]
    start, normal = _closest_edge(table, out_points.mean(axis=0))
    return float(np.max((out_points - start) @ normal)), outside, (start, normal)


def support_margin(table: SupportSurface, moved_xy: np.ndarray, moved_com) -> float:
    """The centre of mass's signed distance inside what the table bears (m; negative outside): the convex hull
    of the object's points on the table (``support_hull``). Past it the object tips over the edge once the
    finger lets go, though its centre of mass may lie inside the table (an L's lies off its own material).

    Args:
        table: the support surface.
        moved_xy: (N, 2) the object's points where it lies.
        moved_com: (2,) its centre of mass there.
    """
    on = moved_xy[table.contains(moved_xy)]
    point = shapely.Point(np.asarray(moved_com, dtype=float))
    hull = shapely.MultiPoint(on).convex_hull if len(on) else None
    if hull is None or hull.geom_type != "Polygon":
        return -math.inf  # a point or a line bears nothing
    return float(hull.exterior.distance(point)) if hull.contains(point) else -float(hull.distance(point))


class Ending(NamedTuple):
    """How a slide leaves an object for the grasp (paper IV-C.1): the one home of "the slide ends graspable".

    Attributes:
        overhang: ``u`` (m), :func:`overhang` at the final pose (the verifier gives the part the hand holds).
        com_margin: the centre of mass's signed distance inside the table edge (m; negative off the table).
    """

    overhang: float
    com_margin: float

    @classmethod
    def at(cls, table: SupportSurface, moved_xy: np.ndarray, moved_com) -> Ending:
        """The ending of an object whose points are at ``moved_xy`` (N, 2) and centre of mass at ``moved_com``."""
        return cls(overhang(table, moved_xy)[0], table.edge_margin(moved_com))

    def overhangs(self, u_star: float, slack: float = 0.0) -> bool:
        """``u >= u*`` (less ``slack``: the verifier's tolerance of the planner's steps)."""
        return self.overhang >= u_star - slack

    def com_inside(self, com_margin: float, slack: float = 0.0) -> bool:
        """The centre of mass at least ``com_margin`` inside the table edge (less ``slack``)."""
        return self.com_margin >= com_margin - slack

    def graspable(self, u_star: float, com_margin: float) -> bool:
        """Both, exactly: the grasp can hold ``u*`` of the object and the table still bears it."""
        return self.overhangs(u_star) and self.com_inside(com_margin)
