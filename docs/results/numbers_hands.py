"""Generated blocks of docs/results/hands.md from ``hands.parquet`` (benchmarks/hands_sweep.py's rows, one per
run of a bundled hand): the table per scene, the runs that did not succeed, and the build, machine and date."""

from __future__ import annotations

import pandas as pd
from numbers_common import HERE, build_of

ROWS = "hands.parquet"


def table(runs: pd.DataFrame) -> str:
    lines = ["| scene | runs | solved | slide within tolerance | lifted | success | median position error | median yaw error |",
             "|---|---|---|---|---|---|---|---|"]
    for scene, group in runs.groupby("scene", sort=False):
        executed = group[group["solved"]]
        lines.append(f"| {scene} | {len(group)} | {len(executed)} | {int(executed['slid'].sum())} | "
                     f"{int(executed['lifted'].sum())} | {int(executed['success'].sum())} | "
                     f"{executed['position_error_mm'].median():.1f} mm | {executed['yaw_error_deg'].median():.1f} deg |")
    return "\n".join(lines)


def failures(runs: pd.DataFrame) -> str:
    failed = runs[runs["solved"] & ~runs["success"].astype(bool)]
    unsolved = runs[~runs["solved"]]
    lines = [f"- {row.scene} {row.object} seed {row.seed}: {row.failure}" for row in failed.itertuples()]
    lines += [f"- {row.scene} {row.object} seed {row.seed}: not solved" for row in unsolved.itertuples()]
    return "\n".join(lines) if lines else "(none)"


def values() -> dict[str, str]:
    runs = pd.read_parquet(HERE / ROWS)
    return {"hands-table": table(runs), "hands-failures": failures(runs), "build-hands": build_of(ROWS),
            "hands-machine": ", ".join(sorted(set(runs["cpu"].astype(str)))),
            "hands-date": ", ".join(sorted(set(runs["date"].astype(str).str[:10])))}
