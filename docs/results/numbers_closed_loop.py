"""Generated blocks of the closed-loop evaluation (docs/results/closed_loop.md): the world's verdict
per task set, setting and mode, from ``closed_loop_dev.parquet`` and ``closed_loop_eval.parquet`` (one row
per run, :func:`slideplan.experiments.closed_loop.closed_loop_runs`). A set without its file is reported as
not run yet."""

from __future__ import annotations

import json

import numpy as np
from numbers_common import HERE, rows
from slideplan.experiments.closed_loop_report import SETS, mcnemar, report

HARD_TARGET = 0.90  # the closed loop's true success in the hard setting on eval...
HARD_P = 0.01  # ...above the open loop's with McNemar p below this
LARGE_CAMERA_ERROR_M = 0.01  # a hard draw's camera offset counted as large

SET_FILES = {name: f"closed_loop_{name}.parquet" for name in SETS}
LETTERS_RERUN = "closed_loop_eval_rerun.parquet"  # the former eval set's tasks again, on a later build
DEV_RERUN = "closed_loop_dev_rerun.parquet"  # the dev set's first 5 poses per cell again, on a later build


def values() -> dict[str, str]:
    """The ``cl53-report`` block, and the README's sentence on the eval set (``readme-cl53-eval``)."""
    sets = {name: rows(file, "runs") if (HERE / file).exists() else None for name, file in SET_FILES.items()}
    eval_runs = sets["eval"]
    ran = eval_runs is not None and len(eval_runs)
    return {"cl53-report": report(sets), "readme-cl53-eval": eval_sentence(eval_runs),
            "cl53-eval-targets": targets_sentence(eval_runs) if ran else "not run yet",
            "cl53-eval-hard": hard_failures(eval_runs) if ran else "not run yet",
            "cl53-eval-others": other_failures(eval_runs) if ran else "not run yet",
            "cl53-eval-speed": speed(eval_runs) if ran else "not run yet",
            "cl-letters-rerun": rerun_table(eval_runs, rows(LETTERS_RERUN, "runs")) if ran and (HERE / LETTERS_RERUN).exists()
            else "not run yet",
            "cl-dev-rerun": dev_rerun(sets["dev"], rows(DEV_RERUN, "runs")) if (HERE / DEV_RERUN).exists() else "not run yet",
            "cl-camera-calibration": calibration_table(rows(DEV_RERUN, "runs")) if (HERE / DEV_RERUN).exists()
            else "not run yet",
            "cl-eval2-targets": eval2_targets(sets["eval2"]) if sets["eval2"] is not None and len(sets["eval2"])
            else "not run yet: no numbers exist for `eval2`",
            "cl-eval2-objects": by_object(sets["eval2"]) if sets["eval2"] is not None and len(sets["eval2"])
            else "not run yet",
            "cl-eval2-calibration": calibration_table(sets["eval2"]) if sets["eval2"] is not None and len(sets["eval2"])
            else "not run yet"}


EVAL2_TARGETS = {"nominal": 0.99, "stress": 0.98, "random": 0.98}  # both modes
EVAL2_HARD, EVAL2_HARD_GRIPPY = 0.85, 0.95  # the hard setting's closed loop: overall, and where the pad grips more than the table
WORSE_P = 0.05  # the closed loop significantly worse than the open loop


def eval2_targets(runs) -> str:
    """The held-out ``eval2`` run against the targets fixed before it: each met or missed, with its numbers
    and 95% Wilson interval."""
    from slideplan.experiments.stats import wilson_interval

    def rate(group) -> str:
        ok, n, pct = _rate(group)
        low, high = wilson_interval(ok, n)
        return f"{pct:.1f}% ({ok} of {n}; {100 * low:.1f}-{100 * high:.1f}%)"

    def verdict(group, target) -> str:
        return "met" if _rate(group)[2] >= 100 * target else "missed"

    lines = []
    for setting, target in EVAL2_TARGETS.items():
        for mode in ("open", "closed"):
            group = runs[(runs["setting"] == setting) & (runs["mode"] == mode)]
            lines.append(f"- {setting}, {mode} loop, at least {100 * target:.0f}%: {rate(group)}, {verdict(group, target)}")
    hard = runs[(runs["setting"] == "hard") & (runs["mode"] == "closed")]
    grippy = hard[hard["draws"].map(lambda text: (lambda d: d["pad_friction"] > d["table_friction"])(json.loads(text)))]
    lines.append(f"- hard, closed loop, at least {100 * EVAL2_HARD:.0f}%: {rate(hard)}, {verdict(hard, EVAL2_HARD)}")
    lines.append(f"- hard, closed loop, the pad's friction above the table's, at least {100 * EVAL2_HARD_GRIPPY:.0f}%: "
                 f"{rate(grippy)}, {verdict(grippy, EVAL2_HARD_GRIPPY)}")
    worse = []
    for setting in dict.fromkeys(runs["setting"]):
        better, fewer, p = mcnemar(runs[runs["setting"] == setting])
        if fewer > better and p < WORSE_P:
            worse.append(f"{setting} ({fewer} tasks against {better}, p = {p:.2g})")
    lines.append(f"- the closed loop nowhere significantly worse than the open loop (McNemar p < {WORSE_P:g}): "
                 + ("met" if not worse else "missed: " + ", ".join(worse)))
    return "\n".join(lines)


def by_object(runs) -> str:
    """True success per object, setting and mode (each cell the object's runs on every table)."""
    ok = runs.assign(ok=runs["success"].fillna(False).astype(bool))
    settings = list(dict.fromkeys(runs["setting"]))
    lines = ["| object | " + " | ".join(f"{setting} open | {setting} closed" for setting in settings) + " |",
             "|---|" + "---|" * (2 * len(settings))]
    for name, group in ok.groupby("object"):
        cells = []
        for setting in settings:
            for mode in ("open", "closed"):
                cell = group[(group["setting"] == setting) & (group["mode"] == mode)]
                cells.append(f"{int(cell['ok'].sum())}/{len(cell)}")
        lines.append(f"| {name.rsplit('/', 1)[-1]} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def rerun_table(before, after) -> str:
    """The same tasks, settings and modes on two builds: true success on each, and the runs only one of them
    lifted (paired on object, table, pose, setting and mode: a task's id hashes the planner's parameters, which
    the later build has more of; McNemar's exact p)."""
    from slideplan.experiments.closed_loop_report import builds
    from slideplan.experiments.stats import mcnemar_exact

    key = ["object", "scene", "pose_index", "setting", "mode"]
    before = before.merge(after[key[:3]].drop_duplicates(), on=key[:3])  # a rerun of part of the set: that part
    paired = before[key + ["success", "draws"]].merge(after[key + ["success"]], on=key, suffixes=("_before", "_after"))
    assert len(paired) == len(before) == len(after), "the rerun's runs are not the earlier runs' tasks"
    header = (f"| setting | mode | build {builds(before)} | build {builds(after)} | only before | only after | p |")
    lines = [header, "|---|---|---|---|---|---|---|"]
    for (setting, mode), group in paired.groupby(["setting", "mode"], sort=False):
        old, new = group["success_before"].fillna(False).astype(bool), group["success_after"].fillna(False).astype(bool)
        only_old, only_new, p = mcnemar_exact(old, new)
        lines.append(f"| {setting} | {mode} | {100 * old.mean():.1f}% | {100 * new.mean():.1f}% | {only_old} | {only_new} | "
                     f"{p:.2g} |")
    grippy = paired["draws"].map(lambda text: (lambda draws: draws["pad_friction"] > draws["table_friction"])(json.loads(text)))
    for mode, group in paired[(paired["setting"] == "hard") & grippy].groupby("mode", sort=False):
        old, new = group["success_before"].fillna(False).astype(bool), group["success_after"].fillna(False).astype(bool)
        lines.append(f"| hard, pad > table | {mode} | {100 * old.mean():.1f}% | {100 * new.mean():.1f}% | "
                     f"{int((old & ~new).sum())} | {int((new & ~old).sum())} | |")
    by_object = paired[paired["setting"] == "nominal"].groupby("object")[["success_before", "success_after"]].mean()
    lines.append("")
    lines.append("Nominal, both modes, by object: " + ", ".join(
        f"{name} {100 * row.success_before:.0f}% then {100 * row.success_after:.0f}%" for name, row in by_object.iterrows()) + ".")
    return "\n".join(lines)


def dev_rerun(before, after) -> str:
    """The dev set's rerun against its runs (:func:`rerun_table`), then where the rerun's runs failed and
    its hard setting by the pad's friction against the table's."""
    from slideplan.experiments.closed_loop_report import failure_table, friction_table

    return "\n\n".join([rerun_table(before, after), "Where the rerun's runs failed (stage), and runs whose sliding a bound ended:",
                        failure_table(after), "The rerun's hard setting by the pad's friction drawn against the table's:",
                        friction_table(after)])


def eval_sentence(runs) -> str:
    """True success on the eval set per setting, closed loop then open loop, or that it has not been run."""
    if runs is None or not len(runs):
        return "the held-out `eval` set has not been run yet, so there are no numbers for it"
    ok = runs.assign(ok=runs["success"].fillna(False).astype(bool)).groupby(["setting", "mode"], sort=False)["ok"].mean()
    settings = list(dict.fromkeys(runs["setting"]))
    built = ", ".join(sorted(runs["build"].astype(str).unique()))
    return (f"on the held-out `eval` set (build {built}), judged by the world, the closed loop succeeded in "
            + ", ".join(f"{100 * ok[(setting, 'closed')]:.1f}% ({setting})" for setting in settings)
            + " of runs, the open loop in " + ", ".join(f"{100 * ok[(setting, 'open')]:.1f}%" for setting in settings))


def _rate(group) -> tuple[int, int, float]:
    ok = int(group["success"].fillna(False).astype(bool).sum())
    return ok, len(group), 100 * ok / max(len(group), 1)


def targets_sentence(runs) -> str:
    """the evaluation's targets on the eval set, each said met or missed with its numbers."""
    hard = runs[runs["setting"] == "hard"]
    closed_ok, closed_n, closed_pct = _rate(hard[hard["mode"] == "closed"])
    _, _, open_pct = _rate(hard[hard["mode"] == "open"])
    better, worse, p = mcnemar(hard)
    parts = [f"in the hard setting the closed loop succeeded in {closed_pct:.1f}% ({closed_ok} of {closed_n}; the "
             f"target is {100 * HARD_TARGET:.0f}%: {'met' if closed_pct >= 100 * HARD_TARGET else 'missed'}), above "
             f"the open loop's {open_pct:.1f}% ({better} tasks against {worse}, McNemar p = {p:.2g}; the target is "
             f"p < {HARD_P:g}: {'met' if p < HARD_P and better > worse else 'missed'})"]
    for setting in ("nominal", "stress", "random"):
        group = runs[runs["setting"] == setting]
        _, _, closed_pct = _rate(group[group["mode"] == "closed"])
        _, _, open_pct = _rate(group[group["mode"] == "open"])
        better, worse, p = mcnemar(group)
        verdict = "no worse: met" if closed_pct >= open_pct else "worse: missed, though not significantly"
        parts.append(f"in {setting} {closed_pct:.1f}% against {open_pct:.1f}% ({better} tasks against {worse}, "
                     f"p = {p:.2g}; {verdict})")
    return "; ".join(parts)


def hard_failures(runs) -> str:
    """What the hard setting's closed-loop runs that failed have in common, counted from the rows' draws."""
    hard = runs[(runs["setting"] == "hard") & (runs["mode"] == "closed")]
    draws = hard["draws"].map(json.loads)
    lost = hard["lost_looks"] > 0.5 * hard["looks"]
    camera = draws.map(lambda d: np.linalg.norm([d["camera_dx_m"], d["camera_dy_m"], d["camera_dz_m"]])) > LARGE_CAMERA_ERROR_M
    grip = draws.map(lambda d: d["pad_friction"] <= d["table_friction"])
    opened = runs[(runs["setting"] == "hard") & (runs["mode"] == "open")]
    opened_grip = opened["draws"].map(json.loads).map(lambda d: d["pad_friction"] <= d["table_friction"])

    def split(mask) -> str:
        ok, n, pct = _rate(hard[mask])
        rest_ok, rest_n, rest_pct = _rate(hard[~mask])
        return f"{ok} of {n} succeeded ({pct:.0f}%), against {rest_ok} of {rest_n} of the others ({rest_pct:.0f}%)"

    open_ok, open_n, _ = _rate(opened[opened_grip])
    return (f"in {int(lost.sum())} of the {len(hard)} closed-loop runs the camera lost the object in most looks: "
            f"{split(lost)}. {int(camera.sum())} drew a camera mounting error over {1000 * LARGE_CAMERA_ERROR_M:.0f} mm: "
            f"{split(camera)}. {int(grip.sum())} drew a pad friction no higher than the table's: {split(grip)} (the "
            f"open loop: {open_ok} of {open_n})")


def other_failures(runs) -> str:
    """Which objects the failures of nominal, stress and random fall on, both modes together."""
    easier = runs[runs["setting"] != "hard"]
    failed = easier[~easier["success"].fillna(False).astype(bool)]
    counts = failed["object"].value_counts()
    return (f"{len(failed)} of the {len(easier)} runs failed, " + ", ".join(
        f"{count} on the {name}" for name, count in counts.items()) + " (each letter has as many runs)")


def speed(runs) -> str:
    """Simulated seconds per wall second of the runs, per mode: median, p10, p90, and the CPU."""
    factor = runs["sim_time_s"] / runs["wall_time_s"]
    parts = []
    for mode in ("open", "closed"):
        values = factor[runs["mode"] == mode]
        parts.append(f"the {mode} loop's {len(values)} runs {values.median():.1f}x real time (p10 "
                     f"{values.quantile(0.1):.1f}x, p90 {values.quantile(0.9):.1f}x)")
    return " and ".join(parts) + f", on an {runs['cpu'].iloc[0]}"


def calibration_table(runs) -> str:
    """The hard setting's camera mounting error per axis, drawn and left after the run's calibration from the
    robot (``camera_estimate``, ``camera_error``), median and 95th percentile of the absolute values over the
    closed-loop runs, and what either moves a point of the table where the object started."""
    from slideplan.experiments.tasks import cached_scene
    from slideplan.sim.closed_loop import default_camera
    from slideplan.sim.conditions import camera_as_mounted

    hard = runs[(runs["setting"] == "hard") & (runs["mode"] == "closed") & runs["camera_error"].notna()]
    drawn = hard["draws"].map(json.loads)
    left = hard["camera_error"].map(json.loads)
    estimate = hard["camera_estimate"].map(json.loads)
    axes = [("dx_m", "x", 1000, "mm"), ("dy_m", "y", 1000, "mm"), ("dz_m", "z", 1000, "mm"),
            ("rx_deg", "about x", 1, "deg"), ("ry_deg", "about y", 1, "deg"), ("rz_deg", "about z", 1, "deg")]
    lines = ["| axis | drawn: median | drawn: p95 | left: median | left: p95 |", "|---|---|---|---|---|"]
    for name, label, scale, unit in axes:
        before = np.abs([draws[f"camera_{name}"] for draws in drawn]) * scale
        after = np.abs([error[name] for error in left]) * scale
        digits = 1 if unit == "mm" else 2
        lines.append(f"| {label} ({unit}) | {np.median(before):.{digits}f} | {np.percentile(before, 95):.{digits}f} | "
                     f"{np.median(after):.{digits}f} | {np.percentile(after, 95):.{digits}f} |")
    misread = {"drawn": [], "left": []}
    for row, draws, guess in zip(hard.itertuples(), drawn, estimate):
        believed = default_camera(cached_scene(row.scene))
        mounted = camera_as_mounted(believed, draws)
        placed = camera_as_mounted(believed, {f"camera_{name}": value for name, value in guess.items()})
        point = np.array([row.x, row.y, cached_scene(row.scene).table.height, 1.0])
        for label, camera in (("drawn", believed), ("left", placed)):
            read = camera.optical_pose() @ np.linalg.inv(mounted.optical_pose()) @ point
            misread[label].append(1000 * float(np.linalg.norm(read[:3] - point[:3])))
    lines.append(f"| a point of the table where the object started (mm) | {np.median(misread['drawn']):.1f} | "
                 f"{np.percentile(misread['drawn'], 95):.1f} | {np.median(misread['left']):.1f} | "
                 f"{np.percentile(misread['left'], 95):.1f} |")
    return "\n".join(lines) + f"\n\nOver {len(hard)} closed-loop runs of the hard setting, build {_builds(hard)}."


def _builds(runs) -> str:
    from slideplan.experiments.closed_loop_report import builds

    return builds(runs)
