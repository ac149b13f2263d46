"""What the generated blocks share: loading the committed rows once, the build each file's rows record,
and number formats.

A Parquet file's build comes from its rows' ``build`` column for rows that recorded it at run time
(``build_recorded_at_run`` True); for rows written before rows recorded their build (no column, or
backfilled from the pages), from :data:`BUILDS_NAMED_BY_THE_PAGES`, what the pages said when the rows were
committed.
"""

from __future__ import annotations

from collections import Counter
from functools import cache
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq

HERE = Path(__file__).resolve().parent

BUILDS_NAMED_BY_THE_PAGES = {
    "fig10.parquet": "06e0096",
    "fig10_paper.parquet": "06e0096",
    "fig11.parquet": "bc015d9, 388daad, 3460cc6 and a37807a",
    "fig11_paper.parquet": "a37807a (slideplan rows; the baselines' rows as in fig11.parquet)",
    "fig12.parquet": "a37807a",
    "fig12_paper.parquet": "a37807a",
    "execution.parquet": "d3e2f75",
    "execution_paper.parquet": "03f2c70",
    "closed_loop.parquet": "49efcf6",
    "closed_loop_e0328a8.parquet": "e0328a8",
    "closed_loop_tasks_e0328a8.parquet": "e0328a8",
    "partial/closed_loop.parquet": "b74bcec",
    "partial/closed_loop_e0328a8.parquet": "e0328a8",
}
"""Builds as the pages named them before the rows recorded their own (used only where a file has no
``build`` column)."""


@cache
def rows(name: str, loader: str = "planning") -> pd.DataFrame:
    """The committed rows of ``docs/results/<name>`` through the package's loader (``planning``:
    :func:`slideplan.experiments.load_results`; ``execution``, ``closed_loop``: their loaders; ``runs``:
    a closed-loop file already one row per run)."""
    path = HERE / name
    if loader == "planning":
        from slideplan.experiments import load_results

        return load_results(path)
    if loader == "execution":
        from slideplan.experiments.execution import load_execution

        return load_execution(path)
    if loader == "closed_loop":
        from slideplan.experiments.closed_loop import closed_loop_runs, load_closed_loop

        return closed_loop_runs(load_closed_loop(path))
    if loader == "runs":
        return pd.read_parquet(path)
    raise ValueError(f"unknown loader {loader!r}")


def build_of(name: str) -> str:
    """The build (or builds, with their row counts) that made ``docs/results/<name>``'s rows: the rows'
    ``build`` where it was recorded at run time, the page's word (:data:`BUILDS_NAMED_BY_THE_PAGES`) for rows
    without one or backfilled from the pages (``build_recorded_at_run`` False), so that a backfill changes
    no text and a rerun does."""
    path = HERE / name
    fallback = BUILDS_NAMED_BY_THE_PAGES[name]
    columns = pq.read_schema(path).names
    if "build" not in columns:
        return fallback
    wanted = ["build"] + (["build_recorded_at_run"] if "build_recorded_at_run" in columns else [])
    table = pd.read_parquet(path, columns=wanted)
    at_run = table["build_recorded_at_run"].fillna(False).astype(bool) if len(wanted) > 1 else table["build"].notna()
    recorded = table.loc[at_run, "build"].astype(str)
    if recorded.empty:
        return fallback
    short = recorded.map(lambda build: "+".join([build.split("+")[0][:7], *build.split("+")[1:]]))
    counts = Counter(short)
    text = ", ".join(f"{build}" + (f" ({number:,} rows)" if len(counts) > 1 or len(recorded) < len(table) else "")
                     for build, number in sorted(counts.items(), key=lambda item: (-item[1], item[0])))
    older = len(table) - len(recorded)
    return text if not older else f"{text} and, for {older:,} older rows, {fallback}"


def seconds(value: float, se: float | None = None) -> str:
    """A planning time (and its standard error) to a sensible precision: ``0.011 s``, ``0.13 ± 0.01 s``,
    ``27.5 ± 1.7 s``; a standard error that rounds to zero is left out."""
    digits = 3 if value < 0.1 else 2 if value < 1 else 1
    text = f"{value:.{digits}f}"
    if se is not None and not pd.isna(se) and round(se, digits) > 0:
        text += f" ± {se:.{digits}f}"
    return text + " s"


def percent(part: float, whole: float, digits: int = 1) -> str:
    """``part / whole`` as a percentage, e.g. ``96.5%``."""
    return f"{100 * part / whole:.{digits}f}%"


def span(values, fmt) -> str:
    """``a-b`` of formatted values (one value if they format alike)."""
    low, high = fmt(min(values)), fmt(max(values))
    return low if low == high else f"{low}-{high}"


def count(value: int) -> str:
    """An integer with thousands separators."""
    return f"{int(value):,}"
