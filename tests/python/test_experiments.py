"""Experiments: specs, local and Dask runs, resume, statistics, plots and the CLI.

One quick fig11 run (2 objects x 2 poses x 5 settings, 3 s limit) on a 2-process local
pool is shared by the tests that need real results; the Dask test runs the same tasks on a
LocalCluster and must give the same rows (planning is seeded and deterministic).
"""

import subprocess
import time
from pathlib import Path
import sys

import numpy as np
import pandas as pd
import pytest

from slideplan import InputError
from scipy.stats import binomtest
from typer.testing import CliRunner

from slideplan.cli import app
from slideplan.world.scenes import load_scene
from slideplan.experiments import (
    ROW_SCHEMA,
    DaskExecutor,
    LocalPoolExecutor,
    build_spec,
    initial_pose_and_seed,
    load_results,
    part_path,
    run_experiment,
    success_rate_curve,
    wilson_interval,
)
from slideplan.experiments.tasks import cached_scene, scaled_outline
from slideplan.world.objects import place_outline
from slideplan.experiments.plots import (
    SHADED_MIN_RUNS,
    draw_interval,
    plot_planning_time_by_geometry,
    plot_planning_time_vs_n_star,
    plot_results,
    plot_success_rate_vs_time,
)

TIME_LIMIT_S = 3.0
CLI_ARGS = ["experiment", "fig11", "--quick", "--time-limit", str(TIME_LIMIT_S), "--seed", "0", "--workers", "2"]
runner = CliRunner()


@pytest.fixture(scope="module")
def quick_spec():
    return build_spec("fig11", quick=True, time_limit_s=TIME_LIMIT_S, seed=0)


@pytest.fixture(scope="module")
def local_run(quick_spec, tmp_path_factory):
    out = tmp_path_factory.mktemp("local")
    summary = run_experiment(quick_spec, out, LocalPoolExecutor(workers=2), progress=False)
    return out, summary


def test_quick_run_on_the_local_pool_writes_one_verified_row_per_task(quick_spec, local_run):
    out, summary = local_run
    results = load_results(out)
    assert summary.executed == len(quick_spec.tasks) == 20 and summary.lost == 0 and summary.errors == 0
    assert list(results.columns) == ROW_SCHEMA.names
    assert sorted(results["task_id"]) == sorted(task.task_id for task in quick_spec.tasks)
    assert results["error"].isna().all()
    solved = results[results["solved"]]
    assert len(solved) >= 10, results[["planner", "reconfiguration_range_m", "status"]]
    assert solved["verified"].eq(True).all() and (solved["planning_time_s"] <= TIME_LIMIT_S).all()
    assert (solved["iterations"] > 0).all() and (solved["overhang_m"] > 0).all()
    assert set(zip(results["planner"], results["reconfiguration_range_m"])) == {
        ("slideplan", 0.0), ("slideplan", 0.005), ("slideplan", 0.02), ("cbirrt", 0.02), ("cbirrt2", 0.02)}


def assert_same_plans(rows, reference):
    """The same plans where the reference solved far inside the time limit: whether a run near its limit
    solves depends on the wall clock (a busy machine), not on the executor, so those are not compared."""
    fast = reference["solved"] & (reference["planning_time_s"] < TIME_LIMIT_S / 3)
    assert fast.sum() >= 10, reference[["solved", "planning_time_s"]]
    assert rows.loc[fast, "solved"].all()
    for column in ("iterations", "overhang_m"):
        assert (rows.loc[fast, column] == reference.loc[fast, column]).all(), column


def test_dask_cluster_gives_the_same_rows_as_the_local_pool(quick_spec, local_run, tmp_path):
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None, local_directory=str(tmp_path / "dask")) as cluster:
        summary = run_experiment(quick_spec, tmp_path, DaskExecutor(cluster.scheduler_address), progress=False)
    assert summary.executed == len(quick_spec.tasks) and summary.lost == 0
    local = load_results(local_run[0]).set_index("task_id").sort_index()
    dask = load_results(tmp_path).set_index("task_id").sort_index()
    assert list(dask.index) == list(local.index)
    assert_same_plans(dask, local)


def test_local_threads_give_the_same_rows_as_local_processes(quick_spec, local_run, tmp_path):
    summary = run_experiment(quick_spec, tmp_path, LocalPoolExecutor(workers=2, threads=True), progress=False)
    assert summary.executed == len(quick_spec.tasks) and summary.lost == 0 and summary.errors == 0
    local = load_results(local_run[0]).set_index("task_id").sort_index()
    threaded = load_results(tmp_path).set_index("task_id").sort_index()
    assert_same_plans(threaded, local)
    assert threaded.loc[threaded["solved"], "verified"].eq(True).all()


def test_rerun_runs_nothing_and_a_deleted_part_runs_again(quick_spec, local_run):
    out, _ = local_run
    first = runner.invoke(app, [*CLI_ARGS, "--out", str(out)])
    assert first.exit_code == 0, first.output
    assert "0 run (0 solved, 0 raised), 20 already done, 0 lost" in first.output
    task = quick_spec.tasks[7]
    part = part_path(out, task.task_id)
    before = pd.read_parquet(part)
    part.unlink()
    summary = run_experiment(quick_spec, out, LocalPoolExecutor(workers=1), progress=False)
    assert (summary.executed, summary.skipped) == (1, len(quick_spec.tasks) - 1)
    after = pd.read_parquet(part)
    assert after.loc[0, "task_id"] == task.task_id and after.loc[0, "solved"] == before.loc[0, "solved"]


def test_task_ids_are_stable_across_processes(quick_spec):
    code = ("from slideplan.experiments import build_spec; "
            f"print(' '.join(t.task_id for t in build_spec('fig11', quick=True, time_limit_s={TIME_LIMIT_S}).tasks))")
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert other == [task.task_id for task in quick_spec.tasks]
    assert len(set(other)) == len(other)


def test_task_id_changes_with_any_field(quick_spec):
    import dataclasses

    task = quick_spec.tasks[0]
    assert dataclasses.replace(task, seed=task.seed + 1).task_id != task.task_id
    assert dataclasses.replace(task, time_limit_s=4.0).task_id != task.task_id
    assert dataclasses.replace(task, n_star=10.0).task_id != task.task_id


@pytest.mark.parametrize("scene, object_name, scale", [("round", "crescent", 1.0), ("triangle", "irregular", 0.5),
                                                       ("long", "square", 1.0)])
def test_initial_poses_lie_on_the_table_and_are_reproducible(scene, object_name, scale):
    table = cached_scene(scene).table.polygon
    outline, _ = scaled_outline(object_name, scale)
    poses = [initial_pose_and_seed(scene, object_name, scale, index, 3) for index in range(20)]
    for pose, _ in poses:
        assert table.contains(place_outline(outline, pose))
    initial_pose_and_seed.cache_clear()
    assert [initial_pose_and_seed(scene, object_name, scale, index, 3) for index in range(20)] == poses
    assert len({pose for pose, _ in poses}) == 20  # independent draws, not one pose repeated
    assert initial_pose_and_seed(scene, object_name, scale, 0, 4)[0] != poses[0][0]  # the seed matters


def test_fig11_and_fig12_share_poses_and_the_paper_sizes():
    assert len(build_spec("fig10").tasks) == 5 * 4 * 50 * 2
    fig11, fig12 = build_spec("fig11"), build_spec("fig12")
    assert len(fig11.tasks) == 5 * 100 * 5 and len(fig12.tasks) == 5 * 100 * 5
    assert {(t.object, t.pose_index, t.x, t.seed) for t in fig11.tasks} == {(t.object, t.pose_index, t.x, t.seed) for t in fig12.tasks}
    assert sorted({t.n_star for t in fig12.tasks}) == [1, 10, 100, 1000, 10000]
    assert all(t.time_limit_s == 60 for t in fig11.tasks)


def test_a_planner_filter_keeps_exactly_that_planners_tasks_with_their_ids():
    whole = build_spec("fig11", poses=2)
    ours = build_spec("fig11", poses=2, planners=("slideplan",))
    assert {task.planner for task in ours.tasks} == {"slideplan"}
    assert [task.task_id for task in ours.tasks] == [task.task_id for task in whole.tasks if task.planner == "slideplan"]
    assert len(ours.tasks) < len(whole.tasks)


def test_a_table_filter_keeps_exactly_that_tables_tasks_and_names_a_table_the_figure_lacks():
    whole = build_spec("fig10", poses=2)
    long = build_spec("fig10", poses=2, scenes=("long", "round"))
    assert {task.scene for task in long.tasks} == {"long", "round"}
    assert [task.task_id for task in long.tasks] == [task.task_id for task in whole.tasks if task.scene in ("long", "round")]
    with pytest.raises(InputError, match="unknown scene.*'kitchen'") as raised:
        build_spec("fig10", poses=2, scenes=("kitchen",))
    assert raised.value.field == "scene"


def test_fewer_poses_are_a_prefix_of_the_full_figure():
    reduced, full = build_spec("fig11", poses=3), build_spec("fig11")
    assert len(reduced.tasks) == 5 * 3 * 5
    assert {t.task_id for t in reduced.tasks} <= {t.task_id for t in full.tasks}  # a full run resumes on top
    for bad in (0, 1001, 10**9):  # a billion poses: refused at once, not minutes of silent set-up
        with pytest.raises(InputError, match="from 1 to 1000") as raised:
            build_spec("fig11", poses=bad)
        assert raised.value.field == "poses"


@pytest.mark.parametrize("k, n", [(0, 1), (1, 1), (0, 10), (10, 10), (3, 10), (1, 100), (57, 100), (999, 1000)])
@pytest.mark.parametrize("confidence", [0.95, 0.8])
def test_wilson_interval_matches_scipy(k, n, confidence):
    expected = binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    low, high = wilson_interval(k, n, confidence)
    assert low == pytest.approx(expected.low, abs=1e-9) and high == pytest.approx(expected.high, abs=1e-9)


def test_wilson_interval_rejects_impossible_counts():
    for k, n in [(1, 0), (-1, 5), (6, 5)]:
        with pytest.raises(ValueError):
            wilson_interval(k, n)


def fixture_results():
    """A small results table in the schema, not from a run: 3 settings x 2 objects x 2 scenes x 2 scales."""
    rng = np.random.default_rng(0)
    rows = []
    for experiment, planner, reconfiguration_range, n_star in [
        ("fig10", "slideplan", 0.02, 100.0), ("fig11", "slideplan", 0.0, 100.0), ("fig11", "slideplan", 0.02, 100.0),
        ("fig11", "cbirrt", 0.02, 100.0), ("fig12", "slideplan", 0.02, 1.0), ("fig12", "slideplan", 0.02, 100.0),
    ]:
        for index in range(16):
            solved = bool(rng.random() < 0.8)
            rows.append({name: None for name in ROW_SCHEMA.names} | {
                "task_id": f"{experiment}-{planner}-{reconfiguration_range}-{n_star}-{index}", "experiment": experiment,
                "scene": ("square", "round")[index % 2], "object": ("square", "crescent")[index // 2 % 2],
                "scale": (1.0, 0.5)[index // 4 % 2], "planner": planner, "n_star": n_star, "time_limit_s": 60.0,
                "reconfiguration_range_m": reconfiguration_range, "solved": solved,
                "status": "solved" if solved else "timeout",
                "planning_time_s": float(rng.uniform(0.01, 5)) if solved else 60.0,
            })
    return pd.DataFrame(rows)


@pytest.mark.parametrize("plot", [plot_planning_time_by_geometry, plot_success_rate_vs_time, plot_planning_time_vs_n_star])
def test_each_plot_writes_png_and_svg(plot, tmp_path):
    results = fixture_results()
    paths = plot(results, tmp_path, "figure")
    assert [path.name for path in paths] == ["figure.png", "figure.svg"]
    assert paths[0].read_bytes().startswith(b"\x89PNG") and paths[0].stat().st_size > 10_000
    assert "<svg" in paths[1].read_text()[:1000]


def test_plot_results_draws_the_figures_the_data_supports(tmp_path):
    results = fixture_results()
    assert {path.name for path in plot_results(results, tmp_path / "all")} == {
        f"fig1{digit}.{suffix}" for digit in "012" for suffix in ("png", "svg")}
    only_fig11 = results[results["experiment"] == "fig11"]
    assert {path.name for path in plot_results(only_fig11, tmp_path / "one")} == {"fig11.png", "fig11.svg"}


def test_success_curve_counts_runs_solved_within_the_budget():
    results = fixture_results().query("experiment == 'fig11' and planner == 'cbirrt'")
    curve = success_rate_curve(results, [0.0, 1.0, 60.0])
    solved_times = results.loc[results["solved"], "planning_time_s"]
    assert list(curve["successes"]) == [0, int((solved_times <= 1.0).sum()), len(solved_times)]
    assert (curve["low"] <= curve["rate"]).all() and (curve["rate"] <= curve["high"]).all()


def assert_bad_input(result, fragment):
    assert result.exit_code == 2, (result.exit_code, result.output)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("slideplan: error: ") and fragment in lines[0], result.stderr


@pytest.mark.parametrize("args, fragment", [
    (["experiment", "fig13"], "unknown figure 'fig13'"),
    (["experiment", "fig11", "--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "at most one of --workers and --scheduler"),
    (["experiment", "fig11", "--time-limit", "0"], "--time-limit: must be > 0"),
    (["experiment", "fig11", "--time-limit", "-2"], "--time-limit: must be > 0"),
    (["experiment", "fig11", "--workers", "0"], "--workers: must be >= 1"),
    (["experiment", "fig11", "--planner", "rrt"], "--planner: unknown planner(s) ['rrt']"),
    (["experiment", "fig10", "--planner", "cbirrt"], "--planner: fig10 has no tasks of cbirrt"),
])
def test_experiment_bad_input_exits_2(args, fragment, tmp_path):
    assert_bad_input(runner.invoke(app, [*args, "--out", str(tmp_path)]), fragment)
    assert not (tmp_path / "results").exists()


def test_plot_bad_input_exits_2(tmp_path):
    assert_bad_input(runner.invoke(app, ["plot", str(tmp_path / "missing"), "--out", str(tmp_path)]), "no such file")
    assert_bad_input(runner.invoke(app, ["plot", str(tmp_path), "--out", str(tmp_path)]), "no planning results")


def test_tasks_plan_with_the_hand_parameters_and_the_given_params():
    default, paper = build_spec("execution", poses=1), build_spec("execution", poses=1, params={"grasp_standoff": 0.0})
    scene_standoff = load_scene(default.tasks[0].scene).hand.params["grasp_standoff"]
    assert default.tasks[0].planner_config().grasp_standoff == scene_standoff > 0
    assert paper.tasks[0].planner_config().grasp_standoff == 0.0
    # Execution presses with the hand's depth band (a force there); the paper's figures keep the paper's.
    hand = load_scene(default.tasks[0].scene).hand.params
    assert (default.tasks[0].dz_min, default.tasks[0].dz_max) == (hand["dz_min"], hand["dz_max"]) != (0.005, 0.025)
    assert {t.dz_min for t in build_spec("fig10", poses=1).tasks} == {0.005}
    assert {task.task_id for task in default.tasks}.isdisjoint(task.task_id for task in paper.tasks)
    with pytest.raises(InputError) as error:
        build_spec("execution", poses=1, params={"no_such_parameter": 1})
    assert "no_such_parameter" in str(error.value)


@pytest.mark.parametrize("runs, fills, dotted", [(4, 0, 2), (SHADED_MIN_RUNS, 1, 0)])
def test_a_small_experiments_intervals_are_dotted_lines_not_shades(runs, fills, dotted):
    from matplotlib.figure import Figure

    curve = pd.DataFrame({"time_s": [0.01, 0.1, 1.0], "low": [0.1, 0.3, 0.5], "high": [0.6, 0.8, 0.95]})
    axes = Figure().add_subplot()
    draw_interval(axes, curve, "tab:blue", runs)
    assert (len(axes.collections), len([line for line in axes.lines if line.get_linestyle() == ":"])) == (fills, dotted)


DRIVER = """
import sys, time
from slideplan.experiments import LocalPoolExecutor
for _ in LocalPoolExecutor(workers=2).imap_unordered(time.sleep, [600, 600]):
    pass
"""


def _children(pid: int) -> set[int]:
    children = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            children.add(int(stat.parent.name))
    return children


def test_workers_exit_when_the_driver_is_killed():
    import contextlib
    import os
    import signal

    driver = subprocess.Popen([sys.executable, "-c", DRIVER])
    try:
        workers = set()
        for _ in range(300):  # the pool's processes appear (spawned: they import slideplan first)
            workers = _children(driver.pid)
            if len(workers) >= 2:
                break
            time.sleep(0.2)
        assert len(workers) >= 2, workers
        time.sleep(2.0)  # the workers are inside their 600 s tasks
        driver.send_signal(signal.SIGKILL)
        driver.wait(timeout=10)
        alive = workers
        for _ in range(150):  # bounded by polls: a worker looks for its parent every second
            alive = {pid for pid in alive if _running(pid)}
            if not alive:
                break
            time.sleep(0.2)
        assert not alive, f"orphaned workers still running: {alive}"
    finally:
        driver.kill()
        for pid in workers:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)


def _running(pid: int) -> bool:
    """Whether process ``pid`` exists and is not a zombie."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


CRASHER = """
import os, pathlib, time


def work(task):
    # Task 1 kills its worker: once (MARK written first), or every time.
    mark = pathlib.Path(MARK)
    if task == 1 and (ALWAYS or not mark.exists()):
        mark.touch()
        os._exit(1)
    time.sleep(0.2)
    return task
"""


@pytest.mark.parametrize("always", [False, True])
def test_a_killed_worker_loses_no_other_task_and_a_task_that_kills_each_worker_is_lost_alone(tmp_path, always):
    # A dead worker breaks its pool, which fails every unfinished task, its neighbours' too: one killed demos
    # worker lost all four episodes of a run.
    import importlib
    from concurrent.futures.process import BrokenProcessPool

    (tmp_path / "crasher.py").write_text(CRASHER.replace("MARK", repr(str(tmp_path / "mark"))).replace("ALWAYS", str(always)))
    sys.path.insert(0, str(tmp_path))
    try:
        crasher = importlib.import_module("crasher")
        outcomes = dict(LocalPoolExecutor(workers=2).imap_unordered(crasher.work, [0, 1, 2, 3]))
    finally:
        sys.path.remove(str(tmp_path))
        sys.modules.pop("crasher", None)
    assert sorted(outcomes) == [0, 1, 2, 3]
    assert all(outcomes[task] == task for task in (0, 2, 3))  # its neighbours ran again, to the end
    if always:  # run again alone, it killed its worker again: lost, alone
        assert isinstance(outcomes[1], BrokenProcessPool)
    else:
        assert outcomes[1] == 1
