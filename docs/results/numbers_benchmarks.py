"""Generated blocks from the benchmarks' committed rows (docs/benchmarks/*.parquet): the README's sentence
on the command's wall time (``readme-cli-wall``, from benchmarks/cli_bench.py's ``cli.parquet``)."""

from __future__ import annotations

import pandas as pd
from numbers_common import HERE

CLI_ROWS = HERE.parent / "benchmarks" / "cli.parquet"


def values() -> dict[str, str]:
    return {"readme-cli-wall": cli_sentence(pd.read_parquet(CLI_ROWS)) if CLI_ROWS.exists()
            else "not measured yet (benchmarks/cli_bench.py writes docs/benchmarks/cli.parquet)"}


def cli_sentence(rows: pd.DataFrame) -> str:
    """The first plan's median wall time, cold and warm, pinned and on a busy machine, with the conditions."""
    median = rows.groupby(["part", "cache"])["wall_s"].median()
    pinned = rows[rows["part"] == "first plan, pinned"]
    first = rows.iloc[0]
    return (f"{median[('first plan, pinned', 'cold')]:.3f} s wall with an empty grasp-map cache and "
            f"{median[('first plan, pinned', 'warm')]:.3f} s with a stored one: medians of "
            f"{int((pinned['cache'] == 'cold').sum())} new processes pinned to one core of an {first['cpu']} "
            f"({int(first['cores'])} cores), {str(first['date'])[:10]}, build {first['build']} (docs/benchmarks/cli.md). "
            f"With every core busy (one spinning process on each), the same command took "
            f"{median[('first plan, busy', 'cold')]:.3f} s cold and {median[('first plan, busy', 'warm')]:.3f} s warm")
