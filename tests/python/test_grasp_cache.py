"""The grasp map stored on disk: warm in a new process, the same plans, a new file for any changed input,
unusable files ignored, concurrent writers never leave a partial file."""

import os
import shutil
import subprocess
import sys

import numpy as np
import pytest
from typer.testing import CliRunner

from slideplan import PlannerConfig, load_object, load_scene, plan
from slideplan import grasp_cache
from slideplan.cli import app
from slideplan.plan.robot import robot_description
from slideplan.plan.planner import _grasp_map_and_file, clear_grasp_map_cache

POSE = (0.55, -0.08, 0.4)


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv(grasp_cache.CACHE_DIR_ENV, str(tmp_path / "cache"))
    monkeypatch.setenv(grasp_cache.NO_CACHE_ENV, "0")  # on (and restored after a test that turns it off)
    clear_grasp_map_cache()
    yield tmp_path / "cache" / "grasp-maps"
    clear_grasp_map_cache()


def square_task(name="crescent"):
    scene = load_scene("square")
    return scene, load_object(name, table_height=scene.table.height, pose=POSE)


def test_a_stored_map_starts_warm_and_gives_the_plan_a_fresh_map_gives(store, monkeypatch):
    scene, obj = square_task()
    config = PlannerConfig.for_scene(scene, seed=1, time_limit_s=30.0)
    cold = plan(scene, obj, config)
    files = list(store.glob("*.npz"))
    assert cold.solved and len(files) == 1
    clear_grasp_map_cache()  # as a new process
    core_map, path = _grasp_map_and_file(scene, obj, config)
    assert path == files[0] and core_map.probed > 0  # answers read back before any plan
    warm = plan(scene, obj, config)
    np.testing.assert_array_equal(warm.trajectory, cold.trajectory)
    np.testing.assert_array_equal(warm.grasp["config"], cold.grasp["config"])
    # And with no cache at all.
    monkeypatch.setenv(grasp_cache.NO_CACHE_ENV, "1")
    clear_grasp_map_cache()
    assert _grasp_map_and_file(scene, obj, config)[0].probed == 0
    np.testing.assert_array_equal(plan(scene, obj, config).trajectory, cold.trajectory)


def test_the_second_process_reads_what_the_first_stored(store):
    code = ("from slideplan import PlannerConfig, load_object, load_scene, plan; "
            "from slideplan.plan.planner import grasp_map; "
            "s = load_scene('square'); o = load_object('crescent', table_height=s.table.height, pose=(0.55, -0.08, 0.4)); "
            "c = PlannerConfig.for_scene(s, seed=1); print(grasp_map(s, o, c).probed); r = plan(s, o, c); "
            "print(r.trajectory.sum())")
    env = {**os.environ, grasp_cache.CACHE_DIR_ENV: str(store.parent)}
    first, second = (subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout.split()
                     for _ in range(2))
    assert int(first[0]) == 0 and int(second[0]) > 0
    assert first[1] == second[1]


def test_every_input_of_a_probe_names_another_file(store, tmp_path):
    scene, obj = square_task()
    robot = robot_description(scene)
    base = dict(vertices=((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)), height=0.7, thickness=0.003,
                params=(0.03, 0.02, 0.05, True, True))

    def path(robot=robot, **changes):
        return grasp_cache.map_path(robot, **{**base, **changes})

    assert path() == path() and path().parent == store
    changed = [path(vertices=((0.0, 0.0), (1.0, 0.0), (0.0, 1.1))), path(height=0.71), path(thickness=0.004),
               path(params=(0.03, 0.02, 0.05, True, False)), path(params=(0.03, 0.025, 0.05, True, True))]
    # The URDF's bytes, not its path: a copy names the same file, an edited joint another one.
    copy = tmp_path / "robot.urdf"
    shutil.copy(robot["urdf"], copy)
    assert path(robot={**robot, "urdf": str(copy)}) == path()
    copy.write_text(copy.read_text().replace("<joint", "<!-- edited --><joint", 1))
    changed.append(path(robot={**robot, "urdf": str(copy)}))
    changed.append(path(robot={**robot, "base_pose": np.eye(4)}))
    changed.append(path(robot={**robot, "grasp_link": "other"}))
    assert len({path(), *changed}) == len(changed) + 1


def test_an_unusable_stored_file_is_probed_anew_and_replaced(store):
    scene, obj = square_task()
    config = PlannerConfig.for_scene(scene, seed=1, time_limit_s=30.0)
    reference = plan(scene, obj, config)
    stored = next(store.glob("*.npz"))
    for content in (b"not a zip file", None):
        if content is None:  # well-formed, but another robot's: 3 joints
            np.savez(stored, edges=np.array([0]), cells=np.array([0]), reachable=np.array([True]), grasps=np.zeros((1, 3)))
        else:
            stored.write_bytes(content)
        clear_grasp_map_cache()
        assert _grasp_map_and_file(scene, obj, config)[0].probed == 0
        again = plan(scene, obj, config)
        np.testing.assert_array_equal(again.trajectory, reference.trajectory)
        with np.load(stored) as data:
            assert data["grasps"].shape[1] == len(reference.joint_names) and data["reachable"].any()


def test_concurrent_processes_leave_a_whole_file(store):
    code = ("import sys; from slideplan import PlannerConfig, load_object, load_scene, plan; "
            "s = load_scene('square'); "
            "[plan(s, load_object('crescent', table_height=s.table.height, pose=(0.55, -0.08, 0.4)), "
            "PlannerConfig.for_scene(s, seed=i)) for i in range(int(sys.argv[1]), int(sys.argv[1]) + 3)]")
    env = {**os.environ, grasp_cache.CACHE_DIR_ENV: str(store.parent)}
    workers = [subprocess.Popen([sys.executable, "-c", code, str(3 * k)], env=env) for k in range(3)]
    assert [worker.wait() for worker in workers] == [0, 0, 0]
    files = list(store.iterdir())
    assert len(files) == 1 and files[0].suffix == ".npz"  # no temporary file left behind
    with np.load(files[0]) as data:
        assert len(data["edges"]) == len(data["grasps"]) > 0


def test_cli_no_cache_writes_nothing(store, tmp_path, monkeypatch):
    args = ["plan", "--scene", "square", "--object", "crescent", "--pose", *map(str, POSE), "--json", str(tmp_path / "p.json")]
    result = CliRunner().invoke(app, [*args, "--no-cache"])
    assert result.exit_code == 0, result.output
    assert not store.exists() or not any(store.iterdir())
    assert os.environ[grasp_cache.NO_CACHE_ENV] == "1"  # the flag sets it for the (CLI) process
    monkeypatch.setenv(grasp_cache.NO_CACHE_ENV, "0")
    clear_grasp_map_cache()
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert len(list(store.glob("*.npz"))) == 1
