"""Generated blocks of issue 53's closed-loop evaluation (docs/results/closed_loop.md): the world's verdict
per task set, setting and mode, from ``closed_loop_dev.parquet`` and ``closed_loop_eval.parquet`` (one row
per run, :func:`slideplan.experiments.closed_loop.closed_loop_runs`). A set without its file is reported as
not run yet."""

from __future__ import annotations

from numbers_common import HERE, rows
from slideplan.experiments.closed_loop_report import SETS, report

SET_FILES = {name: f"closed_loop_{name}.parquet" for name in SETS}


def values() -> dict[str, str]:
    """The ``cl53-report`` block."""
    sets = {name: rows(file, "runs") if (HERE / file).exists() else None for name, file in SET_FILES.items()}
    return {"cl53-report": report(sets)}
