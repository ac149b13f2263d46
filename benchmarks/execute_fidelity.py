"""Fidelity of the faster execution model: open-loop executions of the Fig. 10 set's plans
(the execution experiment's tasks, nominal setting), each plan executed in one process with the model
before the feet (``contacts.LEGACY``) and with today's (``contacts.CURRENT``).

    python benchmarks/execute_fidelity.py run [--start 0] [--stride 5] [--count 40] [--out docs/benchmarks/execution_fidelity.parquet]
    python benchmarks/execute_fidelity.py compare [--model current] [docs/benchmarks/execution_fidelity*.parquet]
    python benchmarks/execute_fidelity.py closed --models "current;label=ContactModel(...)" --out ROWS [--settings nominal,hard]
    python benchmarks/execute_fidelity.py compare-closed ROWS --model label

``run`` plans each task of ``build_spec("execution").tasks[start::stride][:count]`` (as the execution
experiment does: planned, verified) and writes one row per task and model: the slide's final planar
pose (``actual_motion``, the pose the report measures, after the slide and 0.3 s still), its errors
against Eq. 2, the centre of mass there (``com_x``, ``com_y``: the pose compared is the centre of
mass and the yaw), lifted, success, the failed stage, sim and wall time, the model, and the provenance
columns (``slideplan.provenance.run_provenance()``). ``compare`` reads the rows and checks, over the
tasks both models executed: the final pose within 3 mm and 2 deg of the old model's in >= 95% of
runs, and the lifted outcome the same in >= 98%. The checks are the issue's; they are not tuned here.
``closed`` runs the same tasks closed loop (``closed_loop.run``, its own seed and setting) with each model;
``compare-closed`` prints each model's lifted share with its Wilson 95% interval, and the runs that agree.
"""

from __future__ import annotations

import argparse
import sys
import math
import time
from pathlib import Path

import numpy as np
import pandas as pd

DEFAULT_OUT = Path(__file__).resolve().parents[1] / "docs/benchmarks/execution_fidelity.parquet"
POSITION_M, YAW_DEG, POSE_SHARE, LIFTED_SHARE = 0.003, 2.0, 0.95, 0.98


def run(args) -> None:
    from slideplan.sim import ExecutionSettings, contacts, execute
    from slideplan.experiments import build_spec
    from slideplan.experiments.tasks import cached_scene
    from slideplan.plan.planner import plan
    from slideplan.provenance import run_provenance
    from slideplan.checks.verify import verify

    tasks = build_spec("execution").tasks[args.start::args.stride][: args.count]
    tree = tree_commit()
    rows = []
    for number, task in enumerate(tasks):
        started = time.perf_counter()
        result = plan(cached_scene(task.scene), task.placed_object(), task.planner_config())
        base = dict(task_index=args.start + number * args.stride, scene=task.scene, object=task.object,
                    pose_index=task.pose_index, solved=bool(result.solved and verify(result).ok),
                    planning_time_s=time.perf_counter() - started, **run_provenance(), tree_commit=tree)
        if not base["solved"]:
            rows.append({**base, "model": None})
            print(f"{number + 1}/{len(tasks)} {task.scene} {task.object} {task.pose_index}: not solved", flush=True)
            continue
        for name in args.models.split(";"):
            # "legacy", "current", or "label=ContactModel(...)" (a candidate being measured)
            label, _, expression = name.partition("=")
            model = {"legacy": contacts.LEGACY, "current": contacts.CURRENT}.get(label) or eval(  # noqa: S307
                expression, {"ContactModel": contacts.ContactModel})
            name = label
            contacts.ACTIVE[0] = model
            try:
                execution = execute(result, ExecutionSettings())
            finally:
                contacts.ACTIVE[0] = contacts.CURRENT
            motion = execution.actual_motion or {}
            com = (None, None)
            if motion:  # the object's centre of mass where the slide left it: its planar motion applied to com_xy
                cos, sin = math.cos(motion["yaw"]), math.sin(motion["yaw"])
                x0, y0 = (float(value) for value in result.object["com_xy"])
                com = (cos * x0 - sin * y0 + motion["x"], sin * x0 + cos * y0 + motion["y"])
            rows.append({**base, "model": name, "contact_model": str(model),
                         "x": motion.get("x"), "y": motion.get("y"), "yaw": motion.get("yaw"), "com_x": com[0], "com_y": com[1],
                         "position_error_m": execution.position_error_m, "yaw_error_deg": execution.yaw_error_deg,
                         "lifted": execution.lifted, "success": execution.success, "failed_stage": execution.failed_stage,
                         "sim_time_s": execution.sim_time_s, "wall_time_s": execution.wall_time_s})
            print(f"{number + 1}/{len(tasks)} {task.scene} {task.object} {task.pose_index} {name}: {execution.summary()}",
                  flush=True)
        pd.DataFrame(rows).to_parquet(args.out, index=False)  # after every task: a stopped run keeps its rows
    if {"legacy", "current"} <= set(args.models.split(";")):
        compare_rows(pd.DataFrame(rows))


def closed(args) -> None:
    """Closed-loop runs (``closed_loop.run``, the nominal and hard settings) of the same tasks with each model."""
    from slideplan.sim.closed_loop import run as run_closed
    from slideplan.sim import contacts
    from slideplan.experiments import build_spec
    from slideplan.provenance import run_provenance

    tasks = build_spec("execution").tasks[args.start::args.stride][: args.count]
    tree, rows = tree_commit(), []
    for number, task in enumerate(tasks):
        for setting in args.settings.split(","):
            for name in args.models.split(";"):
                label, _, expression = name.partition("=")
                model = {"legacy": contacts.LEGACY, "current": contacts.CURRENT}.get(label) or eval(  # noqa: S307
                    expression, {"ContactModel": contacts.ContactModel})
                contacts.ACTIVE[0] = model
                try:
                    report = run_closed(task.scene, task.object, (task.x, task.y, task.yaw), seed=task.seed, setting=setting)
                finally:
                    contacts.ACTIVE[0] = contacts.CURRENT
                rows.append({"task_index": args.start + number * args.stride, "scene": task.scene, "object": task.object,
                             "setting": setting, "model": label, "contact_model": str(model), "success": report.success,
                             "failed_stage": report.failed_stage, "replans": report.replans, "sim_time_s": report.sim_time_s,
                             "wall_time_s": report.wall_time_s, **run_provenance(), "tree_commit": tree})
                print(f"{number + 1}/{len(tasks)} {task.scene} {task.object} {setting} {label}: {report.summary()}", flush=True)
            pd.DataFrame(rows).to_parquet(args.out, index=False)


def compare_closed(rows: pd.DataFrame, model: str) -> None:
    """Each setting's success rate per model with its Wilson 95% interval, and how many runs agree."""
    from slideplan.experiments import wilson_interval

    for setting, group in rows.groupby("setting"):
        table = group.pivot_table(index="task_index", columns="model", values="success", aggfunc="first").dropna()
        for name in ("current", model):
            low, high = wilson_interval(int(table[name].sum()), len(table))
            print(f"{setting} {name}: {int(table[name].sum())}/{len(table)} lifted (95% interval {100 * low:.0f}-{100 * high:.0f}%)")
        print(f"{setting}: the same outcome in {int((table['current'] == table[model]).sum())}/{len(table)} runs")


def tree_commit() -> str:
    """The commit of the working tree this script runs from (``+dirty`` when the execution code differs
    from it): the Python code may be newer than the installed extension that ``build`` names."""
    import subprocess

    root = Path(__file__).resolve().parents[1]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "python/slideplan/execute", "benchmarks/execute_fidelity.py"],
                           cwd=root, capture_output=True, text=True).stdout.strip()
    return commit + ("+dirty" if dirty else "")


def compare_rows(rows: pd.DataFrame, model: str = "current") -> bool:
    """Print the checks of ``model``'s rows against the legacy model's (a task's first row of each); True if
    both hold."""
    executed = rows[rows["model"].notna()]
    legacy = executed[executed["model"] == "legacy"].drop_duplicates("task_index").set_index("task_index")
    current = executed[executed["model"] == model].drop_duplicates("task_index").set_index("task_index")
    both = legacy.index.intersection(current.index)
    legacy, current = legacy.loc[both], current.loc[both]
    valid = legacy["com_x"].notna() & current["com_x"].notna()
    distance = np.hypot(current["com_x"] - legacy["com_x"], current["com_y"] - legacy["com_y"])
    turn = np.degrees(np.abs(np.angle(np.exp(1j * (current["yaw"] - legacy["yaw"])))))
    close = valid & (distance <= POSITION_M) & (turn <= YAW_DEG)
    same_lift = legacy["lifted"] == current["lifted"]
    n = len(both)
    pose_share, lift_share = close.sum() / max(n, 1), same_lift.sum() / max(n, 1)
    wall = {name: frame["wall_time_s"].to_numpy() for name, frame in (("legacy", legacy), (model, current))}
    factor = {name: frame["sim_time_s"].to_numpy() / frame["wall_time_s"].to_numpy() for name, frame in (("legacy", legacy), (model, current))}
    print(f"{len(rows['task_index'].unique())} tasks, {n} executed by both models "
          f"({(~rows.drop_duplicates('task_index')['solved']).sum()} not solved)")
    print(f"final pose within {1000 * POSITION_M:.0f} mm and {YAW_DEG:.0f} deg of the old model's: {close.sum()}/{n} = "
          f"{100 * pose_share:.1f}% (needs >= {100 * POSE_SHARE:.0f}%): {'holds' if pose_share >= POSE_SHARE else 'FAILS'}")
    print(f"  distance median {1000 * np.nanmedian(distance):.2f} mm, p90 {1000 * np.nanpercentile(distance, 90):.2f} mm, "
          f"max {1000 * np.nanmax(distance):.2f} mm; yaw difference median {np.nanmedian(turn):.2f} deg, "
          f"p90 {np.nanpercentile(turn, 90):.2f} deg, max {np.nanmax(turn):.2f} deg")
    print(f"lifted the same: {same_lift.sum()}/{n} = {100 * lift_share:.1f}% (needs >= {100 * LIFTED_SHARE:.0f}%): "
          f"{'holds' if lift_share >= LIFTED_SHARE else 'FAILS'}")
    for name in ("legacy", model):
        frame = legacy if name == "legacy" else current
        within = ((frame["position_error_m"] <= 0.005) & (frame["yaw_error_deg"].abs() <= 3.0)).sum()
        print(f"{name}: within 5 mm / 3 deg of Eq. 2 {within}/{n}, lifted {int(frame['lifted'].sum())}/{n}, "
              f"success {int(frame['success'].sum())}/{n}; sim/wall median {np.median(factor[name]):.2f}x "
              f"(p10 {np.percentile(factor[name], 10):.2f}, p90 {np.percentile(factor[name], 90):.2f}), "
              f"wall median {np.median(wall[name]):.1f} s")
    return bool(pose_share >= POSE_SHARE and lift_share >= LIFTED_SHARE)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    runner = commands.add_parser("run")
    runner.add_argument("--start", type=int, default=0)
    runner.add_argument("--stride", type=int, default=5)
    runner.add_argument("--count", type=int, default=40)
    runner.add_argument("--out", type=Path, default=DEFAULT_OUT)
    runner.add_argument("--models", default="legacy;current",
                        help="';'-separated: legacy, current, or label=ContactModel(...) (a candidate)")
    comparer = commands.add_parser("compare")
    comparer.add_argument("rows", type=Path, nargs="*", default=[DEFAULT_OUT], help="row files, compared together")
    comparer.add_argument("--model", default="current", help="the model compared with the legacy one (a run's label)")
    closer = commands.add_parser("closed", help="closed-loop runs of the same tasks with each model")
    closer.add_argument("--start", type=int, default=0)
    closer.add_argument("--stride", type=int, default=5)
    closer.add_argument("--count", type=int, default=40)
    closer.add_argument("--settings", default="nominal,hard")
    closer.add_argument("--out", type=Path, required=True)
    closer.add_argument("--models", default="current", help="as run's; compared with current by compare-closed")
    closed_comparer = commands.add_parser("compare-closed")
    closed_comparer.add_argument("rows", type=Path)
    closed_comparer.add_argument("--model", required=True)
    args = parser.parse_args()
    if args.command == "run":
        run(args)
    elif args.command == "closed":
        closed(args)
    elif args.command == "compare-closed":
        compare_closed(pd.read_parquet(args.rows), args.model)
    else:
        sys.exit(0 if compare_rows(pd.concat([pd.read_parquet(path) for path in args.rows], ignore_index=True), args.model) else 1)


if __name__ == "__main__":
    main()
