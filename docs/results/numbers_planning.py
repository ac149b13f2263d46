"""Generated blocks of the planning experiments (Figs. 10-12) for README.md and docs/results/README.md.

Each function returns ``{block name: text}``; :func:`values` gathers them. Unsolved runs count at their
time limit in means (as in tables.md and the figures); rows of tasks that raised are left out of them.
"""

from __future__ import annotations

import math

import pandas as pd

from numbers_common import build_of, count, percent, rows, seconds, span
from slideplan.experiments import planning_runs, planning_time_summary, success_rate_curve, wilson_interval

FIGURE_FILES = ("fig10.parquet", "fig10_paper.parquet", "fig11.parquet", "fig11_paper.parquet",
                "fig12.parquet", "fig12_paper.parquet")
SCALE_NAMES = {1.0: "full scale", 0.5: "half scale"}


def _solved(frame: pd.DataFrame) -> pd.Series:
    return frame["solved"].fillna(False).astype(bool)


def _listing(summary: pd.DataFrame, category: str) -> str:
    """``square 250/250 (0.011 s), ...``: solved/runs and mean ± s.e. per category, short of runs in bold."""
    items = []
    for row in summary.itertuples():
        outcome = f"{int(row.solved)}/{int(row.runs)}"
        items.append(f"{getattr(row, category)} {outcome if row.solved == row.runs else f'**{outcome}**'} "
                     f"({seconds(row.mean_s, row.se_s)})")
    return ", ".join(items)


def _by_scale(runs: pd.DataFrame, category: str) -> str:
    parts = []
    for scale in sorted(runs["scale"].unique(), reverse=True):
        summary = planning_time_summary(runs[runs["scale"] == scale], [category])
        parts.append(f"{SCALE_NAMES.get(scale, f'scale {scale:g}')}: {_listing(summary, category)}")
    return "; ".join(parts)


def verification() -> dict[str, str]:
    # The baselines' rows are in both Fig. 11 files (the same runs): each run counted once.
    frame = pd.concat([rows(name) for name in FIGURE_FILES], ignore_index=True).drop_duplicates("task_id")
    solved = int(_solved(frame).sum())
    verified = int((_solved(frame) & frame["verified"].fillna(False).astype(bool)).sum())
    invalid = int((frame["status"] == "invalid").sum())
    passed = f"all {count(solved)} solved runs of these files pass" if verified == solved else \
        f"{count(verified)} of {count(solved)} solved runs of these files pass"
    rejected = "none is" if invalid == 0 else f"{count(invalid)} are"
    return {"verified-runs": f"{passed} (a run the verifier rejects is recorded as `invalid`, not solved: {rejected})"}


def fig10() -> dict[str, str]:
    everything = rows("fig10.parquet")
    default = planning_runs(everything)
    paper = planning_runs(rows("fig10_paper.parquet"))
    full, half = default[default["scale"] == 1.0], default[default["scale"] == 0.5]
    values = {}
    objects_full = planning_time_summary(full, ["object"])
    values["fig10-default-full"] = (
        f"{count(_solved(full).sum())}/{count(len(full))} full-scale runs solved, the slowest in "
        f"{full.loc[_solved(full), 'planning_time_s'].max():.3f} s, mean per object "
        f"{span(objects_full['mean_s'], lambda v: f'{v:.3f}')} s")
    values["fig10-default-half"] = "half scale: " + _listing(planning_time_summary(half, ["object"]), "object")
    refused = everything[everything["error"].notna()]
    values["fig10-default-refused"] = ", ".join(
        f"{count(len(group))} runs of the {scale:g}-scale {name}" for (name, scale), group in refused.groupby(["object", "scale"]))
    values["fig10-default-tables"] = _by_scale(default, "scene")
    tables_full = planning_time_summary(full, ["scene"]).set_index("scene")
    triangle, square = tables_full.loc["triangle"], tables_full.loc["square"]
    # Apart: the two means' intervals of twice their standard errors do not overlap.
    apart = abs(triangle["mean_s"] - square["mean_s"]) > 2 * (triangle["se_s"] + square["se_s"])
    values["fig10-default-triangle-ratio"] = (
        f"{triangle['mean_s'] / square['mean_s']:.1f}x the square, "
        + ("its interval apart" if apart else "within twice their standard errors"))
    half_crescent = half[half["object"] == "crescent"]
    unsolved = half_crescent[~_solved(half_crescent)].groupby("scene").size()
    poses = half_crescent["pose_index"].nunique()
    values["fig10-default-half-crescent-timeouts"] = (
        " and ".join(f"{unsolved.get(scene, 0)}" for scene in ("long", "triangle")) + f" of the {poses} half crescents")
    values["fig10-paper-tables"] = _by_scale(paper, "scene")
    per_object = paper.groupby("object").apply(lambda group: _solved(group).mean(), include_groups=False)
    values["fig10-paper-objects"] = f"per object {span(100 * per_object, lambda v: f'{v:.0f}')}% solved"
    triangle = paper[paper["scene"] == "triangle"]
    values["fig10-paper-triangle-unsolved"] = f"{percent((~_solved(triangle)).sum(), len(triangle), 0)} of its {count(len(triangle))} runs"
    default_triangle = full[full["scene"] == "triangle"]
    values["fig10-default-triangle-full"] = f"{_solved(default_triangle).sum()}/{len(default_triangle)} full scale"
    paper_all = rows("fig10_paper.parquet")
    values["fig10-paper-outcome"] = (
        f"{count(_solved(paper_all).sum())} of {count(len(paper_all))} solved, "
        f"{'all' if (_solved(paper_all) <= paper_all['verified'].fillna(False).astype(bool)).all() else 'not all'} verified, "
        f"{count((paper_all['status'] == 'timeout').sum())} timeouts at {paper_all['time_limit_s'].max():g} s, "
        f"{count(paper_all['error'].notna().sum())} errors")
    for preset, frame in (("default", default), ("paper", paper)):
        square = frame[(frame["scene"] == "square") & (frame["scale"] == 1.0)]
        tri = frame[(frame["scene"] == "triangle") & (frame["scale"] == 1.0)]
        values[f"fig10-{preset}-triangle-against-square"] = (
            f"full scale {_solved(tri).sum()}/{len(tri)} solved, mean "
            f"{seconds(*planning_time_summary(tri, ['scene'])[['mean_s', 'se_s']].iloc[0])} against the square table's "
            f"{_solved(square).sum()}/{len(square)}, {seconds(*planning_time_summary(square, ['scene'])[['mean_s', 'se_s']].iloc[0])}")
    return values


def _fig11_slideplan(frame: pd.DataFrame, dz: float) -> tuple[pd.DataFrame, pd.DataFrame]:
    runs = planning_runs(frame)
    setting = runs[(runs["planner"] == "slideplan") & (runs["reconfiguration_range_m"] == dz)]
    return setting, setting[_solved(setting)]


def fig11() -> dict[str, str]:
    default, paper = rows("fig11.parquet"), rows("fig11_paper.parquet")
    values = {}
    for dz, name in ((0.02, "dz2"), (0.005, "dz05"), (0.0, "dz0")):
        setting, solved = _fig11_slideplan(default, dz)
        within = int((solved["planning_time_s"] <= 1.0).sum())
        low, high = wilson_interval(within, len(setting))
        values[f"fig11-{name}"] = (
            f"**{percent(within, len(setting), 0)} within 1 s** ({within}/{len(setting)}, 95% Wilson "
            f"[{100 * low:.1f}, {100 * high:.1f}]); median {solved['planning_time_s'].median():.3f} s, "
            f"slowest {solved['planning_time_s'].max():.3f} s")
    medians, slowest, within = [], [], []
    for dz in (0.0, 0.005, 0.02):
        setting, solved = _fig11_slideplan(paper, dz)
        medians.append(solved["planning_time_s"].median())
        slowest.append(solved["planning_time_s"].max())
        within.append(f"{int((solved['planning_time_s'] <= 1.0).sum())}/{len(setting)}")
    default_median = _fig11_slideplan(default, 0.02)[1]["planning_time_s"].median()
    values["fig11-paper"] = (
        f"each dz*: {' / '.join(sorted(set(within)))} within 1 s; medians {span(medians, lambda v: f'{v:.3f}')} s, "
        f"slowest {max(slowest):.2f} s ({min(medians) / default_median:.0f}x the default's median)")
    runs = planning_runs(default)
    curves = {}
    times = [0.01, 0.02, 0.03, 0.05, 0.1, 0.2, 0.3, 0.5, 1, 2, 5, 10, 20, 60]
    for planner in ("cbirrt", "cbirrt2"):
        curves[planner] = success_rate_curve(runs[runs["planner"] == planner], times).set_index("time_s")
    last = curves["cbirrt"].iloc[-1]
    last2 = curves["cbirrt2"].iloc[-1]
    values["fig11-baselines"] = (
        f"as published, {times[-1]} s: CBiRRT {100 * last.rate:.1f}% [{100 * last.low:.1f}, {100 * last.high:.1f}] "
        f"({int(last.successes)}/{int(last.runs)}), CBiRRT2 {100 * last2.rate:.1f}% [{100 * last2.low:.1f}, {100 * last2.high:.1f}] "
        f"({int(last2.successes)}/{int(last2.runs)}), against 100%")
    one, two = curves["cbirrt"]["rate"], curves["cbirrt2"]["rate"]
    cbirrt = runs[(runs["planner"] == "cbirrt") & _solved(runs)]
    ahead = [time for time in times if two[time] > one[time]]
    crossing = ahead[0] if ahead else None
    text = (f"CBiRRT solves all it will by {cbirrt['planning_time_s'].max():.2f} s ({100 * one[0.01]:.1f}% within 10 ms, "
            f"{100 * one[times[-1]]:.1f}% at {times[-1]} s); CBiRRT2 lies under it at 30 ms ({100 * two[0.03]:.1f}% against "
            f"{100 * one[0.03]:.1f}%)")
    if crossing is not None:
        text += (f", above it from {crossing:g} s on ({100 * two[crossing]:.1f}% against {100 * one[crossing]:.1f}%) and "
                 f"goes on gaining to {100 * two[times[-1]]:.1f}% at {times[-1]} s")
    values["fig11-crossover"] = text
    values["fig11-crossover-verdict"] = "reproduced" if crossing is not None and two[0.01] < one[0.01] else "not reproduced"
    return values


def fig12() -> dict[str, str]:
    values = {}
    for preset, name in (("default", "fig12.parquet"), ("paper", "fig12_paper.parquet")):
        runs = planning_runs(rows(name))
        summary = planning_time_summary(runs, ["n_star"]).set_index("n_star")
        limit = runs["time_limit_s"].max()
        items = []
        for n_star, row in summary.iterrows():
            item = f"N* = {n_star:g}: {int(row.solved)}/{int(row.runs)} solved, mean {seconds(row.mean_s, row.se_s)}"
            if row.solved < row.runs:
                solved = runs[(runs["n_star"] == n_star) & _solved(runs)]["planning_time_s"]
                item += f" (its {int(row.runs - row.solved)} unsolved counted at {limit:g} s; median of the solved {solved.median():.3f} s)"
            items.append(item)
        values[f"fig12-{preset}"] = "; ".join(items)
        smallest = summary.iloc[0]
        small = smallest.solved < summary.loc[100.0].solved and smallest.mean_s > summary.loc[100.0].mean_s
        at_100 = summary.loc[100.0]
        larger = summary[summary.index > 100.0]
        large = ", ".join(f"N* = {n:g} {1000 * row.mean_s:.1f} ms" for n, row in larger.iterrows())
        # The paper: a larger N* is slower. Only a difference beyond twice its standard error counts as one.
        slower = all(row.mean_s - at_100.mean_s > 2 * math.hypot(row.se_s, at_100.se_s) for _, row in larger.iterrows())
        verdict = f"too small an N* is too conservative: {'reproduced' if small else 'not reproduced'}; best at 100: "
        if slower:
            verdict += f"reproduced (N* = 100 {1000 * at_100.mean_s:.1f} ms, {large})"
        else:
            verdict += (f"**not reproduced**, a larger N* costs no more, within twice the standard error ({large}, "
                        f"against {1000 * at_100.mean_s:.1f} ms at N* = 100)")
        values[f"fig12-{preset}-verdict"] = verdict
    return values


def readme() -> dict[str, str]:
    """The top-level README's summary of Section V."""
    default = rows("fig11.parquet")
    setting, solved = _fig11_slideplan(default, 0.0)
    paper = planning_runs(rows("fig10_paper.parquet"))
    triangle = paper[paper["scene"] == "triangle"]
    paper_setting, paper_solved = _fig11_slideplan(rows("fig11_paper.parquet"), 0.0)
    return {
        "readme-dz0": (f"{percent(len(solved), len(setting), 0)} here ({len(solved)}/{len(setting)} within "
                       f"{setting['time_limit_s'].max():g} s, median {solved['planning_time_s'].median():.3f} s; "
                       f"`--preset paper`: {len(paper_solved)}/{len(paper_setting)})"),
        "readme-triangle-paper": f"{_solved(triangle).sum()}/{len(triangle)} solved within 60 s",
    }


def values() -> dict[str, str]:
    """Every block of the planning experiments."""
    out = {**verification(), **fig10(), **fig11(), **fig12(), **readme()}
    for name in FIGURE_FILES:
        out[f"build-{name.removesuffix('.parquet')}"] = build_of(name)
    return out
