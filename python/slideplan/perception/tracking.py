"""Tracking the sliding object in depth frames of a fixed camera (beyond the paper: the closed loop).

The object's outline is known (from the scene or :mod:`slideplan.perception.tabletop`) and so is roughly
where it is (the last estimate, or where Eq. 2 puts it); a new depth frame says where it is now.
Rather than segment the scene again, the tracker registers the known outline to the object's
*edges with the table* in the frame:

1. a 3 x 3 median filter of the depth image (sensor noise shrinks, a step between two surfaces
   stays where it is), back-projected pixel by pixel;
2. near the expected pose each pixel is *object* (its height above the table between half the
   thickness and the thickness plus ``hand_clearance``), *table* (within half the thickness of
   the table top) or neither (the arm and hand above it, dropouts, the floor);
3. the edge points are the object pixels next to a table pixel and the table pixels next to an
   object pixel (the two sides of the edge, so the half-pixel offsets cancel); where the arm hides
   the object there is no object-table edge, so occlusion removes points instead of adding wrong
   ones;
4. a trimmed 2-D ICP of those points to the outline (point to nearest outline point, the rigid
   fit in closed form, pairs beyond three times the median distance dropped);
5. the fit counts only if its edge points hold it in x and y: with the arm over the object, the one
   edge left in view may be straight, and a straight edge lets the outline slide along it (the fit
   is then anywhere along it, centimetres off). The outline's normals at the matched points give the
   translation's information matrix; its smallest eigenvalue must reach ``MIN_CONSTRAINT``;
6. and only if the frame shows the object where the fit puts it: inside its outline (``INLIER_M`` in
   from the edge) at least ``MIN_EDGE_POINTS`` object pixels, and table pixels at most
   ``MAX_TABLE_INSIDE`` of the pixels seen there. The edges of the hand with the table fit the outline
   too, with the fit wholly under the hand, where no pixel shows it.

Needs SciPy (``perception`` extra).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import MultiPoint, Polygon

from .. import _core
from .._fields import as_number, as_numbers
from ..errors import InputError
from ..world.objects import ThinObject
from .camera import Camera, pixel_points
from ..transforms import move_planar, rotation_2d, wrap_angle

OUTLINE_SPACING_M = 0.0005  # the outline is matched as points this far apart
GRID_CELL_M = 0.0005  # the nearest-point grid's cell: its answers are within 0.4 mm of the nearest
MIN_EDGE_POINTS = 20  # fewer edge pixels than this is no evidence of where the object is
START_YAW = 0.12  # rad: the second and third starts of the fit turn the guess by this much either way
SCOUT_ITERATIONS = 8  # ICP iterations from each start before the best one is refined
EXPLAINED = 0.85  # a fit from the guess explaining this fraction of the edge points, NEAR_GUESS, is taken
NEAR_GUESS = (0.01, 0.1)  # m (the centre of mass), rad
INLIER_M = 0.003  # an edge point this near the fitted outline is explained by it (about a pixel at 0.75 m)
MIN_CONSTRAINT = 2.0  # the fit's weakest direction in x, y must be held by as many edge points as this, head on
MAX_TABLE_INSIDE = 0.1  # of the pixels seen inside a fit's outline, at most this fraction may be table

NOT_UNDER_TIP = "no fit puts the object under the fingertip"  # a TrackedPose reason


@dataclass(frozen=True)
class TrackedPose:
    """One frame's estimate.

    Attributes:
        ok: the frame showed enough of the object's edge and the fit converged.
        motion: (x, y, yaw) taking the reference object (the ``obj`` given to :func:`track`) to where
            the frame shows it: ``obj.moved(motion)`` is the object now. The guess when not ``ok``.
        edge_points: edge points within ``INLIER_M`` of the fitted outline.
        rmse_m: their root mean square distance to it (m).
        reason: why not ``ok`` ("" when ok).
    """

    ok: bool
    motion: tuple[float, float, float]
    edge_points: int
    rmse_m: float
    reason: str = ""


class Tracker:
    """Registers one object's outline in depth frames of one camera.

    Args:
        obj: the object as perceived at the start (its pose is the reference of every motion).
        camera: the fixed camera that takes the frames.
        table_height: z of the table top (m).
        table_plane: the table top as this camera sees it, ``z = a x + b y + c`` as ``(a, b, c)``
            (:attr:`slideplan.perception.tabletop.Perception.plane`), or None for the level ``table_height``.
            Heights are measured from it: a camera mounted a few millimetres or a fraction of a degree
            off where it is believed to be sees the table that far off ``table_height``, and a thin
            object is only millimetres high.
        hand_clearance: pixels higher than the object's top by more than this are not the object
            (the finger, hand and arm over it), m.
        window_margin: pixels further than this from the object's expected footprint are ignored, m.
        iterations: ICP iterations at most per frame.

    Raises:
        InputError: a clearance or margin that is not a positive number, an iteration count that is
            not a positive integer, a table height or plane that is not numbers, or an object known only as a
            cloud whose concave hull has no area.
    """

    def __init__(self, obj: ThinObject, camera: Camera, *, table_height: float, table_plane=None,
                 hand_clearance: float = 0.01, window_margin: float = 0.05, iterations: int = 40) -> None:
        self.hand_clearance = as_number(hand_clearance, source="", field="hand_clearance", positive=True)
        self.window_margin = as_number(window_margin, source="", field="window_margin", positive=True)
        if not isinstance(iterations, int) or isinstance(iterations, bool) or iterations <= 0:
            raise InputError(f"expected a positive integer, got {iterations!r}", field="iterations")
        self.obj, self.camera, self.iterations = obj, camera, iterations
        self.table_height = as_number(table_height, source="", field="table_height")
        self.table_plane = None if table_plane is None else as_numbers(table_plane, 3, source="", field="table_plane")
        # Concave, unlike symmetry_turns' convex hull: a crescent's convex hull covers its bite, where the camera sees table.
        outline = obj.outline if obj.outline is not None else _cloud_outline(obj.points[:, :2])
        self.outline = outline  # where the pressing finger may be: on the material, not in a crescent's bite
        shapely.prepare(self.outline)
        interior = outline.buffer(-INLIER_M)
        self._interior_outline = outline if interior.is_empty else interior  # a strip under 6 mm wide: all of it
        shapely.prepare(self._interior_outline)
        self._model, self._normals = _densify(outline, OUTLINE_SPACING_M)
        self._icp_core = _core.OutlineIcp(self._model, *_nearest_grid(self._model, self.window_margin), GRID_CELL_M, INLIER_M)
        self._centre = np.asarray(obj.centroid_xy, dtype=float)
        self._radius = float(np.max(np.linalg.norm(obj.points[:, :2] - self._centre, axis=1)))

    def classify(self, depth: np.ndarray, guess) -> tuple[np.ndarray, np.ndarray]:
        """The object-table edge points and the object points of a frame near the guessed pose (steps
        1-3 of the module).

        Args:
            depth: (height, width) depth image of the tracker's camera (m), NaN for no return.
            guess: (x, y, yaw) motion of the reference object expected now.

        Returns:
            (K, 2) world xy of the edge points, (L, 2) of the object's pixels, (M, 2) of the table's.
        """
        from scipy.ndimage import binary_dilation, median_filter

        centre = move_planar(self._centre[None, :], guess)[0]
        reach = self._radius + self.window_margin
        # Only the pixels that can see the window around the expected footprint are filtered.
        corners = np.array([[centre[0] + dx, centre[1] + dy, self.table_height] for dx in (-reach, reach) for dy in (-reach, reach)])
        pixels = self.camera.pixels(corners)
        low = np.clip(np.floor(pixels.min(axis=0)).astype(int) - 2, 0, None)
        high = np.minimum(np.ceil(pixels.max(axis=0)).astype(int) + 3, depth.shape)
        if np.any(high <= low):
            return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2))
        window = depth[low[0]:high[0], low[1]:high[1]]
        filled = np.where(np.isfinite(window), window, np.inf)  # a dropout never wins the median unless most are
        world = pixel_points(median_filter(filled, size=3, mode="nearest"), self.camera, (int(low[0]), int(low[1])))
        height = self._height(world)
        with np.errstate(invalid="ignore"):
            near = np.linalg.norm(world[..., :2] - centre, axis=-1) <= reach
            half = 0.5 * self.obj.thickness
            is_object = near & (height > half) & (height < self.obj.thickness + self.hand_clearance)
            is_table = near & (np.abs(height) < half)
        cross = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], dtype=bool)
        edge = (is_object & binary_dilation(is_table, cross)) | (is_table & binary_dilation(is_object, cross))
        return world[edge][:, :2], world[is_object][:, :2], world[is_table][:, :2]

    def _height(self, world: np.ndarray) -> np.ndarray:
        """Each back-projected point's height above the table top (m)."""
        if self.table_plane is None:
            return world[..., 2] - self.table_height
        a, b, c = self.table_plane
        return world[..., 2] - (a * world[..., 0] + b * world[..., 1] + c)

    def locate(self, depth: np.ndarray, guess, region: Polygon):
        """Where to start tracking an object that is nowhere near ``guess``: ``guess`` shifted so that the
        object's centre of mass lies at the middle of the largest patch of pixels at the object's height
        over ``region`` anywhere in the frame (:meth:`track` looks only near its guess, and a push or a
        slide gone wrong can leave the object farther away). None when no patch has ``MIN_EDGE_POINTS``
        pixels.

        Args:
            depth: (height, width) depth image of the tracker's camera (m), NaN for no return.
            guess: (x, y, yaw) motion of the reference object: its yaw is kept.
            region: where the object may lie (the table top), world xy.
        """
        from scipy.ndimage import label, median_filter

        filled = np.where(np.isfinite(depth), depth, np.inf)
        world = pixel_points(median_filter(filled, size=3, mode="nearest"), self.camera)
        height = self._height(world)
        with np.errstate(invalid="ignore"):
            level = (height > 0.5 * self.obj.thickness) & (height < self.obj.thickness + self.hand_clearance)
        level &= np.isfinite(world[..., 0])
        level[level] = shapely.contains_xy(region, world[level][:, 0], world[level][:, 1])
        patches, count = label(level)
        if count == 0:
            return None
        sizes = np.bincount(patches.ravel())[1:]
        if sizes.max() < MIN_EDGE_POINTS:
            return None
        centre = world[patches == 1 + int(np.argmax(sizes))][:, :2].mean(axis=0)
        yaw = float(guess[2])
        shift = centre - rotation_2d(yaw) @ self._centre
        return (float(shift[0]), float(shift[1]), yaw)

    def track(self, depth: np.ndarray, guess=(0.0, 0.0, 0.0), contact=None) -> TrackedPose:
        """Estimate where the object is in one frame.

        Args:
            depth: (height, width) depth image of the tracker's camera (m), NaN for no return.
            guess: (x, y, yaw) motion of the reference object expected now (the last estimate, or the
                pose Eq. 2 predicts); the fit starts there.
            contact: (x, y) of the fingertip pressing on the object (its measured pose), or None: only
                a fit that puts the object under it is taken. The edges of the finger and hand with the
                table can match part of the outline better than the occluded object does; this is
                what rules those fits out.

        Returns:
            The estimate; ``ok`` False (with the reason) when the frame shows too little edge, no fit
            puts the object under ``contact``, or the fit is not held in x and y or not shown by the
            frame (module steps 5 and 6).

        Raises:
            InputError: a depth image of another shape than the camera's, or a guess that is not 3
                finite numbers.
        """
        depth = np.asarray(depth, dtype=float)
        if depth.shape != (self.camera.height, self.camera.width):
            raise InputError(f"expected a ({self.camera.height}, {self.camera.width}) depth image, got shape {depth.shape}",
                             field="depth")
        guess = tuple(float(value) for value in as_numbers(guess, 3, source="", field="guess"))
        if contact is not None:
            contact = as_numbers(contact, 2, source="", field="contact")
        points, inside, table = self.classify(depth, guess)
        if len(points) < MIN_EDGE_POINTS:
            return TrackedPose(False, guess, len(points), math.nan, f"{len(points)} edge points in view (< {MIN_EDGE_POINTS})")
        # A disturbed object may lie centimetres from the guess, where the nearest outline points pull
        # ICP into a wrong fit. When the fit from the guess leaves edge points unexplained or lands far
        # from the guess (a slide moves the object a few millimetres between frames), more starts:
        # the guess moved by the shift of the object pixels' mean (biased where the hand hides part of
        # it, but near), both turned either way. The fit that explains more edge points wins.
        fit = self._icp(points, [guess], self.iterations)[0]
        expected = move_planar(self._centre[None, :], guess)[0]
        shifted = np.linalg.norm(move_planar(self._centre[None, :], fit[0])[0] - expected)
        turned = abs(wrap_angle(float(fit[0][2]) - guess[2]))
        if fit[1] < EXPLAINED * len(points) or shifted > NEAR_GUESS[0] or turned > NEAR_GUESS[1]:
            shift = inside.mean(axis=0) - expected if len(inside) else np.zeros(2)
            offsets = [np.zeros(2)] + ([shift] if np.linalg.norm(shift) > 0.003 else [])
            # Short fits from the guess and the shifted guess, each also turned by +-START_YAW; the best goes on.
            starts = [np.array(guess) + [dx, dy, turn] for dx, dy in offsets for turn in (0.0, -START_YAW, START_YAW)]
            scouts = self._icp(points, starts, SCOUT_ITERATIONS, exact=False)
            under = [scout for scout in scouts if self._holds(scout[0], contact)]
            refined = self._icp(points, [max(under or scouts, key=_score)[0]], self.iterations)[0]
            fits = [candidate for candidate in (fit, refined) if self._holds(candidate[0], contact)]
            if not fits:
                return TrackedPose(False, guess, 0, math.nan, NOT_UNDER_TIP)
            fit = max(fits, key=_score)
        elif not self._holds(fit[0], contact):
            return TrackedPose(False, guess, 0, math.nan, NOT_UNDER_TIP)
        motion, inliers, rmse = fit
        if inliers < MIN_EDGE_POINTS:
            return TrackedPose(False, guess, inliers, math.nan, "the fit lost the edge")
        held = self._held(points, motion)
        if held < MIN_CONSTRAINT:
            return TrackedPose(False, guess, inliers, math.nan,
                               f"the edge in view does not fix the pose (held by {held:.1f} points < {MIN_CONSTRAINT:g})")
        seen, table_share = self._interior(motion, inside, table)
        if seen < MIN_EDGE_POINTS or table_share > MAX_TABLE_INSIDE:
            return TrackedPose(False, guess, inliers, math.nan, f"the frame does not show the object where the fit puts it "
                               f"({seen} object pixels inside, {100 * table_share:.0f}% of those seen there table)")
        return TrackedPose(True, (float(motion[0]), float(motion[1]), wrap_angle(float(motion[2]))), inliers, rmse)

    def _holds(self, motion: np.ndarray, contact) -> bool:
        """Whether the outline at ``motion`` covers ``contact`` (within ``INLIER_M``): the finger presses
        on the object's material (the planner draws its contacts from the object's points), so a fit with
        the fingertip in a concave bite is a wrong one; True without one."""
        if contact is None:
            return True
        local = (np.asarray(contact, dtype=float) - motion[:2]) @ rotation_2d(motion[2])
        return self.outline.distance(shapely.Point(local)) <= INLIER_M

    def _interior(self, motion: np.ndarray, inside: np.ndarray, table: np.ndarray) -> tuple[int, float]:
        """The object pixels inside the outline at ``motion`` (``INLIER_M`` in from its edge), and the
        share of table pixels among the pixels seen there (module step 6)."""
        counts = []
        for pixels in (inside, table):
            local = (pixels - motion[:2]) @ rotation_2d(motion[2])
            counts.append(int(shapely.contains_xy(self._interior_outline, local[:, 0], local[:, 1]).sum()))
        return counts[0], counts[1] / max(sum(counts), 1)

    def _held(self, points: np.ndarray, motion: np.ndarray) -> float:
        """How firmly the edge points explained by the fit at ``motion`` hold it: the smallest eigenvalue
        of its point-to-outline information matrix (module step 5)."""
        distance, index = self._icp_core.nearest(points, motion)
        normals = self._normals[index[distance <= INLIER_M]]
        return float(np.linalg.eigvalsh(normals.T @ normals)[0])

    def _icp(self, points: np.ndarray, starts, iterations: int, exact: bool = True) -> list[tuple[np.ndarray, int, float]]:
        """Trimmed ICP (module step 4, ``slideplan._core.OutlineIcp``) from each of ``starts`` ((S, 3)
        motions): per start the fit, the edge points within ``INLIER_M`` of the outline, and their root
        mean square distance. ``exact=False``: iterations pair by the grid (scouting: fast, a fit's last
        tenths of a degree aside)."""
        starts = np.array(starts, dtype=float).reshape(-1, 3)
        # No gate at first: a start may be centimetres off.
        return self._icp_core.fit(points, starts, iterations, exact, self._radius)


def _score(fit: tuple[np.ndarray, int, float]) -> tuple[int, float]:
    """Order of fits: more edge points explained, then a smaller residual."""
    return fit[1], -fit[2]


def _nearest_grid(model: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """For ICP's pairing by grid: the index of the outline point nearest each cell (``GRID_CELL_M``)
    of the outline's bounding box and ``margin`` around it (a distance transform of the outline's
    cells, made once; its answer is within a cell of the true nearest), and the grid's corner. ICP asks
    for the nearest point of every edge point in every iteration from every start, where a k-d tree
    query would cost most of a scouting's time."""
    from scipy.ndimage import distance_transform_edt

    low = model.min(axis=0) - margin
    shape = np.ceil((model.max(axis=0) + margin - low) / GRID_CELL_M).astype(int) + 1
    cells = np.clip(np.floor((model - low) / GRID_CELL_M).astype(int), 0, shape - 1)
    owner = np.full(shape, -1, dtype=np.int64)
    owner[cells[:, 0], cells[:, 1]] = np.arange(len(model))
    _, nearest = distance_transform_edt(owner < 0, return_indices=True)
    return owner[nearest[0], nearest[1]], low


def _densify(outline: Polygon, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``spacing`` along every ring of the outline, and the ring's unit normal at each."""
    points, normals = [], []
    for ring in (outline.exterior, *outline.interiors):
        ring_points = np.asarray(shapely.segmentize(ring, spacing).coords)[:-1]
        along = np.roll(ring_points, -1, axis=0) - np.roll(ring_points, 1, axis=0)
        points.append(ring_points)
        normals.append(np.column_stack([along[:, 1], -along[:, 0]]) / np.linalg.norm(along, axis=1)[:, None])
    return np.concatenate(points), np.concatenate(normals)


def _cloud_outline(xy: np.ndarray) -> Polygon:
    """An outline for an object known only as a cloud: its concave hull (shapely), the points'
    spacing as the detail it keeps."""
    outline = shapely.concave_hull(MultiPoint(xy), ratio=0.05)
    if not isinstance(outline, Polygon) or outline.area <= 0:
        raise InputError("the object's cloud has no area to track", field="obj")
    return outline
