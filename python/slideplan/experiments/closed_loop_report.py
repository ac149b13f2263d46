"""The closed loop judged by the world, from committed rows: true success per set, setting and
mode with 95% Wilson intervals, a paired exact McNemar test of closed against open loop per setting, and
the failure causes. docs/results/make_tables.py writes :func:`report` into docs/results/closed_loop.md.

The rows are :func:`slideplan.experiments.closed_loop.closed_loop_runs`'s, one per run; ``success`` is
the world's verdict (:mod:`slideplan.checks.verdict`), the same for both modes.
"""

from __future__ import annotations

import json

import pandas as pd

from ..sim.conditions import SETTINGS
from .stats import mcnemar_exact, wilson_interval

# eval: the former held-out set, spent, worked on as dev; eval2: held out; clutter: among obstacles, nominal only.
SETS = ("dev", "eval", "eval2", "clutter")
STAGES = ("plan", "slide", "release", "grasp", "hold", "simulation")  # ClosedLoopRun.failed_stage
STOPS = ("no_progress", "replan_cap", "time_cap", "slip")  # ClosedLoopRun.slide_stop, "+"-joined


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def _settings(runs: pd.DataFrame) -> list[str]:
    return [setting for setting in SETTINGS if setting in set(runs["setting"])]


def _ok(runs: pd.DataFrame) -> pd.Series:
    return runs["success"].fillna(False).astype(bool)


def mcnemar(runs: pd.DataFrame) -> tuple[int, int, float]:
    """The paired test of closed against open loop on the same tasks and draws: ``(closed only, open only,
    p)``, p the exact two-sided binomial test of the discordant pairs (McNemar's exact test; 1 with none).

    Args:
        runs: one setting's rows, both modes.
    """
    paired = runs.assign(ok=_ok(runs)).pivot_table(index="task_id", columns="mode", values="ok", aggfunc="first").dropna()
    return mcnemar_exact(paired["closed"].astype(bool), paired["open"].astype(bool))


def success_table(runs: pd.DataFrame) -> str:
    """Per setting and mode: runs, true successes, 95% Wilson interval."""
    rows = []
    for setting in _settings(runs):
        for mode in ("open", "closed"):
            group = runs[(runs["setting"] == setting) & (runs["mode"] == mode)]
            if not len(group):
                continue
            successes = int(_ok(group).sum())
            low, high = wilson_interval(successes, len(group))
            rows.append([setting, mode, str(len(group)), f"{successes} ({100 * successes / len(group):.1f}%)",
                         f"{100 * low:.1f}-{100 * high:.1f}%"])
    return _table(["setting", "mode", "runs", "true success", "95% Wilson interval"], rows)


def mcnemar_table(runs: pd.DataFrame) -> str:
    """Per setting: the discordant pairs and McNemar's exact p."""
    rows = []
    for setting in _settings(runs):
        better, worse, p = mcnemar(runs[runs["setting"] == setting])
        rows.append([setting, str(better), str(worse), f"{p:.3g}"])
    return _table(["setting", "closed only succeeded", "open only succeeded", "exact McNemar p (two-sided)"], rows)


def failure_table(runs: pd.DataFrame) -> str:
    """Per setting and mode: failed runs by the stage that failed, and runs whose sliding a bound ended."""
    rows = []
    for setting in _settings(runs):
        for mode in ("open", "closed"):
            group = runs[(runs["setting"] == setting) & (runs["mode"] == mode)]
            failed = group[~_ok(group)]
            stops = group["slide_stop"].fillna("")
            met = stops.str.split("+")
            rows.append([setting, mode, *(str(int((failed["failed_stage"] == stage).sum())) for stage in STAGES),
                         *(str(int(met.map(lambda bounds, stop=stop: stop in bounds).sum())) for stop in STOPS)])
    return _table(["setting", "mode", *STAGES, *(f"stopped: {stop}" for stop in STOPS)], rows)


def friction_table(runs: pd.DataFrame) -> str:
    """The hard setting by its draw of the pad's friction against the table's, per mode: runs, true
    successes, 95% Wilson interval, and runs that ended for a slip. Where the pad's friction is below the
    table's, no normal force lets the pad carry the object."""
    hard = runs[runs["setting"] == "hard"]
    above = hard["draws"].map(lambda text: (lambda draws: draws["pad_friction"] > draws["table_friction"])(json.loads(text)))
    rows = []
    for label, side in (("pad > table", True), ("pad <= table", False)):
        for mode in ("open", "closed"):
            group = hard[(above == side) & (hard["mode"] == mode)]
            if not len(group):
                continue
            successes = int(_ok(group).sum())
            low, high = wilson_interval(successes, len(group))
            slips = int(group["slide_stop"].fillna("").str.split("+").map(lambda bounds: "slip" in bounds).sum())
            rows.append([label, mode, str(len(group)), f"{successes} ({100 * successes / len(group):.1f}%)",
                         f"{100 * low:.1f}-{100 * high:.1f}%", str(slips)])
    return _table(["friction", "mode", "runs", "true success", "95% Wilson interval", "ended for a slip"], rows)


def builds(runs: pd.DataFrame) -> str:
    """The builds the rows record, with their row counts."""
    counts = runs["build"].fillna("unrecorded").astype(str).value_counts()
    return ", ".join(f"{build} ({count} runs)" for build, count in counts.items())


def report(sets: dict[str, pd.DataFrame | None]) -> str:
    """The markdown of every set: its builds and the three tables, or that it has not been run yet.

    Args:
        sets: ``{set: rows or None}`` for each of :data:`SETS`, None (or empty) where no rows are committed.
    """
    sections = []
    for name in SETS:
        runs = sets.get(name)
        if runs is None or not len(runs):
            sections.append(f"**`{name}`: not run yet.** No rows are committed for this set, so there are no "
                            "numbers for it here.")
            continue
        sections += [f"**`{name}`**: {runs['task_id'].nunique()} tasks, {len(runs)} runs; build {builds(runs)}.",
                     "True success (the world's verdict):", success_table(runs),
                     "Closed against open loop, paired on the same tasks and draws:", mcnemar_table(runs),
                     "Where the runs failed (stage), and runs whose sliding a bound ended:", failure_table(runs)]
        if (runs["setting"] == "hard").any():
            sections += ["The hard setting by the pad's friction drawn against the table's:", friction_table(runs)]
    return "\n\n".join(sections)
