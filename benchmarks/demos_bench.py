"""Demonstrations benchmark: successful episodes per hour of `slideplan demos` on this machine's cores, end to
end (the episode, rendering, encoding, each episode's finalize and the merge), and the share of attempts kept.

1. Throughput, nominal setting, closed loop, --keep success: state only, and with one 256x256 RGB camera
   (front) at 10 fps: the command's wall time, its successes, and successes per hour.
2. The share kept (successes over attempts, the world's verdict) per setting, state only.

Each part is one `slideplan demos` command in a new process on all cores (--workers = cores), with its own
seed. Prints and writes docs/benchmarks/demos.md (build, CPU, date named) and every command as a row
(docs/benchmarks/demos.parquet, with the build). Not a test: `make bench`.

    python benchmarks/demos_bench.py [--episodes 40] [--setting-episodes 20]
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=40, help="episodes per throughput command")
    parser.add_argument("--setting-episodes", type=int, default=20, help="episodes per setting for the kept share")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks/demos.md"))
    parser.add_argument("--rows", type=Path, default=Path("docs/benchmarks/demos.parquet"))
    args = parser.parse_args()
    workers = os.cpu_count() or 1
    rows = [dict(part="throughput", **generate(args.episodes, "nominal", [], 11, workers)),
            dict(part="throughput", **generate(args.episodes, "nominal", ["front:256x256"], 12, workers))]
    rows += [dict(part="kept", **generate(args.setting_episodes, setting, [], 13, workers)) for setting in SETTINGS]
    table = pd.DataFrame(rows)
    from slideplan.provenance import run_provenance

    table.assign(cores=workers, **run_provenance()).to_parquet(args.rows)
    lines = ["# Demonstrations: episodes per hour", "",
             f"`slideplan demos --scene square`, closed loop, --keep success, {workers} workers on {workers} cores, "
             "end to end (a new process per command: episodes, rendering, encoding, finalize, merge).", "",
             "| setting | cameras | attempts | successes (kept) | wall | successes per hour | frames per second of wall |",
             "|---|---|---|---|---|---|---|"]
    for row in rows:
        lines.append(f"| {row['setting']} | {row['cameras']} | {row['attempts']} | {row['kept']} "
                     f"({100 * row['kept'] / row['attempts']:.0f}%) | {row['wall_s']:.0f} s | "
                     f"{3600 * row['kept'] / row['wall_s']:.0f} | {row['frames'] / row['wall_s']:.0f} |")
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
