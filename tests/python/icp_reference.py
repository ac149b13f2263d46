"""The tracker's trimmed ICP written with NumPy and SciPy (cKDTree): the reference the C++ one
(``slideplan._core.OutlineIcp``) is checked against."""

import math

import numpy as np
from scipy.spatial import cKDTree


def icp_reference(model, grid, low, cell, inlier, points, starts, iterations, exact, gate):
    """Per start (motion, inliers, rmse), as ``OutlineIcp.fit``."""
    tree = cKDTree(model)

    def match(motions, exact):
        cos, sin = np.cos(motions[:, 2])[:, None], np.sin(motions[:, 2])[:, None]
        dx, dy = points[None, :, 0] - motions[:, 0, None], points[None, :, 1] - motions[:, 1, None]
        local = np.stack([dx * cos + dy * sin, dy * cos - dx * sin], axis=-1).reshape(-1, 2)
        if exact:
            distance, index = tree.query(local)
        else:
            cells = np.clip(np.floor((local - low) / cell).astype(int), 0, np.asarray(grid.shape) - 1)
            index = grid[cells[:, 0], cells[:, 1]]
            distance = np.linalg.norm(local - model[index], axis=1)
        return distance.reshape(len(motions), -1), index.reshape(len(motions), -1)

    motions = np.array(starts, dtype=float).reshape(-1, 3)
    gates = np.full(len(motions), gate)
    active = np.ones(len(motions), dtype=bool)
    for _ in range(iterations):
        rows = np.flatnonzero(active)
        if not len(rows):
            break
        distance, index = match(motions[rows], exact)
        keep = distance <= gates[rows, None]
        enough = keep.sum(axis=1) >= 3
        step = _rigid_fits(model[index], points, keep & enough[:, None])
        change = np.abs(step - motions[rows])
        moving = rows[enough]
        motions[moving] = step[enough]
        ordered = np.sort(np.where(keep[enough], distance[enough], np.inf), axis=1)
        count, kept_rows = keep[enough].sum(axis=1), np.arange(len(ordered))
        median = 0.5 * (ordered[kept_rows, (count - 1) // 2] + ordered[kept_rows, count // 2])
        gates[moving] = np.maximum(3.0 * median, inlier)
        active[rows[~enough | ((change[:, :2].max(axis=1) < 1e-5) & (change[:, 2] < 1e-4))]] = False
    distance, _ = match(motions, True)
    fits = []
    for motion, row in zip(motions, distance):
        inliers = row[row <= inlier]
        fits.append((motion, len(inliers), float(np.sqrt(np.mean(inliers ** 2))) if len(inliers) else math.inf))
    return fits


def _rigid_fits(source, target, weights):
    """Per row, the 2-D Kabsch motion mapping source (S, N, 2) onto target (N, 2) over the selected pairs."""
    weights = weights.astype(float)
    total = np.maximum(weights.sum(axis=1), 1.0)[:, None]
    source_mean = np.einsum("sn,snk->sk", weights, source) / total
    target_mean = weights @ target / total
    a = source - source_mean[:, None, :]
    b = target[None, :, :] - target_mean[:, None, :]
    yaw = np.arctan2(np.sum(weights * (a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]), axis=1),
                     np.sum(weights * (a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]), axis=1))
    cos, sin = np.cos(yaw), np.sin(yaw)
    x = target_mean[:, 0] - (cos * source_mean[:, 0] - sin * source_mean[:, 1])
    y = target_mean[:, 1] - (sin * source_mean[:, 0] + cos * source_mean[:, 1])
    return np.column_stack([x, y, yaw])
