"""Give the committed result rows written before rows recorded their build the provenance columns.

Rows written by the experiments now carry ``build``, ``version``, ``cpu``, ``date`` and
``build_recorded_at_run`` = True (:func:`slideplan.provenance.run_provenance`). The Parquet files in this
folder predate them: this script fills their rows from what the results pages
(``README.md``, ``execution.md``, ``closed_loop.md``) say about each file, with ``build_recorded_at_run`` =
False, so that nobody mistakes a backfill for a record. A value no page states, or that differs between
rows the file cannot tell apart, is ``"unrecorded"``; no page names a package version. Dates are the
pages' (when a run finished), without a time.

Idempotent: rows that already recorded their build at run time are left as they are, and backfilled rows
get the same values again. Usage (from the repository root)::

    python docs/results/backfill_provenance.py [FILE ...]    # default: every file of FILES
"""

from __future__ import annotations

import sys
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from slideplan.experiments.results import PROVENANCE_FIELDS

HERE = Path(__file__).resolve().parent
UNRECORDED = "unrecorded"
AMD = "AMD EPYC"
# File (relative to this folder) -> (build, cpu, date) of its rows, as its page states them.
FILES = {
    "fig10.parquet": ("06e0096", AMD, "2026-12-01"),  # README.md, Machine: "planner of commit 06e0096"
    "fig10_paper.parquet": ("06e0096", AMD, "2026-12-01"),
    # Four sessions (bc015d9 on an AMD EPYC, 388daad and 3460cc6 on Intel Xeons, a37807a on an AMD EPYC)
    # whose rows the file does not tell apart.
    "fig11.parquet": (UNRECORDED, UNRECORDED, UNRECORDED),
    # The baselines' rows are fig11.parquet's (mixed sessions); slideplan's are told apart below.
    "fig11_paper.parquet": (UNRECORDED, UNRECORDED, UNRECORDED),
    "fig12.parquet": ("a37807a", AMD, "2026-12-02"),
    "fig12_paper.parquet": ("a37807a", AMD, "2026-12-02"),
    # The execution files' rows record their own build since their rerun at b30da0b (2026-12-06); these
    # are what the page said of the rows before, used only for a row that recorded none.
    "execution.parquet": ("d3e2f75", AMD, UNRECORDED),
    "execution_paper.parquet": ("03f2c70", UNRECORDED, UNRECORDED),
    # The closed-loop sets: every row recorded its build at run time (closed_loop.md names them); these values
    # would serve only a row that recorded none.
    "closed_loop_dev.parquet": ("a380440", "Intel(R) Xeon(R) Processor", "2026-12-06"),
    "closed_loop_eval.parquet": ("a380440", "Intel(R) Xeon(R) Processor", "2026-12-06"),
    "closed_loop_clutter.parquet": ("df67b8c", AMD, "2026-12-07"),
    "closed_loop_eval_rerun.parquet": ("bd11be7", AMD, "2026-12-07"),
    "closed_loop_dev_rerun.parquet": ("b323f11", AMD, "2026-12-07"),
    "closed_loop_eval2.parquet": ("5ee2cb0", AMD, "2026-12-07"),
    # benchmarks/hands_sweep.py's rows, recorded at run time from their first run (hands.md names them).
    "hands.parquet": ("c07a69c", AMD, "2026-12-07"),
    # benchmarks/grasp_model.py's rows, recorded at run time (grasp_model.md names them).
    "grasp_model.parquet": ("bd11be7", AMD, "2026-12-07"),
}
# File -> planner -> (build, cpu, date): rows a page dates more closely than the file as a whole.
BY_PLANNER = {
    # README.md: "the 1,500 slideplan runs again with --preset paper (build of a37807a, AMD EPYC, ..., 2026-12-02)".
    "fig11_paper.parquet": {"slideplan": ("a37807a", AMD, "2026-12-02")},
}


def backfilled(table: pa.Table, name: str) -> pa.Table:
    """The table with the provenance columns last: rows that recorded their build at run time keep theirs,
    every other row gets the values ``FILES`` and ``BY_PLANNER`` give for ``name``.

    Args:
        table: the rows of one file.
        name: the file's key in ``FILES``.
    """
    names = [field.name for field in PROVENANCE_FIELDS]
    existing = {column: table[column].to_pylist() if column in table.column_names else [None] * table.num_rows
                for column in names}
    planners = table["planner"].to_pylist() if "planner" in table.column_names else [None] * table.num_rows
    values = {column: [] for column in names}
    for row, planner in enumerate(planners):
        if existing["build_recorded_at_run"][row]:
            filled = {column: existing[column][row] for column in names}
        else:
            build, cpu, date = BY_PLANNER.get(name, {}).get(planner, FILES[name])
            filled = {"build": build, "version": UNRECORDED, "cpu": cpu, "date": date, "build_recorded_at_run": False}
        for column in names:
            values[column].append(filled[column])
    table = table.drop_columns([column for column in names if column in table.column_names])
    for field in PROVENANCE_FIELDS:
        table = table.append_column(field, pa.array(values[field.name], field.type))
    return table


def main(argv: list[str]) -> int:
    """Backfill the files named in ``argv`` (keys of ``FILES``; default: all); return the exit code."""
    unknown = [name for name in argv if name not in FILES]
    if unknown:
        print(f"backfill_provenance: error: no provenance known for {', '.join(unknown)}", file=sys.stderr)
        return 2
    for name in argv or FILES:
        path = HERE / name
        pq.write_table(backfilled(pq.read_table(path), name), path)
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
