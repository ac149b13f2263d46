"""Provenance: which build made a result, on which CPU, and when.

CMake records the build at configure time in ``slideplan/_build.py`` (from ``cmake/build_info.py.in``),
so an installed wheel knows the commit it was built from; :func:`build_info` reads it.
:func:`run_provenance` adds the CPU and the date: the columns every experiment row carries
(:data:`PROVENANCE_COLUMNS`), and what every benchmark page names in its header.
"""

from __future__ import annotations

import datetime
import functools
import platform
from pathlib import Path

UNKNOWN = "unknown"
PROVENANCE_COLUMNS = ("build", "version", "cpu", "date", "build_recorded_at_run")
"""Row columns of :func:`run_provenance`. ``build_recorded_at_run`` is False only for rows written
before provenance existed and filled in afterwards (``docs/results/backfill_provenance.py``)."""


def build_info() -> dict:
    """The build this package was made from, as CMake recorded it when the package was built.

    Returns:
        A dict: ``build``, the commit with ``+dirty`` appended when tracked files differed from it
        (``"abc1234"``, ``"abc1234+dirty"``; ``"unknown"`` when built without git, e.g. from a source
        tarball); ``commit``, the commit's first 7 hex digits or ``"unknown"``; ``dirty`` (bool; untracked
        files do not count); ``version``, the package version. Run from a source checkout that was never
        built (no ``_build.py``), every field but ``dirty`` is ``"unknown"``.
    """
    try:
        from . import _build
    except ImportError:  # python/ on sys.path without a build: nothing was recorded
        commit, dirty, version = UNKNOWN, False, UNKNOWN
    else:
        commit, dirty, version = _build.COMMIT, bool(_build.DIRTY), _build.VERSION
    return {"build": f"{commit}+dirty" if dirty else commit, "commit": commit, "dirty": dirty, "version": version}


@functools.lru_cache(maxsize=1)
def cpu_model() -> str:
    """The CPU's model name: ``model name`` of ``/proc/cpuinfo`` (Linux), else :func:`platform.processor`,
    else the machine type; ``"unknown"`` if none says."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:  # not Linux
        pass
    return platform.processor() or platform.machine() or UNKNOWN


def run_provenance() -> dict:
    """The provenance columns of a row written now (:data:`PROVENANCE_COLUMNS`).

    Returns:
        A dict: ``build`` and ``version`` from :func:`build_info`, ``cpu`` (:func:`cpu_model`), ``date``
        (now, UTC, ISO 8601 to the second, e.g. ``"2026-12-06T09:30:00Z"``) and ``build_recorded_at_run``
        (True).
    """
    info = build_info()
    now = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)
    return {"build": info["build"], "version": info["version"], "cpu": cpu_model(),
            "date": now.isoformat().replace("+00:00", "Z"), "build_recorded_at_run": True}
