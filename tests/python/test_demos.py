"""slideplan demos: episodes recorded as a LeRobotDataset v3.0. The checks of the request, the draw and the
folder run without MuJoCo or lerobot; the whole generations (marked lerobot) need the lerobot extra, which
`make test-lerobot` installs."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from slideplan.cli import app
from slideplan.demos import dataset as demos_dataset
from slideplan.demos.draw import draw, episode_seed
from slideplan.demos.frames import CameraSpec
from slideplan.demos.generate import REQUEST_FILE, Request, prepare
from slideplan.errors import InputError
from slideplan.world.objects import load_outline, place_outline
from slideplan.world.scenes import load_scene

runner = CliRunner()
DEMOS_DOC = Path(__file__).resolve().parents[2] / "docs" / "demos.md"


def bad_input(*args) -> str:
    result = runner.invoke(app, ["demos", *args])
    assert result.exit_code == 2, (result.exit_code, result.output, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("slideplan: error: "), result.stderr
    return lines[0]


@pytest.mark.parametrize("args, words", [
    (["--episodes", "0"], ["--episodes", "1..1000000", "got 0"]),
    (["--episodes", "1000001"], ["--episodes", "got 1000001"]),
    (["--episodes", "3", "--cameras", "wrist:64x64"], ["--cameras", "unknown camera 'wrist'"]),
    (["--episodes", "3", "--cameras", "front:64"], ["--cameras", "NAME:WxH"]),
    (["--episodes", "3", "--cameras", "front:8x8"], ["--cameras", "16..1024"]),
    (["--episodes", "3", "--setting", "windy"], ["--setting", "windy"]),
    (["--episodes", "3", "--keep", "some"], ["--keep", "success, all"]),
    (["--episodes", "3", "--objects", "nothing_like_it"], ["nothing_like_it"]),
])
def test_bad_options_are_one_line_naming_the_option(tmp_path, args, words):
    line = bad_input("--scene", "square", "--out", str(tmp_path / "d"), "--workers", "1", *args)
    for word in words:
        assert word in line, line


def test_an_unknown_scene_is_named(tmp_path):
    assert "no_such_scene" in bad_input("--scene", "no_such_scene", "--episodes", "2", "--out", str(tmp_path / "d"))


def test_a_folder_holding_a_dataset_or_other_files_is_refused(tmp_path):
    (tmp_path / "d" / "meta").mkdir(parents=True)
    (tmp_path / "d" / "meta" / "info.json").write_text("{}")
    assert "holds a dataset" in bad_input("--scene", "square", "--episodes", "2", "--out", str(tmp_path / "d"))
    (tmp_path / "e").mkdir()
    (tmp_path / "e" / "notes.txt").write_text("mine")
    line = bad_input("--scene", "square", "--episodes", "2", "--out", str(tmp_path / "e"))
    assert "--out" in line and "other files" in line


def test_a_generation_resumes_only_with_the_same_request(tmp_path):
    out = tmp_path / "d"
    prepare(Request(scene="square", episodes=4), out)
    prepare(Request(scene="square", episodes=4), out)  # the same request: resumed
    with pytest.raises(InputError, match="episodes, seed") as caught:
        prepare(Request(scene="square", episodes=5, seed=3), out)
    assert caught.value.field == "--out"
    assert json.loads((out / REQUEST_FILE).read_text())["phases"][0] == "slide"


def test_without_the_extra_the_command_says_how_to_install_it(tmp_path, monkeypatch):
    real = demos_dataset.importlib.util.find_spec
    monkeypatch.setattr(demos_dataset.importlib.util, "find_spec", lambda name, *args: None if name == "lerobot" else real(name, *args))
    line = bad_input("--scene", "square", "--episodes", "2", "--out", str(tmp_path / "d"), "--workers", "1")
    assert 'pip install "slideplan[lerobot]"' in line
    assert not (tmp_path / "d").exists()  # nothing written
    # the other options are checked first: a bad one is named, with or without the extra
    assert "no_such_scene" in bad_input("--scene", "no_such_scene", "--episodes", "2", "--out", str(tmp_path / "e"))


def test_a_second_generation_into_a_folder_being_written_is_refused_naming_the_lock(tmp_path, monkeypatch):
    """Two generations into one folder interleaved their episodes and merged a corrupt dataset: the second is
    refused while the first holds the folder's lock, and goes on once it is free (the lock dies with its
    process)."""
    import fcntl

    from slideplan.demos import generate as demos_generate

    monkeypatch.setattr(demos_generate, "require_lerobot", lambda: (lambda: None))  # the lock comes before lerobot's work
    out = tmp_path / "d"
    out.mkdir()
    with open(out / demos_generate.LOCK_FILE, "a") as first:  # as a running generation holds it
        fcntl.flock(first, fcntl.LOCK_EX | fcntl.LOCK_NB)
        line = bad_input("--scene", "square", "--episodes", "2", "--out", str(out), "--workers", "1")
        assert "--out" in line and "another slideplan demos is writing" in line and demos_generate.LOCK_FILE in line
        assert sorted(path.name for path in out.iterdir()) == [demos_generate.LOCK_FILE]  # nothing else written
    # Free again (the first finished, or was killed): the lock file alone does not make the folder another's.
    prepare(Request(scene="square", episodes=2), out)
    assert (out / REQUEST_FILE).exists()


def test_a_kept_episode_whose_dataset_is_not_whole_runs_again_rather_than_being_merged(tmp_path):
    """An episode committed without its data/ folder made the documented recovery (the same command again)
    fail asking the dataset hub for the missing files."""
    from slideplan.demos import generate as demos_generate

    out = tmp_path / "d"
    for index, files in enumerate((["meta/info.json", "data/chunk-000/file-000.parquet"], ["meta/info.json"], [])):
        folder = demos_generate.episode_dir(out, index)
        folder.mkdir(parents=True)
        for name in files:
            (folder / "dataset" / name).parent.mkdir(parents=True, exist_ok=True)
            (folder / "dataset" / name).write_text("")
        demos_generate.write_json_atomic(folder / "record.json", {"index": index, "kept": True})
    demos_generate.episode_dir(out, 3).mkdir()
    demos_generate.write_json_atomic(demos_generate.episode_dir(out, 3) / "record.json", {"index": 3, "kept": False})
    assert sorted(demos_generate.records(out)) == [0, 3]  # 1 (no data) and 2 (no dataset) run again
    (out / "meta").mkdir()
    demos_generate.write_json_atomic(out / "meta" / demos_generate.MERGED_FILE, {})
    assert sorted(demos_generate.records(out)) == [0, 1, 2, 3]  # merged whole: the episodes' own datasets are gone


def test_the_draw_is_the_seeds_and_lies_wholly_on_the_table():
    scene = load_scene("square")
    objects = ("crescent", "square", "triangle")
    drawn = [draw(scene, objects, "nominal", episode_seed(7, index)) for index in range(30)]
    assert drawn == [draw(scene, objects, "nominal", episode_seed(7, index)) for index in range(30)]
    assert len({d.object for d in drawn}) == 3 and len({d.pose for d in drawn}) == 30
    for d in drawn:
        outline, _, _ = load_outline(d.object)
        assert scene.table.polygon.buffer(-0.009).contains(place_outline(outline, d.pose))
    assert episode_seed(7, 1) != episode_seed(8, 1) and episode_seed(7, 1) != episode_seed(7, 2)



def test_a_broken_lerobot_install_is_named_once_the_episodes_are_done(monkeypatch):
    real_find, real_import = demos_dataset.importlib.util.find_spec, demos_dataset.importlib.import_module

    def broken(name, *args):
        if name.startswith("lerobot"):
            raise ImportError("libtorch_cpu.so: cannot open shared object file")
        return real_import(name, *args)

    monkeypatch.setattr(demos_dataset.importlib.util, "find_spec", lambda name, *args: object() if name == "lerobot" else real_find(name, *args))
    monkeypatch.setattr(demos_dataset.importlib, "import_module", broken)
    loaded = demos_dataset.require_lerobot()  # installed: no error yet (the import runs beside the episodes)
    with pytest.raises(InputError, match="libtorch_cpu.so") as caught:
        loaded()
    assert caught.value.field == "lerobot" and 'pip install "slideplan[lerobot]"' in str(caught.value)

@pytest.mark.physics
def test_the_front_camera_keeps_the_hand_and_the_object_in_view_through_the_grasp_and_the_lift():
    # Framed on the table alone, the hand left the frame as it closed on the overhang past the edge.
    import math

    from slideplan.demos.frames import PHASES, Frames
    from slideplan.demos.generate import front_points
    from slideplan.experiments.tasks import cached_scene
    from slideplan.sim.closed_loop import run

    scene = cached_scene("square")
    drawn = draw(scene, Request.objects, "nominal", episode_seed(5, 0))
    seen = []

    def observe(plan, built, runner, robot):
        frames = Frames(built, runner, robot, 10, (CameraSpec("front", 256, 256),), front_points(scene))
        model, data = built.model, built.data
        fingers = model.jnt_bodyid[model.actuator_trnid[built.gripper.actuators, 0]]
        hand = np.unique(np.append(fingers, model.body_parentid[fingers]))  # the fingers and the palm they hang on
        camera = frames._cameras[0][2]

        def after_step():
            before = len(frames.rows)
            frames.after_step()
            phase = PHASES[frames.rows[-1]["phase"]] if len(frames.rows) > before else None
            # The grasp, the lift and the hold, and the approach's last 10 cm down (it comes from clear above).
            if phase in ("grasp", "lift", "hold") or (phase == "approach" and
                                                      data.geom_xpos[built.pad_geom][2] < scene.table.height + 0.1):
                points = np.vstack([data.xpos[hand], data.geom_xpos[built.pad_geom], data.xpos[built.object_body]])
                seen.append(_pixels(camera, math.radians(model.vis.global_.fovy), points, 256, 256))
        return after_step

    report = run(scene, drawn.object, drawn.pose, seed=drawn.seed, closed=True, observe=observe)
    assert report.success and len(seen) > 20
    pixels = np.vstack(seen)
    assert (pixels >= 0).all() and (pixels < 256).all(), (pixels.min(axis=0), pixels.max(axis=0))


def _pixels(camera, fov_y: float, points: np.ndarray, width: int, height: int) -> np.ndarray:
    """Where a MuJoCo free camera (its look-at, distance, azimuth and elevation) images world points (u right, v down)."""
    import math

    azimuth, elevation = math.radians(camera.azimuth), math.radians(camera.elevation)
    forward = np.array([math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth), math.sin(elevation)])
    eye = np.asarray(camera.lookat) - camera.distance * forward
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    offsets = points - eye
    depth = offsets @ forward
    focal = (height / 2) / math.tan(fov_y / 2)
    return np.column_stack([width / 2 + focal * (offsets @ right) / depth, height / 2 - focal * (offsets @ up) / depth])


def test_camera_specs():
    assert CameraSpec.parse("front:256x128") == CameraSpec("front", 256, 128)  # width x height
    assert CameraSpec.parse("scene:64x64:depth") == CameraSpec("scene", 64, 64, depth=True)
    for bad in ("front:64x64:rgb", "front:64x64:depth:depth", "front:64"):
        with pytest.raises(InputError, match="NAME:WxH:depth"):
            CameraSpec.parse(bad)


# ---- whole generations: MuJoCo and the lerobot extra (marker lerobot: make test-lerobot) ----

def generate(out: Path, *extra: str, episodes: int = 3, workers: int = 2) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "slideplan.cli", "demos", "--scene", "square", "--episodes", str(episodes),
               "--out", str(out), "--workers", str(workers), "--seed", "5", *extra]
    return subprocess.run(command, capture_output=True, text=True, timeout=900, env={**os.environ, "MUJOCO_GL": "egl"})


def load(root: Path):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    return LeRobotDataset("slideplan/demos", root=root)  # as a user loads it: torchcodec decodes (make install-lerobot)


def frames_of(root: Path):
    import pandas as pd

    return pd.concat([pd.read_parquet(path) for path in sorted((root / "data").rglob("*.parquet"))], ignore_index=True)


@pytest.mark.lerobot
def test_a_dataset_loads_iterates_and_is_the_same_for_the_same_seed(tmp_path, monkeypatch):
    import torch

    first = generate(tmp_path / "a", "--cameras", "front:64x64:depth")
    assert first.returncode == 0, first.stderr
    records = json.loads((tmp_path / "a" / "meta" / "slideplan_episodes.json").read_text())
    kept = records["episodes"]
    assert records["attempts"] == 3 and kept and all(episode["success"] for episode in kept)
    assert f"{len(kept)} kept" in first.stdout
    assert f"3/3 kept {len(kept)}, lost 0" in " ".join(first.stderr.split())  # the progress bar's last state
    dataset = load(tmp_path / "a")
    assert dataset.num_episodes == len(kept) and dataset.meta.stats["observation.state"]["mean"].shape == (14,)
    item = dataset[0]
    assert item["observation.images.front"].shape == (3, 64, 64) and item["action"].shape == (8,)
    # depth as grey levels over 0..depth_max_m: the table and arm nearer than the range's end, the void at its end
    depth = item["observation.images.front_depth"]
    assert depth.shape == (3, 64, 64) and float((depth[0] - depth[2]).abs().max()) <= 4 / 255
    assert 0.5 <= kept[0]["depth_max_m"]["front"] <= 5.0 and float(depth.min()) < 0.9 and float(depth.max()) > 0.98
    assert item["task"].startswith(f"slide the {kept[0]['object']}")
    batches = list(torch.utils.data.DataLoader(dataset, batch_size=32))
    assert sum(len(batch["index"]) for batch in batches) == dataset.num_frames
    # docs/demos.md's examples, as written, where the document's first command put the dataset.
    (tmp_path / "user" / "demos").mkdir(parents=True)
    shutil.copytree(tmp_path / "a", tmp_path / "user" / "demos" / "square")
    monkeypatch.chdir(tmp_path / "user")
    namespace: dict = {}
    for index, block in enumerate(re.findall(r"```python\n(.*?)```", DEMOS_DOC.read_text(), re.S)):
        exec(compile(block, f"demos.md example {index + 1}", "exec"), namespace)
    assert len(namespace["dataset"]) == dataset.num_frames and namespace["info"]["is_success"]
    table = frames_of(tmp_path / "a")
    phases = table["phase"].tolist()
    assert phases[0] == 0 and {4, 5, 6} <= set(phases)  # slide first; grasp, lift and hold recorded
    # Offline RL's columns: each episode done on its last frame, rewarded there as it succeeded (all kept did).
    for _, episode in table.groupby("episode_index"):
        last = episode["frame_index"] == episode["frame_index"].max()
        done, success, reward = (np.hstack(episode[column].to_numpy()) for column in ("next.done", "next.success", "next.reward"))
        assert done.tolist() == last.tolist() and success.tolist() == last.tolist()
        assert reward.tolist() == last.astype(float).tolist()
    second = generate(tmp_path / "b", "--cameras", "front:64x64:depth", workers=1)
    assert second.returncode == 0, second.stderr
    a, b = frames_of(tmp_path / "a"), frames_of(tmp_path / "b")
    for column in ("observation.state", "action", "ee_delta_action", "phase", "episode_index", "frame_index"):
        assert np.array_equal(np.stack(a[column]), np.stack(b[column])), column


@pytest.mark.lerobot
def test_a_generation_on_a_dask_cluster_is_the_local_pools(tmp_path, monkeypatch):
    from distributed import LocalCluster

    monkeypatch.setenv("MUJOCO_GL", "egl")  # the cluster's worker processes inherit it
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None,
                      local_directory=str(tmp_path / "dask")) as cluster:
        command = [sys.executable, "-m", "slideplan.cli", "demos", "--scene", "square", "--episodes", "2",
                   "--out", str(tmp_path / "dask-run"), "--scheduler", cluster.scheduler_address, "--seed", "5"]
        on_cluster = subprocess.run(command, capture_output=True, text=True, timeout=900)
    assert on_cluster.returncode == 0, on_cluster.stderr
    assert f"on Dask scheduler {cluster.scheduler_address}" in on_cluster.stdout
    local = generate(tmp_path / "local", episodes=2, workers=1)
    assert local.returncode == 0, local.stderr
    a, b = frames_of(tmp_path / "dask-run"), frames_of(tmp_path / "local")
    assert len(a) > 0
    for column in ("observation.state", "action", "episode_index", "frame_index"):
        assert np.array_equal(np.stack(a[column]), np.stack(b[column])), column


@pytest.mark.lerobot
def test_a_killed_worker_loses_no_episode_and_a_rerun_changes_nothing(tmp_path):
    out = tmp_path / "d"
    command = [sys.executable, "-m", "slideplan.cli", "demos", "--scene", "square", "--episodes", "4", "--out", str(out),
               "--workers", "1", "--seed", "9", "--keep", "all"]
    driver = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env={**os.environ, "MUJOCO_GL": "egl"})
    deadline = time.monotonic() + 600
    while not list(out.glob("episodes/*/record.json")) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert list(out.glob("episodes/*/record.json")), "no episode finished"
    children = Path(f"/proc/{driver.pid}/task/{driver.pid}/children").read_text().split()
    workers = [int(pid) for pid in children if "spawn" in Path(f"/proc/{pid}/cmdline").read_text()]
    assert workers, children
    os.kill(workers[0], signal.SIGKILL)  # mid-episode: the next one had started
    stdout, stderr = driver.communicate(timeout=900)
    # The episodes its pool failed ran again in a fresh pool: none lost, all merged.
    assert driver.returncode == 0 and "4 kept (100%), 0 lost" in stdout, stdout + stderr
    assert len(list(out.glob("episodes/*/record.json"))) == 4
    assert not list(out.glob("episodes/*/dataset")), "the merged episodes' own datasets are removed"
    merged = (out / "meta" / "slideplan_episodes.json").read_text()
    rerun = subprocess.run(command, capture_output=True, text=True, timeout=900, env={**os.environ, "MUJOCO_GL": "egl"})
    assert rerun.returncode == 0, rerun.stderr
    assert (out / "meta" / "slideplan_episodes.json").read_text() == merged  # done: nothing run or merged again
    records = json.loads(merged)["episodes"]
    assert [r["index"] for r in records] == [0, 1, 2, 3]  # --keep all: every attempt, once each
    dataset = load(out)
    assert dataset.num_episodes == 4
    frames = frames_of(out)
    assert sorted(set(frames["episode_index"])) == [0, 1, 2, 3]
    for index, record in enumerate(records):
        assert (frames["episode_index"] == index).sum() == record["frames"]  # whole episodes, none twice


@pytest.mark.lerobot
def test_an_so101_generation_is_written_in_lerobots_so101_convention(tmp_path):
    out = tmp_path / "so101"
    command = [sys.executable, "-m", "slideplan.cli", "demos", "--scene", "so101_square", "--episodes", "1", "--out", str(out),
               "--workers", "1", "--seed", "2", "--keep", "all"]
    # Its own cache: the arm's convex parts would join the ones test_execute counts in the session's.
    environment = {**os.environ, "MUJOCO_GL": "egl", "SLIDEPLAN_CACHE_DIR": str(tmp_path / "cache")}
    done = subprocess.run(command, capture_output=True, text=True, timeout=900, env=environment)
    assert done.returncode == 0, done.stderr
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["robot_type"] == "so101_follower"
    assert info["features"]["observation.state"]["names"][:6] == [
        "shoulder_pan.pos", "shoulder_lift.pos", "elbow_flex.pos", "wrist_flex.pos", "wrist_roll.pos", "gripper.pos"]
    record = json.loads((out / "meta" / "slideplan_episodes.json").read_text())["episodes"][0]
    assert record["frames"] > 0 and record["failed_stage"] != "plan", record  # perceived and planned on its small table
    state, action = (np.stack(frames_of(out)[column]) for column in ("observation.state", "action"))
    assert np.abs(state[:, :5]).max() > 10.0  # degrees: in radians no joint of the arm reaches 10
    for gripper in (state[:, 5], action[:, 5]):  # 0..100 over the joint's range (to float rounding at its ends)
        assert -1e-6 <= gripper.min() and gripper.max() <= 100.0 + 1e-6 and np.ptp(gripper) > 10.0


def test_lerobots_so101_convention_names_and_units():
    from types import SimpleNamespace

    from slideplan.demos.dataset import convention_for, features

    so101 = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"]
    convention = convention_for(so101, ["gripper"])
    assert convention is not None and convention.robot_type == "so101_follower"
    assert convention_for(so101[:4], ["gripper"]) is None and convention_for(so101, []) is None
    names = features(so101, (), convention)["observation.state"]["names"]
    assert names[:6] == ["shoulder_pan.pos", "shoulder_lift.pos", "elbow_flex.pos", "wrist_flex.pos", "wrist_roll.pos",
                         "gripper.pos"]
    # the hand open at 0.6 rad and closed at -0.12 rad of a joint ranging -0.2..1.8 rad
    gripper = SimpleNamespace(opened=np.array([0.6]), closed=np.array([-0.12]), limits=np.array([[-0.2, 1.8]]))
    row = {"state": np.array([1.0, 0, 0, 0, -0.5, 0.0, *np.zeros(6)]), "action": np.array([1.0, 0, 0, 0, -0.5, 1.0]),
           "ee_delta": np.zeros(7)}
    convention.apply([row], gripper)
    assert row["state"][0] == pytest.approx(57.2958, abs=1e-3) and row["action"][4] == pytest.approx(-28.6479, abs=1e-3)
    assert row["state"][5] == pytest.approx(40.0) and row["action"][5] == pytest.approx(4.0)  # open 40 %, closed 4 %
    assert row["ee_delta"][-1] == pytest.approx(4.0)
    assert convention_for(["j1", "j2"], ["gripper"]) is None  # other arms keep their URDF names


@pytest.mark.lerobot
def test_an_episode_written_without_lerobots_image_embedding_has_the_same_parquet(tmp_path, monkeypatch):
    import contextlib

    import pyarrow.parquet as pq

    from slideplan.demos.dataset import features, write_episode

    rng = np.random.default_rng(3)
    rows = [{"state": rng.normal(size=14), "action": rng.normal(size=8), "ee_delta": rng.normal(size=7), "phase": index // 10}
            for index in range(40)]
    feature_set = features([f"j{index}" for index in range(7)], ())
    write_episode(tmp_path / "skipped", 10, feature_set, "arm", "slide", rows, True)
    monkeypatch.setattr(demos_dataset, "_without_image_embedding", lambda _features: contextlib.nullcontext())
    write_episode(tmp_path / "embedded", 10, feature_set, "arm", "slide", rows, True)
    tables = [pq.read_table(next((tmp_path / name / "data").rglob("*.parquet"))) for name in ("skipped", "embedded")]
    assert tables[0].num_rows == 40 and tables[0].equals(tables[1])
    # the features lerobot records there too; the map adds only its cache's fingerprint (random per map)
    recorded = [json.loads(table.schema.metadata[b"huggingface"]) for table in tables]
    assert recorded[0]["info"] == recorded[1]["info"] and recorded[1].keys() - recorded[0].keys() == {"fingerprint"}
