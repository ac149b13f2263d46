"""Plans are independent (docs/design.md 9): plans run in threads of one process, sharing the cached robot
model (and its collision geometry: the Z1's hand meshes as BVHs of their triangles), give exactly what the
same calls give alone, and every one passes the verifier."""

import threading

import numpy as np
import pytest

from slideplan import PlannerConfig, load_object, load_scene, plan, verify
from slideplan.world.objects import load_outline, sample_pose_on_table

OBJECTS = ["square", "circle", "crescent", "triangle"]
RUNS = 5


def _object(scene, name: str, pose_seed: int):
    outline, _, _ = load_outline(name)
    pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(pose_seed))
    return load_object(name, table_height=scene.table.height, pose=pose)


def _same(first, second) -> bool:
    return (
        first.status == second.status
        and np.array_equal(first.trajectory, second.trajectory)
        and np.array_equal(first.grasp["approach"], second.grasp["approach"])
        and first.object_motion == second.object_motion
    )


@pytest.mark.parametrize("scene_name", ["square", "z1_square", "panda_square"])
def test_four_threads_give_the_sequential_plans_and_every_plan_verifies(scene_name):
    scene = load_scene(scene_name)
    objects = {name: _object(scene, name, index) for index, name in enumerate(OBJECTS)}
    configs = [PlannerConfig.for_scene(scene, seed=7 + run, time_limit_s=30.0) for run in range(RUNS)]
    sequential = {(name, run): plan(scene, objects[name], configs[run]) for name in OBJECTS for run in range(RUNS)}

    threaded, errors = {}, []

    def worker(name: str) -> None:
        try:
            for run in range(RUNS):
                threaded[(name, run)] = plan(scene, objects[name], configs[run])
        except Exception as error:  # surfaced by the assertion below, not lost in the thread
            errors.append(error)

    threads = [threading.Thread(target=worker, args=(name,)) for name in OBJECTS]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors, errors
    differing = [key for key in sequential if not _same(sequential[key], threaded[key])]
    assert not differing, f"{len(differing)} of {len(sequential)} threaded plans differ from their twins: {differing}"
    for key, result in threaded.items():
        assert result.solved, key
        verification = verify(result)
        assert verification.ok, (key, verification.violations[:5])


def _plan_json_without_clock(scene, obj, seed: int) -> dict:
    import json

    result = plan(scene, obj, PlannerConfig(seed=seed, time_limit_s=60.0))
    data = json.loads(result.to_json())
    del data["planning_time_s"], data["stats"]["precompute_time"], data["stats"]["setup_time"]  # clock readings
    return data


def test_twenty_plans_are_identical_with_both_cores_busy():
    # Every budget inside a plan is a count: a loaded machine is slower, never different.
    import multiprocessing

    tasks = []
    for table in ("square", "round", "triangle", "long"):
        scene = load_scene(table)
        for k, name in enumerate(["square", "circle", "triangle", "crescent", "irregular"]):
            tasks.append((scene, _object(scene, name, pose_seed=100 + k), k))
    alone = [_plan_json_without_clock(*task) for task in tasks]
    assert sum(data["status"] == "solved" for data in alone) >= 18
    busy = [multiprocessing.get_context("spawn").Process(target=_spin, daemon=True) for _ in range(2)]
    for process in busy:
        process.start()
    try:
        loaded = [_plan_json_without_clock(*task) for task in tasks]
    finally:
        for process in busy:
            process.kill()
    for (scene, obj, seed), first, second in zip(tasks, alone, loaded):
        assert first == second, (scene.name if hasattr(scene, "name") else scene, seed)


def _spin() -> None:
    while True:
        pass
