"""Command-line benchmark: the wall time a user waits for `slideplan plan`, in a new process each run.

1. The command of the README's first plan (square table, crescent, a fixed pose), pinned to one core:
   with a cold grasp-map cache (a new, empty SLIDEPLAN_CACHE_DIR each run) and a warm one (primed by
   one run first).
2. The same on a busy machine, as a user often has one: every core running one spinning process beside
   the command, which is not pinned (the scheduler shares the cores).
3. Per robot scene: 5 objects x 2 seeds (random poses), each run cold, 10 s planning budget: the wall
   time, how many solved, and how many timed out.

Prints and writes (docs/benchmarks/cli.md) medians and percentiles, with the build, CPU and date named, and
every run's wall time as a row (docs/benchmarks/cli.parquet, with the build: the README's sentence on the
command's wall time is written from these rows by docs/results/make_tables.py). Not a test: `make bench`.

    python benchmarks/cli_bench.py [--runs 5] [--scenes square panda_square ur5_square]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from plan_bench import write_report  # same directory: python puts it on sys.path

SLIDEPLAN = str(Path(sys.executable).with_name("slideplan"))
FIRST_PLAN = ["--scene", "square", "--object", "crescent", "--pose", "0.55", "-0.08", "0.4", "--seed", "1"]
OBJECTS = ("crescent", "L", "E", "triangle", "irregular")
SEEDS = (1, 2)


def wall(args: list[str], cache: Path, core: int | None) -> tuple[float, int]:
    """Run `slideplan plan ARGS` pinned to one core (None: not pinned); returns (wall seconds, exit code)."""
    env = {**os.environ, "SLIDEPLAN_CACHE_DIR": str(cache)}
    env.pop("SLIDEPLAN_NO_CACHE", None)
    with tempfile.TemporaryDirectory() as out:
        pin = [] if core is None else ["taskset", "-c", str(core)]
        command = [*pin, SLIDEPLAN, "plan", *args, "--json", f"{out}/plan.json"]
        start = time.perf_counter()
        code = subprocess.run(command, env=env, capture_output=True).returncode
        return time.perf_counter() - start, code


def quantiles(times: list[float]) -> str:
    median, p90 = np.percentile(times, [50, 90])
    return f"{median:.3f} s | {p90:.3f} s | {min(times):.3f} s | {max(times):.3f} s"


ROWS: list[dict] = []  # every run: part, scene, cache, wall_s, exit_code


def first_plan(runs: int, core: int | None, part: str = "first plan, pinned") -> list[str]:
    cold, warm = [], []
    with tempfile.TemporaryDirectory() as root:
        for run in range(runs):
            cache = Path(root) / f"cold{run}"
            seconds, code = wall(FIRST_PLAN, cache, core)
            assert code == 0, f"the first plan failed (exit {code})"
            cold.append(seconds)
        primed = Path(root) / "cold0"  # holds the map the first cold run stored
        for _ in range(runs):
            seconds, code = wall(FIRST_PLAN, primed, core)
            assert code == 0, f"the first plan failed (exit {code})"
            warm.append(seconds)
    ROWS.extend({"part": part, "scene": "square", "cache": cache, "wall_s": seconds, "exit_code": 0}
                for cache, times in (("cold", cold), ("warm", warm)) for seconds in times)
    return ["| grasp-map cache | median | p90 | min | max |", "|---|---|---|---|---|",
            f"| cold (empty cache) | {quantiles(cold)} |", f"| warm (stored map) | {quantiles(warm)} |"]


def robots(scenes: list[str], core: int, time_limit: float) -> list[str]:
    rows = ["| scene | runs | solved | timeouts | median | p90 | min | max |", "|---|---|---|---|---|---|---|---|"]
    for scene in scenes:
        times, solved, timeouts = [], 0, 0
        for name in OBJECTS:
            for seed in SEEDS:
                with tempfile.TemporaryDirectory() as cache:
                    seconds, code = wall(["--scene", scene, "--object", name, "--seed", str(seed),
                                          "--time-limit", str(time_limit)], Path(cache), core)
                times.append(seconds)
                ROWS.append({"part": "robots", "scene": scene, "cache": "cold", "wall_s": seconds, "exit_code": code})
                solved += code == 0
                timeouts += code == 1
        rows.append(f"| {scene} | {len(times)} | {solved} | {timeouts} | {quantiles(times)} |")
    return rows


def busy_first_plan(runs: int) -> list[str]:
    """:func:`first_plan`, not pinned, with one spinning process per core for the whole time."""
    spinners = [subprocess.Popen(["taskset", "-c", str(core), sys.executable, "-c", "while True: pass"])
                for core in range(os.cpu_count() or 1)]
    try:
        return first_plan(runs, None, "first plan, busy")
    finally:
        for spinner in spinners:
            spinner.kill()
            spinner.wait()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="runs per cache state of the first plan")
    parser.add_argument("--scenes", nargs="+", default=["square", "panda_square", "ur5_square", "xarm7_square", "kinova_square"],
                        help="robot scenes (built-in names or scene files) for part 2")
    parser.add_argument("--core", type=int, default=0, help="the core every run is pinned to")
    parser.add_argument("--time-limit", type=float, default=10.0, help="planning budget of part 2 (s)")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks/cli.md"))
    parser.add_argument("--rows", type=Path, default=Path("docs/benchmarks/cli.parquet"))
    args = parser.parse_args()
    if shutil.which("taskset") is None:
        sys.exit("cli_bench needs taskset (util-linux) to pin runs to one core")
    lines = [
        "# `slideplan plan` wall time", "",
        f"`benchmarks/cli_bench.py`: every run a new process pinned to core {args.core} (`taskset`), wall time of "
        "the whole command (start, plan, verify, write the JSON).", "",
        f"## The first plan: `slideplan plan {' '.join(FIRST_PLAN)} --json plan.json`, {args.runs} runs each", "",
        *first_plan(args.runs, args.core), "",
        f"## The first plan on a busy machine: one spinning process on each of the {os.cpu_count()} cores, the "
        f"command not pinned, {args.runs} runs each", "",
        *busy_first_plan(args.runs), "",
        f"## Robots, cold cache: {len(OBJECTS)} objects x {len(SEEDS)} seeds (random poses), "
        f"`--time-limit {args.time_limit:g}`", "",
        "Each run with an empty grasp-map cache, as the first plan of a new robot is; exit 0 is solved and verified.", "",
        *robots(args.scenes, args.core, args.time_limit),
    ]
    write_report(lines, args.out)
    from slideplan.provenance import run_provenance

    pd.DataFrame(ROWS).assign(runs=args.runs, cores=os.cpu_count(), **run_provenance()).to_parquet(args.rows)


if __name__ == "__main__":
    main()
