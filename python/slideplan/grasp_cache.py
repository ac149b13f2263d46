"""The grasp map on disk, so that the second plan on a scene starts warm in a new process.

A grasp map (``_core.GraspMap``) answers, per 1 cm stretch of a table edge, whether a liftable side grasp
is reachable there; each answer depends only on the robot's kinematics, the hand's grasp frame, the
table, the object's thickness and five grasp parameters, so a stored answer is the answer a fresh probe
would give and a plan is the same with a stored map or a fresh one. Maps are stored as ``.npz`` files
named by a SHA-256 of every such input: the URDF's and each attached file's bytes, the robot block but
its file paths, the table, the thickness, the parameters, and the identity of the compiled core (a
rebuilt core may probe differently). Any changed input names another file.

Where: ``$SLIDEPLAN_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/slideplan`` (``~/.cache/slideplan``), in
its ``grasp-maps`` folder. ``SLIDEPLAN_NO_CACHE=1`` (the CLI's ``--no-cache``) turns it off. Files are
written whole to a temporary file and renamed, so concurrent processes never read a partial file; two
writers merge with what is on disk and the last rename wins (a lost entry is only probed again).
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import tempfile
import threading
from pathlib import Path
from typing import Any

import numpy as np

CACHE_DIR_ENV = "SLIDEPLAN_CACHE_DIR"
NO_CACHE_ENV = "SLIDEPLAN_NO_CACHE"
_FORMAT = 1  # bumped when the file layout or the key changes
_PATH_KEYS = ("urdf", "attach", "package_dirs")  # named by content instead; meshes do not enter a probe
_lock = threading.Lock()
_saved: dict[Path, int] = {}  # entries this process last read or wrote, per file


def cache_dir(folder: str = "grasp-maps") -> Path | None:
    """The cache's ``folder`` (the stored grasp maps by default), or None when the cache is turned off."""
    if os.environ.get(NO_CACHE_ENV, "") not in ("", "0"):
        return None
    root = os.environ.get(CACHE_DIR_ENV) or Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "slideplan"
    return Path(root) / folder


@functools.cache  # the loaded core does not change while the process runs
def _core_identity() -> str:
    from . import _core

    stat = os.stat(_core.__file__)
    return f"{stat.st_size}:{stat.st_mtime_ns}"


def map_path(robot: dict[str, Any], vertices: tuple, height: float, thickness: float, params: tuple) -> Path | None:
    """The file of the grasp map of these inputs (None when the cache is off).

    Args:
        robot: the plan JSON's robot block (:func:`slideplan.plan.robot.robot_description`).
        vertices, height: the table polygon and height.
        thickness: the object's thickness as the map keeps it (to the micrometre).
        params: the values of the grasp parameters the map depends on (slideplan.parameters.GRASP_MAP_NAMES).

    Raises:
        OSError: the URDF or an attached file cannot be read.
    """
    folder = cache_dir()
    if folder is None:
        return None
    digest = hashlib.sha256()
    for path in [robot["urdf"], *robot["attach"]]:
        digest.update(Path(path).read_bytes())
    rest = {key: value for key, value in robot.items() if key not in _PATH_KEYS}
    inputs = [_FORMAT, _core_identity(), rest, vertices, height, thickness, params]
    digest.update(json.dumps(inputs, sort_keys=True, default=lambda value: np.asarray(value).tolist()).encode())
    return folder / f"{digest.hexdigest()[:32]}.npz"


def _read(path: Path) -> list[tuple[int, int, np.ndarray]]:
    """The entries stored in ``path``; none if it is missing or unreadable (then it is probed anew)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            edges, cells, reachable, grasps = data["edges"], data["cells"], data["reachable"], data["grasps"]
        return [(int(edge), int(cell), grasps[i] if reachable[i] else np.zeros(0))
                for i, (edge, cell) in enumerate(zip(edges, cells))]
    except (OSError, KeyError, ValueError, IndexError):
        return []


def restore(grasp_map, path: Path | None) -> None:
    """Give a fresh ``_core.GraspMap`` the answers stored for its inputs (nothing if none, or unusable)."""
    if path is None:
        return
    entries = _read(path)
    try:
        grasp_map.remember(entries)
    except ValueError:  # not this robot's or table's: overwritten at the next save
        entries = []
    with _lock:
        _saved[path] = len(entries)


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> bool:
    """Write ``arrays`` to ``path`` atomically (readers never see half a file); False when the folder
    cannot be written, which leaves the cache cold, never the caller failed."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".npz")
    except OSError:
        return False
    try:
        with os.fdopen(handle, "wb") as file:
            np.savez(file, **arrays)
        os.replace(temporary, path)
    except OSError:
        Path(temporary).unlink(missing_ok=True)
        return False
    return True


def persist(grasp_map, path: Path | None) -> None:
    """Store the map's answers if it learnt some since it was last read or written. A folder that cannot
    be written leaves the cache cold, never the plan failed."""
    if path is None:
        return
    with _lock:
        if grasp_map.probed <= _saved.get(path, 0):
            return
        known = {(edge, cell): grasp for edge, cell, grasp in _read(path)}
        known.update({(edge, cell): np.asarray(grasp) for edge, cell, grasp in grasp_map.entries()})
        dof = max((len(grasp) for grasp in known.values()), default=0)
        keys = sorted(known)
        arrays = {
            "edges": np.array([key[0] for key in keys], dtype=np.int64),
            "cells": np.array([key[1] for key in keys], dtype=np.int64),
            "reachable": np.array([len(known[key]) > 0 for key in keys], dtype=bool),
            "grasps": np.array([known[key] if len(known[key]) else np.zeros(dof) for key in keys]).reshape(len(keys), dof),
        }
        if write_npz(path, arrays):
            _saved[path] = len(keys)
