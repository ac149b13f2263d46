"""Episodes as LeRobotDataset v3.0, through the ``lerobot`` package's own API (the optional extra
``slideplan[lerobot]``): each episode is written as a dataset of its own (so a worker killed mid-episode
loses that episode only, and a stopped generation resumes), then all are merged with lerobot's
``aggregate_datasets``."""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import importlib.util
import io
import json
import math
import os
import shutil
import threading
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..paths import data_dir
from .frames import EE_ACTION_NAMES, CameraSpec, action_names, state_names

REPO_ID = "slideplan/demos"  # the datasets' name; they live under the output folder, nothing is uploaded
EXTRA = 'lerobot (pip install "slideplan[lerobot]": the lerobot 0.4 line, with torch)'


def _quiet() -> None:
    """No progress bars from datasets and lerobot, and only errors from the AV1 encoder (SVT-AV1 prints its
    configuration for every video): a generation's output is its own summary. The dataset hub offline: a
    generation reads and writes local folders only (a missing file asked the hub, retried for minutes)."""
    os.environ.setdefault("HF_HUB_OFFLINE", "1")  # local folders only: a missing file is named, never downloaded
    os.environ.setdefault("SVT_LOG", "1")
    os.environ.setdefault("TQDM_DISABLE", "1")
    os.environ.setdefault("HF_DATASETS_DISABLE_PROGRESS_BARS", "1")


def require_lerobot() -> Callable[[], None]:
    """Raises InputError, naming the extra, when ``lerobot`` is not installed; otherwise starts importing it
    in a thread (torch's import takes seconds of one core: done while the workers run episodes, not before
    them). Returns a function that waits for that import and raises InputError if it failed (an install
    that is there but broken)."""
    if importlib.util.find_spec("lerobot") is None:
        raise InputError(f"needs {EXTRA}; it is not installed", field="lerobot")
    failed: list[ImportError] = []

    def load() -> None:
        _quiet()
        try:
            importlib.import_module("lerobot.datasets.aggregate")  # what merge needs (it imports the dataset)
        except ImportError as error:
            failed.append(error)

    loading = threading.Thread(target=load, name="import lerobot", daemon=True)
    loading.start()

    def loaded() -> None:
        loading.join()
        if failed:
            raise InputError(f"needs {EXTRA}; importing it failed: {failed[0]}", field="lerobot")

    return loaded


@dataclasses.dataclass(frozen=True)
class Convention:
    """LeRobot's names and units for a robot it drives (``data/lerobot/conventions.toml``)."""

    robot_type: str
    joints: tuple[str, ...]
    gripper: str
    suffix: str
    unit: str

    def names(self, joint_names: list[str]) -> list[str]:
        return [f"{name}{self.suffix}" for name in joint_names]

    def apply(self, rows: list[dict], gripper) -> None:
        """Rewrite the rows' joints in the convention's unit and the gripper's closing as 0..100 of its joint's
        range (``gripper``: the model's :class:`~slideplan.sim.model.Gripper`, one joint)."""
        scale = math.degrees(1.0) if self.unit == "deg" else 1.0
        opened, closed = float(gripper.opened[0]), float(gripper.closed[0])
        low, high = (float(value) for value in gripper.limits[0])
        joints = len(self.joints)

        def percent(closing: float) -> float:
            return 100.0 * (opened + closing * (closed - opened) - low) / (high - low)

        for row in rows:
            for key in ("state", "action"):
                row[key][:joints] *= scale
                row[key][joints] = percent(row[key][joints])
            row["ee_delta"][-1] = row["action"][joints]


def convention_for(joint_names: list[str], gripper_joints: list[str]) -> Convention | None:
    """The convention whose joints are the plan's and whose gripper is the hand's only one, or None."""
    table = tomllib.loads((data_dir() / "lerobot" / "conventions.toml").read_text())
    for entry in table.get("convention", []):
        if list(entry["joints"]) == list(joint_names) and list(gripper_joints) == [entry["gripper"]]:
            return Convention(entry["robot_type"], tuple(entry["joints"]), entry["gripper"], entry["suffix"], entry["unit"])
    return None


def features(joint_names: list[str], cameras: tuple[CameraSpec, ...], convention: Convention | None = None) -> dict:
    """The dataset's per-frame features (LeRobot's ``features`` dict).

    Args:
        joint_names: the arm's joints, in the plan's order.
        cameras: the cameras: a video feature ``observation.images.NAME`` each, and ``NAME_depth`` for its
            depth (grey levels: :meth:`slideplan.demos.frames.Frames._depth`).
        convention: LeRobot's names for this robot (:func:`convention_for`), or None: the URDF's joint names.
    """
    shown = convention.names(joint_names) if convention else list(joint_names)
    gripper = f"{convention.gripper}{convention.suffix}" if convention else "gripper"
    state, action = state_names(shown), action_names(shown)
    state[len(shown)] = action[len(shown)] = gripper
    out = {
        "observation.state": {"dtype": "float32", "shape": (len(shown) + 7,), "names": state},
        "action": {"dtype": "float32", "shape": (len(shown) + 1,), "names": action},
        "ee_delta_action": {"dtype": "float32", "shape": (len(EE_ACTION_NAMES),), "names": EE_ACTION_NAMES},
        "phase": {"dtype": "int64", "shape": (1,), "names": ["phase"]},
        # Offline RL's columns, as SlideToEdge-v1's sparse reward: 1 on the episode's last frame if it succeeded.
        "next.reward": {"dtype": "float32", "shape": (1,), "names": None},
        "next.done": {"dtype": "bool", "shape": (1,), "names": None},
        "next.success": {"dtype": "bool", "shape": (1,), "names": None},
    }
    for camera in cameras:
        for name in (camera.name, f"{camera.name}_depth") if camera.depth else (camera.name,):
            out[f"observation.images.{name}"] = {"dtype": "video", "shape": (camera.height, camera.width, 3),
                                                 "names": ["height", "width", "channels"]}
    return out


def write_episode(root: Path, fps: int, feature_set: dict, robot_type: str, task: str, rows: list[dict],
                  success: bool) -> None:
    """One episode as a finalized dataset at ``root`` (which must not exist): written beside it and renamed
    into place, so ``root`` exists only whole.

    Args:
        root: the episode's dataset folder.
        fps: frames per second.
        feature_set: :func:`features`.
        robot_type: the robot's name (LeRobot's ``robot_type``).
        task: the episode's task string.
        rows: the frames (:class:`slideplan.demos.frames.Frames`'s rows).
        success: the world's verdict of the episode (its last frame's ``next.success`` and reward).
    """
    _quiet()
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    partial = root.with_name(root.name + ".partial")
    if partial.exists():
        shutil.rmtree(partial)
    dataset = LeRobotDataset.create(REPO_ID, fps, feature_set, root=partial, robot_type=robot_type,
                                    use_videos=True, streaming_encoding=True)
    for index, row in enumerate(rows):
        last = index == len(rows) - 1
        frame = {"observation.state": row["state"].astype(np.float32), "action": row["action"].astype(np.float32),
                 "ee_delta_action": row["ee_delta"].astype(np.float32), "phase": np.array([row["phase"]], dtype=np.int64),
                 "next.reward": np.array([float(last and success)], dtype=np.float32),
                 "next.done": np.array([last]), "next.success": np.array([last and success]), "task": task}
        for key in feature_set:
            if key.startswith("observation.images."):
                frame[key] = row[key.removeprefix("observation.images.")]
        dataset.add_frame(frame)
    with _without_image_embedding(feature_set):
        dataset.save_episode()
    dataset.finalize()
    os.replace(partial, root)


@contextlib.contextmanager
def _without_image_embedding(feature_set: dict):
    """lerobot 0.4's ``save_episode`` runs ``embed_images``, a row-by-row ``datasets.map``, over every episode
    (a 200-frame episode's write: 0.13 s with it, 0.04 s without, one core). It embeds ``image`` features only; these
    datasets have none (cameras are ``video`` features, kept outside the Parquet files), so it is skipped
    while the episode is saved. test_demos checks the Parquet files are the same as with it."""
    import lerobot.datasets.lerobot_dataset as lerobot_dataset

    if any(feature["dtype"] == "image" for feature in feature_set.values()):
        yield
        return
    embed = lerobot_dataset.embed_images
    lerobot_dataset.embed_images = lambda dataset: dataset
    try:
        yield
    finally:
        lerobot_dataset.embed_images = embed


def merge(parts: list[Path], out: Path) -> None:
    """Merge the episode datasets ``parts`` (in this order) into the dataset at ``out`` (its ``meta``,
    ``data`` and ``videos`` folders; other files there are kept)."""
    _quiet()
    from lerobot.datasets.aggregate import aggregate_datasets

    staging = out / ".merging"
    if staging.exists():
        shutil.rmtree(staging)
    with contextlib.redirect_stderr(io.StringIO()):  # its progress bars (tqdm, imported before TQDM_DISABLE was set)
        aggregate_datasets([REPO_ID] * len(parts), REPO_ID, roots=list(parts), aggr_root=staging)
    for name in ("meta", "data", "videos", "images"):
        target = out / name
        if target.exists():
            shutil.rmtree(target)
        if (staging / name).exists():
            os.replace(staging / name, target)
    shutil.rmtree(staging)


def write_json_atomic(path: Path, content: dict) -> None:
    """``content`` as JSON at ``path``, replaced whole (a reader never sees half of it)."""
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(content, sort_keys=True, indent=1) + "\n")
    os.replace(partial, path)
