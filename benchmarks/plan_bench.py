"""Planning benchmark: on each scene (default: the square table), 5 objects x N seeded poses,
reconfiguration range dz* in {2, 0.5, 0} cm for Algorithm 1 and both baselines at 2 cm, or Algorithm 1
with the hand's own parameters ("slideplan hand").

Prints and writes (docs/benchmarks/plan_bench.md) the success rate within 1, 5, 10 and 60 s and the
median / p90 / p99 planning time, under a header naming the build, the CPU and the date. Unsolved runs
count as never finishing (infinite time), so a quantile reads "inf" when more runs than it failed. Not a test: `make bench`.

    python benchmarks/plan_bench.py [--poses 20] [--time-limit 60] [--workers 1] [--scenes square ...]
                                    [--variants "slideplan dz*=2cm" ...] [--threads 1]
"""

from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from slideplan import PlannerConfig, load_object, load_scene, plan
from slideplan.world.objects import load_outline, sample_pose_on_table
from slideplan.plan.planner import clear_grasp_map_cache
from slideplan.provenance import run_provenance

OBJECTS = ("square", "circle", "triangle", "crescent", "irregular")
VARIANTS = (  # (label, planner, reconfiguration range dz* in metres, None: the hand's or the preset's)
    ("slideplan hand", "slideplan", None),
    # --preset paper: Algorithm 1 and IsPairValid as published, every departure off (paper-to-code.md).
    ("Algorithm 1 as published", "published", None),
    ("slideplan dz*=2cm", "slideplan", 0.02),
    ("slideplan dz*=2cm, paired goals off", "unpaired", 0.02),
    # Every run with an empty grasp map, as a single `slideplan plan` starts: the other variants share the
    # map of a table and thickness across the runs of a worker process, as a program planning many does.
    ("slideplan dz*=2cm, grasp map cold", "cold", 0.02),
    ("slideplan dz*=0.5cm", "slideplan", 0.005),
    ("slideplan dz*=0cm", "slideplan", 0.0),
    ("cbirrt as published", "cbirrt", None),
    ("cbirrt2 as published", "cbirrt2", None),
)
THRESHOLDS_S = (1.0, 5.0, 10.0, 60.0)


def provenance_line() -> str:
    """Which build ran a benchmark, on which CPU (and how many cores) and when (UTC): the line under
    every benchmark page's title (slideplan.provenance.run_provenance)."""
    run = run_provenance()
    return (f"Build {run['build']} (slideplan {run['version']}), CPU: {run['cpu']}, {os.cpu_count()} cores, "
            f"{run['date']}.")


def run_one(job: tuple[str, str, str, float | None, str, int, float]) -> tuple[str, str, bool, float]:
    """Plan one benchmark problem; returns (scene, variant label, solved, planning time in seconds)."""
    scene_name, label, planner, reconfiguration, object_name, pose_index, time_limit = job
    scene = load_scene(scene_name)
    outline, thickness, _ = load_outline(object_name)
    pose = sample_pose_on_table(outline, scene.table, np.random.default_rng([pose_index, OBJECTS.index(object_name)]),
                                avoid=scene.footprints(scene.table.height + thickness))
    obj = load_object(object_name, table_height=scene.table.height, pose=pose)
    overrides = {"published": {"preset": "paper"}, "slideplan": {}, "cold": {}, "unpaired": {"paired_goals": 0.0}}.get(
        planner, {"planner": planner, "preset": "paper"})
    if planner == "cold":
        clear_grasp_map_cache()
    config = PlannerConfig.for_scene(scene, seed=pose_index, time_limit_s=time_limit, **overrides)
    if reconfiguration is not None:
        config = config.with_reconfiguration_range(reconfiguration)
    result = plan(scene, obj, config)
    return scene_name, label, result.solved, result.planning_time_s


def run_peer(job: tuple[str, str, int, float]) -> tuple[float, float]:
    """One problem for the peer comparison: CBiRRT's precomputed valid start/goal pair, connected by our
    ConstrainedExtend (the cbirrt baseline after its precomputation) and by OMPL's ProjectedStateSpace +
    RRTConnect on the same constraint. Returns (ours, OMPL's) connection seconds, inf if unsolved."""
    from slideplan import _core
    from slideplan.plan.planner import core_task

    scene_name, object_name, pose_index, time_limit = job
    scene = load_scene(scene_name)
    outline, _, _ = load_outline(object_name)
    pose = sample_pose_on_table(outline, scene.table, np.random.default_rng([pose_index, OBJECTS.index(object_name)]))
    obj = load_object(object_name, table_height=scene.table.height, pose=pose)
    config = PlannerConfig.for_scene(scene, preset="paper", planner="cbirrt", seed=pose_index, time_limit_s=time_limit)
    result = plan(scene, obj, config)
    if not result.solved:
        return np.inf, np.inf  # no valid pair within the budget: neither gets to connect
    ours = result.planning_time_s - result.stats["precompute_time"]
    solved, seconds, _ = _core.ompl_projected_connect(
        **core_task(scene, obj, config), start=result.start_config, goal=result.goal_config)
    return ours, seconds if solved else np.inf


def peer_table(scene: str, poses: int, time_limit: float, workers: int) -> list[str]:
    """Markdown lines comparing our connection with OMPL's on the same pairs."""
    jobs = [(scene, name, pose, time_limit) for name in OBJECTS for pose in range(poses)]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        pairs = np.array(list(pool.map(run_peer, jobs)))
    both = np.isfinite(pairs).all(axis=1)
    ratios = pairs[both, 1] / pairs[both, 0]
    rows = ["", f"## Peers: connecting the same valid pair ({scene} table, {len(jobs)} problems)", "",
            "CBiRRT's precomputed valid start/goal pair, connected by our ConstrainedExtend and by OMPL's "
            "`ProjectedStateSpace` + `RRTConnect` on the same `SlidingConstraint` (our projection) and validity. "
            f"Budget {time_limit:g} s each.", "",
            "| connection | solved | median | p90 |", "|---|---|---|---|"]
    for label, column in (("ConstrainedExtend (ours)", 0), ("OMPL ProjectedStateSpace + RRTConnect", 1)):
        times = pairs[np.isfinite(pairs[:, 0]), column]
        row = summarise(times, time_limit)
        rows.append(f"| {label} | {np.mean(np.isfinite(times)):.0%} | {row['median']} | {row['p90']} |")
    if len(ratios):
        rows += ["", f"OMPL / ours, on the {len(ratios)} pairs both connected: median ratio {np.median(ratios):.1f}x, "
                 f"p10 {np.percentile(ratios, 10):.1f}x, p90 {np.percentile(ratios, 90):.1f}x."]
    return rows


def run_dense(job: tuple[int, int, float]) -> tuple[float, float]:
    """The crescent as a uniform random cloud of `points` points (a sensor's resolution) on the square
    table at seeded pose `pose_index`; returns (planning seconds, plan() wall seconds), inf if unsolved."""
    import shapely

    from slideplan.world.objects import ThinObject, place_outline

    points, pose_index, time_limit = job
    scene = load_scene("square")
    outline, thickness, _ = load_outline("crescent")
    placed = place_outline(outline, sample_pose_on_table(outline, scene.table, np.random.default_rng(pose_index)))
    rng = np.random.default_rng([pose_index, points])
    minx, miny, maxx, maxy = placed.bounds
    xy = np.empty((0, 2))
    while len(xy) < points:
        draw = rng.uniform((minx, miny), (maxx, maxy), size=(points, 2))
        xy = np.concatenate([xy, draw[shapely.contains_xy(placed, draw[:, 0], draw[:, 1])]])
    cloud = np.column_stack([xy[:points], np.full(points, scene.table.height + thickness)])
    obj = ThinObject.from_points(cloud, table_height=scene.table.height)
    started = time.perf_counter()
    result = plan(scene, obj, PlannerConfig.for_scene(scene, seed=pose_index, time_limit_s=time_limit))
    wall = time.perf_counter() - started
    return (result.planning_time_s, wall) if result.solved else (np.inf, np.inf)


def dense_table(poses: int, time_limit: float, workers: int, issue_poses: int = 10) -> list[str]:
    """Markdown lines: the crescent at 1,000 and 100,000 points, same poses; medians over the first
    `issue_poses` poses (the first protocol of this benchmark) and over all `poses`."""
    rows = ["", f"## Cloud density (crescent, square table, {poses} seeded poses)", "",
            "A uniform random cloud of the crescent's top surface at two resolutions. Planning time is what the "
            "planner reports; plan() wall time adds building the task from the cloud and the time parameterization. "
            f"The two clouds of a pose are different random draws, so they grow different trees: the median over "
            f"the first {issue_poses} poses (the issue's protocol) moves by tens of percent between runs, the "
            f"median over all {poses} much less.",
            "", f"| points | solved | median planning, {issue_poses} poses | median planning, {poses} poses | "
            f"median plan() wall, {poses} poses |", "|---|---|---|---|---|"]
    medians = {}
    for points in (1_000, 100_000):
        with ProcessPoolExecutor(max_workers=workers) as pool:
            runs = np.array(list(pool.map(run_dense, [(points, pose, time_limit) for pose in range(poses)])))
        medians[points] = (np.median(runs[:issue_poses, 0]), *np.median(runs, axis=0))
        rows.append(f"| {points:,} | {np.isfinite(runs[:, 0]).mean():.0%} | {medians[points][0]:.3f} s | "
                    f"{medians[points][1]:.3f} s | {medians[points][2]:.3f} s |")
    ratio = np.array(medians[100_000]) / np.array(medians[1_000])
    rows += ["", f"100,000 / 1,000 points: {ratio[0]:.2f}x planning time ({issue_poses} poses), {ratio[1]:.2f}x "
             f"({poses} poses), {ratio[2]:.2f}x plan() wall time ({poses} poses)."]
    return rows


def write_report(lines: list[str], out: Path) -> None:
    """Print a Markdown report and write it to `out` (the benchmarks' common ending).

    Args:
        lines: the report's lines, the first its title; :func:`provenance_line` goes under it.
        out: the Markdown file (its folder is created if missing).
    """
    report = "\n".join([lines[0], "", provenance_line(), *lines[1:]]) + "\n"
    print(report)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(report)


def summarise(times: np.ndarray, limit: float) -> dict[str, str]:
    """Success rates and quantiles of one variant; `times` holds inf for unsolved runs."""
    row = {}
    for threshold in THRESHOLDS_S:
        row[f"<= {threshold:g} s"] = f"{np.mean(times <= threshold):.0%}" if threshold <= limit else "n/a"
    for name, q in (("median", 50), ("p90", 90), ("p99", 99)):
        value = np.percentile(times, q, method="higher")
        row[name] = "inf" if np.isinf(value) else f"{value:.3f} s"
    return row


def main() -> None:
    # No stored grasp maps (slideplan.grasp_cache): a cold run starts empty whatever an earlier run left on
    # disk, and the other variants share a map within a worker process only (workers inherit this).
    os.environ["SLIDEPLAN_NO_CACHE"] = "1"
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=20, help="seeded initial poses per object")
    parser.add_argument("--time-limit", type=float, default=60.0, help="planning budget per run (s)")
    parser.add_argument("--workers", type=int, default=1, help="parallel runs (1 keeps timings clean)")
    parser.add_argument("--scenes", nargs="+", default=["square"], help="built-in scenes or scene files")
    parser.add_argument("--variants", nargs="+", default=[label for label, _, _ in VARIANTS if label != "slideplan hand"],
                        choices=[label for label, _, _ in VARIANTS], help="which variants to run")
    parser.add_argument("--peers", action="store_true", help="also compare with OMPL's constrained planning (first scene)")
    parser.add_argument("--dense", action="store_true", help="also time a 1,000- and a 100,000-point crescent")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks/plan_bench.md"))
    args = parser.parse_args()

    variants = [variant for variant in VARIANTS if variant[0] in args.variants]
    jobs = [(scene, label, planner, dz, name, pose, args.time_limit)
            for scene in args.scenes for label, planner, dz in variants for name in OBJECTS for pose in range(args.poses)]
    times: dict[tuple[str, str], list[float]] = {(scene, label): [] for scene in args.scenes for label, _, _ in variants}
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for scene, label, solved, seconds in pool.map(run_one, jobs):
            times[(scene, label)].append(seconds if solved else np.inf)

    header = ["scene", "variant", *[f"<= {t:g} s" for t in THRESHOLDS_S], "median", "p90", "p99"]
    lines = [
        "# Planning benchmark",
        "",
        f"{args.workers} run(s) at a time. Scenes "
        f"{', '.join(args.scenes)}; objects {', '.join(OBJECTS)}, {args.poses} seeded poses each "
        f"({len(OBJECTS) * args.poses} runs per scene and variant), budget {args.time_limit:g} s per run. "
        "Unsolved runs count as infinite time. Every solved plan of these scenes passes `slideplan.checks.verify` "
        "in the tests; this script times planning only. The runs of a worker process share the grasp map of a "
        "table and object thickness, as a program planning many objects does; \"grasp map cold\" empties it "
        "before every run, as a single `slideplan plan` starts.",
        "",
        "| " + " | ".join(header) + " |",
        "|" + "---|" * len(header),
    ]
    for (scene, label), values in times.items():
        row = summarise(np.array(values), args.time_limit)
        lines.append("| " + " | ".join([scene, label, *row.values()]) + " |")
    if args.peers:
        lines += peer_table(args.scenes[0], args.poses, args.time_limit, args.workers)
    if args.dense:
        lines += dense_table(40, args.time_limit, args.workers)
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
