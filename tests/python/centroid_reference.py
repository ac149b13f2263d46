"""The area centroid written with SciPy (Delaunay, cKDTree): the reference the C++ one is checked against."""

import numpy as np
from scipy.spatial import Delaunay, QhullError, cKDTree


def area_centroid_reference(xy) -> np.ndarray:
    """Area centroid of the alpha shape of (N, 2) points (see slideplan.world.geometry.area_centroid)."""
    points = np.asarray(xy, dtype=float)
    if len(points) > 20_000:
        _, first = np.unique(np.floor(points / 1e-3).astype(np.int64), axis=0, return_index=True)
        points = points[np.sort(first)]
    try:
        simplices = Delaunay(points).simplices
    except (QhullError, ValueError):
        return points.mean(axis=0)
    triangles = points[simplices]
    spacing = cKDTree(points).query(points, k=min(7, len(points)))[0][:, 1:].mean(axis=1)
    longest = np.max(np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2), axis=1)
    kept = triangles[longest <= 1.5 * spacing[simplices].max(axis=1)]
    edge_1, edge_2 = kept[:, 1] - kept[:, 0], kept[:, 2] - kept[:, 0]
    areas = 0.5 * np.abs(edge_1[:, 0] * edge_2[:, 1] - edge_1[:, 1] * edge_2[:, 0])
    if areas.sum() <= 0.0:
        return points.mean(axis=0)
    return (areas[:, None] * kept.mean(axis=1)).sum(axis=0) / areas.sum()
