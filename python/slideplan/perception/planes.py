"""Step 1 of perception (docs/perception.md): the table plane of a world-frame scene cloud.

RANSAC (scikit-learn's ``RANSACRegressor``, z as a linear function of x and y) on a random subsample,
repeated on the points left over, finds the large planes; the table is the highest one covering at
least ``min_area``, and it must be horizontal within ``max_tilt_deg``. A plane known from an earlier
cloud of the same camera skips the search while it still holds enough of the points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .._fields import as_numbers
from ..errors import InputError

_PLANE_SAMPLE = 20_000  # RANSAC runs on this many random points: plenty for a plane, fast for any cloud
_MAX_PLANES = 4  # floor, table, and a couple of box tops are all a tabletop scene has
_MIN_PLANE_FRACTION = 0.05  # a plane with fewer inliers is clutter or chance, not a support surface
_AREA_CELL = 0.01  # m; grid for estimating the area a plane's inliers cover


@dataclass
class Plane:
    """z = a x + b y + c, with its inliers among the RANSAC sample."""

    coefficients: np.ndarray  # (a, b, c)
    inliers: np.ndarray  # (k, 3) sample points

    @property
    def tilt_deg(self) -> float:
        return math.degrees(math.atan(math.hypot(*self.coefficients[:2])))

    def covered_area(self) -> float:
        """Area of the _AREA_CELL grid cells holding inliers (m^2)."""
        return occupied_cells(self.inliers[:, :2]) * _AREA_CELL**2


def occupied_cells(xy: np.ndarray) -> int:
    """How many _AREA_CELL cells hold points: distinct cells by one integer key each (numpy's unique
    over rows is ten times slower)."""
    if len(xy) == 0:
        return 0
    cells = np.floor(xy / _AREA_CELL).astype(np.int64)
    cells -= cells.min(axis=0)
    return len(np.unique(cells[:, 0] * (int(cells[:, 1].max()) + 1) + cells[:, 1]))


def default_cell_size(support_xy: np.ndarray) -> float:
    """Twice the mean point spacing of the table's points, clipped to [3, 10] mm."""
    spacing = math.sqrt(occupied_cells(support_xy) * _AREA_CELL**2 / len(support_xy))
    return float(np.clip(2.0 * spacing, 0.003, 0.01))


def known_plane(cloud: np.ndarray, table_plane, tolerance: float) -> Plane | None:
    """The table plane given by the caller, or None when there is none or it holds too few points (the camera moved)."""
    if table_plane is None:
        return None
    known = as_numbers(table_plane, 3, source="", field="table_plane")
    on_known = np.abs(cloud[:, 2] - cloud[:, :2] @ known[:2] - known[2]) < tolerance
    if on_known.mean() >= _MIN_PLANE_FRACTION:  # as much as a plane found by RANSAC must hold
        return Plane(known, cloud[on_known])
    return None


def find_table_plane(cloud: np.ndarray, tolerance: float, min_area: float, max_tilt_deg: float, seed: int,
                     problem: Callable[[str], InputError]) -> Plane:
    """The highest large plane, checked to be horizontal.

    Args:
        cloud: (N, 3) the scene cloud, world frame, z up (m).
        tolerance: distance from a plane (along z) within which a point is its inlier (m).
        min_area: a plane must cover at least this much (m^2).
        max_tilt_deg: largest accepted tilt from the horizontal (deg).
        seed: seed of the subsample and of RANSAC.
        problem: makes the error to raise from a message (it names the file or the argument).

    Raises:
        InputError: no large plane, or the highest one tilted more than ``max_tilt_deg``.
    """
    rng = np.random.default_rng(seed)
    sample = cloud[rng.choice(len(cloud), _PLANE_SAMPLE, replace=False)] if len(cloud) > _PLANE_SAMPLE else cloud
    large = [plane for plane in _fit_planes(sample, tolerance, seed) if plane.covered_area() >= min_area]
    if not large:
        span = float(np.max(np.ptp(cloud, axis=0)))
        # A table is metres across: a cloud spanning tens of metres is most likely in millimetres.
        units = f" (the cloud spans {span:g} along an axis: slideplan reads metres; is it in millimetres?)" if span > 20 else ""
        raise problem(f"no plane of at least {min_area:g} m^2 found: the cloud shows no table top{units}")
    # The highest: the floor is often the largest plane in view, the table stands above it.
    plane = max(large, key=lambda candidate: float(np.median(candidate.inliers[:, 2])))
    if plane.tilt_deg > max_tilt_deg:
        raise problem(
            f"the table plane is tilted {plane.tilt_deg:.1f} deg from horizontal (limit {max_tilt_deg:g} deg): "
            "a tilted table, or a cloud in the camera frame; give the cloud in the world frame with z up"
        )
    return plane


def _ransac_seed(seed: int) -> int:
    """scikit-learn's RANSAC takes seeds below 2**32: a larger seed is folded into that range by its
    SeedSequence (a smaller one is used as it is, as it always was)."""
    return seed if seed < 2**32 else int(np.random.SeedSequence(seed).generate_state(1, dtype=np.uint32)[0])


def _fit_planes(sample: np.ndarray, tolerance: float, seed: int) -> list[Plane]:
    """Large planes, one RANSAC run each on what the previous ones left."""
    from sklearn.linear_model import LinearRegression, RANSACRegressor

    planes = []
    remaining = sample
    min_inliers = max(3, int(_MIN_PLANE_FRACTION * len(sample)))
    for _ in range(_MAX_PLANES):
        if len(remaining) < min_inliers:
            break
        ransac = RANSACRegressor(
            LinearRegression(), min_samples=3, residual_threshold=tolerance, max_trials=200, random_state=_ransac_seed(seed)
        )
        try:
            ransac.fit(remaining[:, :2], remaining[:, 2])
        except ValueError:  # RANSAC found no consensus set at all
            break
        inliers = ransac.inlier_mask_
        if inliers.sum() < min_inliers:
            break
        model = ransac.estimator_
        planes.append(Plane(np.array([*model.coef_, model.intercept_]), remaining[inliers]))
        remaining = remaining[~inliers]
    return planes
