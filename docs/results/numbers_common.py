"""What the generated blocks share: loading the committed rows once, the build each file's rows record,
and number formats.

A Parquet file's build comes from its rows' ``build`` column: recorded at run time, or, for rows written
before rows recorded their build, what the pages said when the rows were committed
(``backfill_provenance.py``, ``build_recorded_at_run`` False).
"""

from __future__ import annotations

from collections import Counter
from functools import cache
from pathlib import Path

import pandas as pd

HERE = Path(__file__).resolve().parent

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
    """The build (or builds, with their row counts) that made ``docs/results/<name>``'s rows, from their
    ``build`` column, so that a rerun changes the text."""
    builds = pd.read_parquet(HERE / name, columns=["build"])["build"].astype(str)
    counts = Counter(builds.map(lambda build: "+".join([build.split("+")[0][:7], *build.split("+")[1:]])))
    return ", ".join(f"{build}" + (f" ({number:,} rows)" if len(counts) > 1 else "")
                     for build, number in sorted(counts.items(), key=lambda item: (-item[1], item[0])))


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
