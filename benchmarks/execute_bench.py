"""Execution benchmark (the execution model's figure of merit): simulated seconds per wall second of MuJoCo episodes,
the model before the feet and today's, from one run in one process (one core).

1. Open loop: the plans of a fixed subset of the Fig. 10 set (the execution experiment's tasks,
   ``tasks[start::stride][:count]``, nominal setting), each executed with ``contacts.LEGACY`` and
   ``contacts.CURRENT`` (benchmarks/execute_fidelity.py ``run``: its rows are the fidelity check's
   too); sim/wall median, p10 and p90 per model.
2. Closed loop: one ``run`` (square table, crescent, the demo's pose, seed 0, its depth frames) per model.
3. The profile (benchmarks/execute_profile.py) of the demo plan's ``execute`` and of that closed-loop
   run, per model: MuJoCo's timers, contacts and solver iterations per phase.

    python benchmarks/execute_bench.py [--start 0] [--stride 5] [--count 40] [--out docs/benchmarks/execution.md]

Not a test (``make bench``). Writes the page (``--out``; its last section, "Findings", is written by hand
and kept) and the rows (``--rows``).
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
import execute_fidelity  # noqa: E402
import execute_profile  # noqa: E402
from plan_bench import write_report  # noqa: E402

from execute_profile import demo_plan, demo_pose  # noqa: E402


def quantiles(values) -> str:
    values = np.asarray(values, dtype=float)
    return f"{np.median(values):.2f}x | {np.percentile(values, 10):.2f}x | {np.percentile(values, 90):.2f}x"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--start", type=int, default=0)
    parser.add_argument("--stride", type=int, default=5)
    parser.add_argument("--count", type=int, default=40)
    parser.add_argument("--closed-loop", action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument("--conditions", default="the machine's other cores as the run found them: say how with this option",
                        help="what else the machine ran meanwhile, for the page (wall times depend on it)")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs/benchmarks/execution.md")
    parser.add_argument("--rows", type=Path, default=execute_fidelity.DEFAULT_OUT)
    args = parser.parse_args()
    from slideplan.sim.closed_loop import run
    from slideplan.sim import contacts, execute

    started = time.perf_counter()
    execute_fidelity.run(argparse.Namespace(start=args.start, stride=args.stride, count=args.count, out=args.rows,
                                            models="legacy;current"))
    rows = pd.read_parquet(args.rows)
    executed = rows[rows["model"].notna()]
    checks = io.StringIO()
    with redirect_stdout(checks):
        held = execute_fidelity.compare_rows(rows)
    lines = [
        "# Execution benchmark: simulated seconds per wall second",
        "",
        f"`benchmarks/execute_bench.py --start {args.start} --stride {args.stride} --count {args.count}`, one process "
        f"(one core; {args.conditions}), {time.perf_counter() - started:.0f} s for the open-loop part. The model before the feet "
        f"(`contacts.LEGACY`: the object's boxes on the table, noslip throughout, no sleeping) and today's "
        f"(`contacts.CURRENT`: {contacts.CURRENT}) in the same run. The Python code is the tree at "
        f"{execute_fidelity.tree_commit()} (the rows' `tree_commit`); `build` above names the installed extension it ran over.",
        "",
        "## Open loop: plans of the Fig. 10 set, nominal",
        "",
        f"A fixed subset, not all 200: `build_spec(\"execution\").tasks[{args.start}::{args.stride}][:{args.count}]` "
        f"({len(rows['task_index'].unique())} tasks: every scene and object, poses "
        f"{sorted(rows['pose_index'].unique().tolist())}); each plan planned once and executed with both models.",
        "",
        "| model | executions | sim/wall median | p10 | p90 | wall per episode, median | simulated per episode, median |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in ("legacy", "current"):
        frame = executed[executed["model"] == name]
        lines.append(f"| {name} | {len(frame)} | {quantiles(frame['sim_time_s'] / frame['wall_time_s'])} | "
                     f"{frame['wall_time_s'].median():.1f} s | {frame['sim_time_s'].median():.1f} s |")
    lines += ["", "Fidelity (benchmarks/execute_fidelity.py compare, the same rows, "
              f"{args.rows.name}): {'both checks hold' if held else 'a check FAILS'}.", "", "```",
              *checks.getvalue().rstrip().splitlines(), "```", ""]

    if args.closed_loop:
        scene, pose = demo_pose()
        lines += ["## Closed loop: one `run` with its depth frames (square, crescent, the demo's pose, seed 0)", "",
                  "Each run profiled (the profiler's bookkeeping costs a few microseconds a step).", "",
                  "| model | simulated | wall | sim/wall | outcome |", "|---|---|---|---|---|"]
        profiles = []
        execute_profile.install()
        for name, model in (("legacy", contacts.LEGACY), ("current", contacts.CURRENT)):
            contacts.ACTIVE[0] = model
            profile = execute_profile.ACTIVE[0] = execute_profile.Profile()
            began = time.perf_counter()
            outcome = run(scene, "crescent", pose, seed=0)
            wall = time.perf_counter() - began
            lines.append(f"| {name} | {outcome.sim_time_s:.1f} s | {wall:.1f} s | {outcome.sim_time_s / wall:.2f}x | "
                         f"{outcome.summary()} |")
            profiles += execute_profile.report(f"Closed-loop `run`, model {name}", profile, wall, outcome.sim_time_s)
            # the demo plan's execute, profiled, with the same model
            result = demo_plan()
            profile = execute_profile.ACTIVE[0] = execute_profile.Profile()
            began = time.perf_counter()
            execution = execute(result)
            wall = time.perf_counter() - began
            profiles += execute_profile.report(f"`execute` of the demo plan, model {name}: {execution.summary()}",
                                               profile, wall, execution.sim_time_s)
        contacts.ACTIVE[0] = contacts.CURRENT
        lines += ["", "## Profiles (benchmarks/execute_profile.py's instrumentation)", "", *profiles]
    # The page's last section, "## Findings", is written by hand from a run: a rerun keeps it (and its date says which run).
    if args.out.exists() and "\n## Findings" in args.out.read_text():
        lines += ["", "## Findings" + args.out.read_text().split("\n## Findings", 1)[1].rstrip()]
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
