"""Convex parts of the hand meshes whose hull fills a concavity, for MuJoCo.

MuJoCo collides every mesh as its convex hull. The planner checks a hand mesh whose hull is more than
``_core.concave_hull_ratio`` times its volume as its triangles (the Z1's jaws and their housing in one
mesh: the hull fills the gap the object enters); execution splits that mesh into convex parts with
CoACD (approximate convex decomposition, which keeps such a gap open) and collides the parts.

A decomposition takes seconds (the Z1's two jaw meshes: about 15 s), so the parts are stored in the
cache folder of :mod:`slideplan.grasp_cache` (``convex-parts``), named by a hash of the mesh and the
decomposition's settings; the next process reads them.
"""

from __future__ import annotations

import hashlib
import threading

import numpy as np

from ..grasp_cache import cache_dir, write_npz

# CoACD's settings: a 10% concavity bound keeps the Z1's jaw gap open (tests/python/test_execute.py),
# at most 12 parts keep the contact count low, and a fixed seed makes the parts the same in every run.
_SETTINGS = {"threshold": 0.1, "max_convex_hull": 12, "preprocess_resolution": 30, "resolution": 1000,
             "mcts_iterations": 60, "mcts_max_depth": 2, "seed": 1}
_FORMAT = 1  # bumped when the file layout or the settings' meaning changes
_lock = threading.Lock()


def convex_parts(vertices: np.ndarray, faces: np.ndarray) -> list[np.ndarray]:
    """The vertices of each convex part of a triangle mesh, read from the cache or decomposed.

    Args:
        vertices: (N, 3) the mesh's vertices.
        faces: (M, 3) its triangles (vertex indices).

    Returns:
        One (K, 3) array per part, in the mesh's frame.
    """
    vertices, faces = np.ascontiguousarray(vertices, dtype=float), np.ascontiguousarray(faces, dtype=np.int64)
    digest = hashlib.sha256(vertices.tobytes() + faces.tobytes() + repr((_FORMAT, sorted(_SETTINGS.items()))).encode())
    folder = cache_dir("convex-parts")
    path = None if folder is None else folder / f"{digest.hexdigest()[:32]}.npz"
    with _lock:  # one decomposition of a mesh at a time; threads then read it
        if path is not None and path.is_file():
            try:
                with np.load(path) as stored:
                    return [stored[f"part_{index}"] for index in range(len(stored.files))]
            except (OSError, ValueError, KeyError):
                pass  # unreadable: decompose again and overwrite it
        import coacd

        coacd.set_log_level("error")
        parts = [np.asarray(part_vertices, dtype=float) for part_vertices, _ in coacd.run_coacd(coacd.Mesh(vertices, faces), **_SETTINGS)]
        if path is not None:
            write_npz(path, {f"part_{index}": part for index, part in enumerate(parts)})
        return parts
