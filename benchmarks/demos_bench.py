"""Demonstrations benchmark: successful episodes per hour of `slideplan demos` on this machine's cores, end to
end (the episode, rendering, encoding, each episode's finalize and the merge), and the share of attempts kept.

1. Throughput, nominal setting, closed loop, --keep success: state only, and with one 256x256 RGB camera
   (front) at 10 fps: the command's wall time, its successes, and successes per hour.
2. The share kept (successes over attempts, the world's verdict) per setting, state only.

Each part is one `slideplan demos` command in a new process on all cores (--workers = cores), with its own
seed. Prints and writes docs/benchmarks/demos.md (build, CPU, date named) and every command as a row
(docs/benchmarks/demos.parquet, with the build). Not a test: `make bench`.

    python benchmarks/demos_bench.py [--episodes 100] [--setting-episodes 20]
    python benchmarks/demos_bench.py --from-rows      # the page again from the committed rows, running nothing
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
from plan_bench import write_report  # same directory: python puts it on sys.path

SLIDEPLAN = str(Path(sys.executable).with_name("slideplan"))
SETTINGS = ("nominal", "stress", "random", "hard")


def generate(episodes: int, setting: str, cameras: list[str], seed: int, workers: int) -> dict:
    """Run one `slideplan demos` command; its wall time, attempts and successes."""
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "d"
        command = [SLIDEPLAN, "demos", "--scene", "square", "--episodes", str(episodes), "--out", str(out),
                   "--setting", setting, "--seed", str(seed), "--workers", str(workers)]
        for camera in cameras:
            command += ["--cameras", camera]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, env={**os.environ, "MUJOCO_GL": "egl"})
        wall = time.perf_counter() - start
        if done.returncode != 0:
            raise SystemExit(f"{' '.join(command)} failed: {done.stderr.strip()}")
        meta = json.loads((out / "meta" / "slideplan_episodes.json").read_text())
        return {"setting": setting, "cameras": " ".join(cameras) or "none", "episodes": episodes,
                "attempts": meta["attempts"], "kept": len(meta["episodes"]), "wall_s": wall, "workers": workers,
                "frames": sum(episode["frames"] for episode in meta["episodes"])}


TARGETS = (  # (what, setting, cameras, the least successes per hour or share kept)
    ("successes per hour, state only", "nominal", "none", 1000),
    ("successes per hour, one 256x256 camera", "nominal", "front:256x256", 400),
)


def report(table: pd.DataFrame, workers: int) -> list[str]:
    """The page's lines: the table of every command, then each target met or missed."""
    lines = ["# Demonstrations: episodes per hour", "",
             f"`slideplan demos --scene square`, closed loop, --keep success, {workers} workers on {workers} cores, "
             "end to end (a new process per command: episodes, rendering, encoding, finalize, merge).", "",
             "| setting | cameras | attempts | successes (kept) | wall | successes per hour | frames per second of wall |",
             "|---|---|---|---|---|---|---|"]
    for row in table.itertuples():
        lines.append(f"| {row.setting} | {row.cameras} | {row.attempts} | {row.kept} "
                     f"({100 * row.kept / row.attempts:.0f}%) | {row.wall_s:.0f} s | "
                     f"{3600 * row.kept / row.wall_s:.0f} | {row.frames / row.wall_s:.0f} |")
    lines += ["", "Targets:", ""]
    throughput = table[table["part"] == "throughput"]
    for what, setting, cameras, least in TARGETS:
        row = throughput[(throughput["setting"] == setting) & (throughput["cameras"] == cameras)].iloc[0]
        rate = 3600 * row["kept"] / row["wall_s"]
        lines.append(f"- {what}: {rate:.0f} against at least {least}: {'met' if rate >= least else 'MISSED'}")
    nominal = table[(table["setting"] == "nominal") & (table["cameras"] == "none")]
    share = nominal["kept"].sum() / nominal["attempts"].sum()
    lines.append(f"- kept in the nominal setting: {100 * share:.1f}% against at least 95%: {'met' if share >= 0.95 else 'MISSED'}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100, help="episodes per throughput command (a generation of "
                        "hundreds, as docs/demos.md's examples: the command's start-up and merge are in its wall time)")
    parser.add_argument("--setting-episodes", type=int, default=20, help="episodes per setting for the kept share")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks/demos.md"))
    parser.add_argument("--rows", type=Path, default=Path("docs/benchmarks/demos.parquet"))
    parser.add_argument("--from-rows", action="store_true", help="write the page from the committed rows, run nothing")
    args = parser.parse_args()
    if args.from_rows:  # the page again from its rows, under the build, CPU and date they recorded
        table = pd.read_parquet(args.rows)
        first = table.iloc[0]
        lines = report(table, int(first["cores"]))
        page = [lines[0], "", f"Build {first['build']} (slideplan {first['version']}), CPU: {first['cpu']}, "
                f"{int(first['cores'])} cores, {first['date']}.", *lines[1:]]
        args.out.write_text("\n".join(page) + "\n")
        print("\n".join(page))
        return
    workers = os.cpu_count() or 1
    rows = [dict(part="throughput", **generate(args.episodes, "nominal", [], 11, workers)),
            dict(part="throughput", **generate(args.episodes, "nominal", ["front:256x256"], 12, workers))]
    rows += [dict(part="kept", **generate(args.setting_episodes, setting, [], 13, workers)) for setting in SETTINGS]
    table = pd.DataFrame(rows)
    from slideplan.provenance import run_provenance

    table.assign(cores=workers, **run_provenance()).to_parquet(args.rows)
    write_report(report(table, workers), args.out)


if __name__ == "__main__":
    main()
