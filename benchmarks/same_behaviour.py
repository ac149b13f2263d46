"""Does a change keep behaviour? An older build and this one make the README's plans and a closed-loop dev
subset in one run, and the results are compared.

- The README's plans (``slideplan plan``): the plan JSON must be identical but for clock readings
  (``planning_time_s``, the core's set-up times), where the package lies (the URDF's folder) and the
  parameters the older build did not have (named in the table; their values must leave the plan as it was).
- The closed loop's dev subset, ``slideplan experiment closed-loop --scene square --poses 1`` (5 objects x
  4 settings x 2 modes = 40 runs): paired by object, table, pose, setting and mode, every column of every row
  must be equal but the provenance, the task id (it hashes the whole configuration) and the wall-clock ones
  (times, re-plan latencies); the simulated seconds per wall second of each build, per
  mode, are reported (medians, p10 and p90 over every pass), measured in this run with the other core
  idle, in passes whose order alternates (older first, then this build first) so that a drift in the
  machine's speed falls on both.

Writes docs/benchmarks/same_behaviour.md, with the build, CPU and date. Not a test: ``make bench``
leaves it out (it needs the older build); run it after a change that must not change behaviour:

    pip install --no-deps --no-build-isolation --target /tmp/before .   # at the older commit
    python benchmarks/same_behaviour.py --before /tmp/before
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd

from plan_bench import write_report  # benchmarks/ is the script's directory, hence on sys.path

README_PLANS = (  # README.md's commands, each with its --json
    ["--scene", "square", "--object", "crescent", "--pose", "0.55", "-0.08", "0.4", "--seed", "1", "--time-limit", "10"],
    ["--scene", "panda_square", "--object", "crescent", "--seed", "1", "--param", "u_star=0.025"],
    ["--scene", "round", "--object", "Y", "--pose", "0.5", "0.0", "1.0", "--seed", "3", "--time-limit", "10"],
)
CLOCK_KEYS = {"planning_time_s", "precompute_time", "setup_time"}
SUBSET = ["closed-loop", "--set", "dev", "--scene", "square", "--poses", "1", "--workers", "1"]
# Columns that say who ran a row and how long it took, not what happened.
NOT_BEHAVIOUR = {"build", "dirty", "cpu", "date", "host", "python", "wall_time_s", "plan_time_s", "replan_time_s",
                 "work_s", "worker", "started", "finished", "replan_latency_s", "max_latency_s"}


def slideplan(python_path: str | None, *arguments: str) -> subprocess.CompletedProcess:
    """``python -m slideplan.cli`` with the older build first on the path (None: this build)."""
    env = dict(os.environ, SLIDEPLAN_NO_CACHE="1")
    env.pop("PYTHONPATH", None)
    if python_path:
        env["PYTHONPATH"] = python_path
    return subprocess.run([sys.executable, "-m", "slideplan.cli", *arguments], env=env, capture_output=True, text=True)


def behaviour(value):
    """The plan JSON without its clock readings, the URDF by its file name."""
    if isinstance(value, dict):
        return {key: Path(item).name if key == "urdf" else behaviour(item)
                for key, item in value.items() if key not in CLOCK_KEYS}
    if isinstance(value, list):
        return [behaviour(item) for item in value]
    return value


def compare_plans(before: str, work: Path) -> list[str]:
    lines = []
    for index, arguments in enumerate(README_PLANS):
        plans = []
        for label, path in (("before", before), ("after", None)):
            out = work / f"plan{index}-{label}.json"
            done = slideplan(path, "plan", *arguments, "--json", str(out))
            if done.returncode not in (0, 1):
                raise SystemExit(f"{label}: slideplan plan {' '.join(arguments)} failed: {done.stderr}")
            plans.append(behaviour(json.loads(out.read_text())))
        # Parameters the older build did not have are compared by the plan they make, not by their presence.
        added = sorted(set(plans[1]["params"]) - set(plans[0]["params"]))
        for name in added:
            plans[1]["params"].pop(name)
            plans[1]["params"].get("sources", {}).pop(name, None)
        same = plans[0] == plans[1]
        note = f" (new parameters: {', '.join(added)})" if added else ""
        lines.append(f"| `slideplan plan {' '.join(arguments)}` | {plans[1]['status']} | {'identical' if same else 'DIFFERENT'}{note} |")
    return lines


def subset_rows(python_path: str | None, out: Path) -> pd.DataFrame:
    """One row per run of the subset, run by the given build into ``out`` (resuming what is there)."""
    from slideplan.experiments.closed_loop import closed_loop_runs, load_closed_loop

    done = slideplan(python_path, "experiment", *SUBSET, "--out", str(out))
    if done.returncode != 0:
        raise SystemExit(f"the closed-loop subset failed: {done.stderr[-2000:]}")
    return closed_loop_runs(load_closed_loop(out))


def speed(rows: pd.DataFrame) -> dict[str, str]:
    factor = rows["sim_time_s"] / rows["wall_time_s"]
    return {mode: f"{factor[rows['mode'] == mode].median():.2f}x (p10 {factor[rows['mode'] == mode].quantile(0.1):.2f}x, "
                  f"p90 {factor[rows['mode'] == mode].quantile(0.9):.2f}x)" for mode in ("open", "closed")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="a folder holding the older build's installed slideplan")
    parser.add_argument("--passes", type=int, default=2, help="runs of the subset per build, the order alternating")
    parser.add_argument("--work", default=None, help="keep the runs here (a rerun resumes them); default: a temporary folder")
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "benchmarks" / "same_behaviour.md"))
    args = parser.parse_args()
    before_build = subprocess.run(
        [sys.executable, "-c", "from slideplan.provenance import build_info; print(build_info()['build'])"],
        env=dict(os.environ, PYTHONPATH=args.before), capture_output=True, text=True, check=True).stdout.strip()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(args.work or folder)
        work.mkdir(parents=True, exist_ok=True)
        plan_lines = compare_plans(args.before, work)
        builds = (("before", args.before), ("after", None))
        passes = []
        for index in range(args.passes):
            order = builds if index % 2 == 0 else builds[::-1]
            passes.append({label: subset_rows(path, work / f"pass{index}" / label) for label, path in order})
        rows = passes[0]
    # A task's id hashes the planner's whole configuration, so a new parameter changes it: runs pair by task.
    key = ["object", "scene", "pose_index", "setting", "mode"]
    columns = sorted(set(rows["after"].columns) - NOT_BEHAVIOUR - {"sim_time_s", "task_id"}
                     - {c for c in rows["after"] if c.endswith("_wall_s")})
    left, right = (rows[label].sort_values(key).reset_index(drop=True)[columns] for label in ("before", "after"))
    differing = [column for column in columns if column not in left or not left[column].equals(right[column])]
    differing += [f"pass {index}: {column}" for index, run in enumerate(passes[1:], 1) for column in columns
                  if not run["after"].sort_values(key).reset_index(drop=True)[column].equals(right[column])]
    speeds = {label: speed(pd.concat([run[label] for run in passes], ignore_index=True)) for label in ("before", "after")}
    lines = [
        "# Same behaviour: an older build against this one",
        f"The older build: {before_build} (`{args.before}`). Command: `python benchmarks/same_behaviour.py --before DIR`.",
        "",
        "| README plan | status | plan JSON (clock readings aside) |", "|---|---|---|", *plan_lines, "",
        f"Closed-loop dev subset (`slideplan experiment {' '.join(SUBSET)}`): {len(rows['after'])} runs a build and "
        f"pass, {len(passes)} passes; "
        + (f"every row identical in all {len(columns)} columns of behaviour." if not differing and len(left) == len(right)
           else f"DIFFERENT in {differing}."),
        "",
        f"| build | open loop, simulated s per wall s ({len(passes)} passes) | closed loop |", "|---|---|---|",
        *(f"| {label} | {speeds[label]['open']} | {speeds[label]['closed']} |" for label in ("before", "after")),
    ]
    write_report(lines, Path(args.out))


if __name__ == "__main__":
    main()
