"""Experiment results on disk: one Parquet file per task, read back as one table.

Results go to ``OUT/results/part-<task_id>.parquet``, one row each, written atomically (temp
file + rename, so a file is either whole or absent). The directory is a Parquet dataset:
:func:`load_results`, pandas and pyarrow read it whole.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.dataset
import pyarrow.parquet as pq

from ..provenance import PROVENANCE_COLUMNS
from .tasks import Task

RESULTS_SUBDIR = "results"
PART_PREFIX, PART_SUFFIX = "part-", ".parquet"
STAT_COLUMNS = ("iterations", "start_roots", "goal_roots", "pairs_checked", "pairs_rejected", "nodes")
_ARROW_TYPES = {"str": pa.string(), "int": pa.int64(), "float": pa.float64()}
# Which build wrote a row, on which CPU and when (slideplan.provenance.run_provenance): the last columns of
# every experiment's rows.
PROVENANCE_FIELDS = [pa.field(name, pa.bool_() if name == "build_recorded_at_run" else pa.string())
                     for name in PROVENANCE_COLUMNS]

# One schema for every part file, so the dataset reads as one table even when a part
# holds nulls only (an error row has no iterations, a timeout no verdict).
ROW_SCHEMA = pa.schema(
    [("task_id", pa.string())]
    + [(item.name, _ARROW_TYPES[item.type]) for item in dataclasses.fields(Task)]
    + [("reconfiguration_range_m", pa.float64()), ("solved", pa.bool_()), ("status", pa.string()),
       ("planning_time_s", pa.float64())]
    + [(name, pa.int64()) for name in STAT_COLUMNS]
    + [("overhang_m", pa.float64()), ("verified", pa.bool_()), ("error", pa.string())]
    + PROVENANCE_FIELDS
)
"""Columns of a results row: the task (:meth:`Task.fields`), the outcome, then its provenance.

``status`` is ``"solved"``, ``"timeout"``, ``"invalid"`` (the planner returned a plan that
:func:`slideplan.verify` rejects) or ``"error"`` (the task raised; ``error`` has the text).
``solved`` is True only for verified plans; ``verified`` is null when there was no plan. ``build``
(the commit, ``+dirty`` when built from a changed tree), ``version``, ``cpu`` and ``date`` (UTC, ISO 8601,
when the task started) are :func:`slideplan.provenance.run_provenance`'s; ``build_recorded_at_run`` is
False for rows filled in after they were written (``docs/results/backfill_provenance.py``).
"""


def results_dir(out_dir: str | Path) -> Path:
    """Return ``OUT/results``, the Parquet dataset directory of an experiment output directory."""
    return Path(out_dir) / RESULTS_SUBDIR


def part_path(out_dir: str | Path, task_id: str) -> Path:
    """Return the result file of one task, ``OUT/results/part-<task_id>.parquet``."""
    return results_dir(out_dir) / f"{PART_PREFIX}{task_id}{PART_SUFFIX}"


def finished_task_ids(out_dir: str | Path) -> set[str]:
    """Return the task ids with a result file in ``OUT/results`` (empty if there is none).

    Only names are read: a part file exists only once it is complete (atomic rename).
    """
    return {
        path.name[len(PART_PREFIX):-len(PART_SUFFIX)]
        for path in results_dir(out_dir).glob(f"{PART_PREFIX}*{PART_SUFFIX}")
    }


def write_row(out_dir: str | Path, row: dict, schema: pa.Schema = ROW_SCHEMA) -> Path:
    """Write one results row to its part file atomically (temp file, then rename).

    The temp name starts with ``.``, which Parquet dataset readers skip, so a write cut
    short leaves nothing that looks like a result.

    Args:
        out_dir: the experiment output directory.
        row: a dict with the keys of ``schema``.
        schema: the row schema (:data:`ROW_SCHEMA` for planning experiments).

    Returns:
        The part file.
    """
    final = part_path(out_dir, row["task_id"])
    temporary = final.with_name(f".{final.name}.{os.getpid()}.tmp")
    pq.write_table(pa.Table.from_pylist([row], schema=schema), temporary)
    os.replace(temporary, final)
    return final


def load_results(path: str | Path, schema: pa.Schema = ROW_SCHEMA) -> pd.DataFrame:
    """Read results into a DataFrame, one row per finished task.

    Args:
        path: an experiment output directory (holding ``results/``), a results directory
            of part files, or a single Parquet file (e.g. a committed, compacted one:
            ``load_results(out).to_parquet(file)``).
        schema: the row schema (the execution experiment has its own,
            :data:`slideplan.experiments.execution.EXECUTION_ROW_SCHEMA`).

    Returns:
        The rows, with the columns of ``schema`` (empty if there are none).

    Raises:
        FileNotFoundError: ``path`` does not exist.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file or directory")
    if path.is_dir() and results_dir(path).is_dir():
        path = results_dir(path)
    files = sorted(path.glob("*.parquet")) if path.is_dir() else [path]  # not temp files, not figures
    table = pyarrow.dataset.dataset(files, format="parquet", schema=schema).to_table()
    return table.to_pandas()
