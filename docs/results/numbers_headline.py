"""The README's headline table (``readme-headline``): the closed loop's true success on the held-out set
(``eval2`` once its rows are committed, else the former held-out set ``eval``) in nominal physics and the
hard setting, both modes; planning on the paper's Fig. 10 set; and how fast the physics runs."""

from __future__ import annotations

from numbers_common import HERE, percent, rows
from numbers_planning import _solved
from slideplan.experiments import planning_runs
from slideplan.experiments.stats import wilson_interval

HELD_OUT = (("eval2", "the held-out objects (`eval2`)"), ("eval", "the former held-out letters (`eval`)"))


def _rate(runs, setting: str, mode: str) -> str:
    group = runs[(runs["setting"] == setting) & (runs["mode"] == mode)]
    ok = int(group["success"].fillna(False).astype(bool).sum())
    low, high = wilson_interval(ok, len(group))
    return f"{percent(ok, len(group))} ({ok}/{len(group)}; 95% CI {100 * low:.0f}-{100 * high:.0f}%)"


def values() -> dict[str, str]:
    name, label = next((name, label) for name, label in HELD_OUT if (HERE / f"closed_loop_{name}.parquet").exists())
    runs = rows(f"closed_loop_{name}.parquet", "runs")
    fig10 = planning_runs(rows("fig10.parquet"))
    full = fig10[fig10["scale"] == 1.0]
    solved = full[_solved(full)]
    speed = runs["sim_time_s"] / runs["wall_time_s"]
    table = [
        "| measure | closed loop | open loop |", "|---|---|---|",
        *(f"| true success on {label}, {setting} physics | {_rate(runs, setting, 'closed')} | {_rate(runs, setting, 'open')} |"
          for setting in ("nominal", "hard")),
        f"| physics speed, simulated s per wall s (median of those runs) | {speed[runs['mode'] == 'closed'].median():.1f}x "
        f"| {speed[runs['mode'] == 'open'].median():.1f}x |",
        f"| planning, the paper's Fig. 10 set at full size ({len(full)} tasks, 60 s budget) | "
        f"{percent(len(solved), len(full))} solved, median {solved['planning_time_s'].median():.3f} s | |",
    ]
    return {"readme-headline": "\n".join(table)}
