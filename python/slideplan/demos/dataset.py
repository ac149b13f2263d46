"""Episodes as LeRobotDataset v3.0, through the ``lerobot`` package's own API (the optional extra
``slideplan[lerobot]``): each episode is written as a dataset of its own (so a worker killed mid-episode
loses that episode only, and a stopped generation resumes), then all are merged with lerobot's
``aggregate_datasets``."""

from __future__ import annotations

import contextlib
import importlib
import io
import json
import os
import shutil
from pathlib import Path

import numpy as np

from ..errors import InputError
from .frames import EE_ACTION_NAMES, CameraSpec, action_names, state_names

REPO_ID = "slideplan/demos"  # the datasets' name; they live under the output folder, nothing is uploaded
EXTRA = 'lerobot (pip install "slideplan[lerobot]": the lerobot 0.4 line, with torch)'


def _quiet() -> None:
    """No progress bars from datasets and lerobot, and only errors from the AV1 encoder (SVT-AV1 prints its
    configuration for every video): a generation's output is its own summary."""
    os.environ.setdefault("SVT_LOG", "1")
    os.environ.setdefault("TQDM_DISABLE", "1")
    os.environ.setdefault("HF_DATASETS_DISABLE_PROGRESS_BARS", "1")


def require_lerobot() -> None:
    """Raises InputError, naming the extra, when ``lerobot`` cannot be imported."""
    try:
        importlib.import_module("lerobot.datasets.lerobot_dataset")
    except ImportError as error:
        raise InputError(f"needs {EXTRA}; importing it failed: {error}", field="lerobot") from None


def features(joint_names: list[str], cameras: tuple[CameraSpec, ...], names: dict[str, str] | None = None) -> dict:
    """The dataset's per-frame features (LeRobot's ``features`` dict).

    Args:
        joint_names: the arm's joints, in the plan's order.
        cameras: the cameras: a video feature ``observation.images.NAME`` each.
        names: joint name -> the feature name a robot's LeRobot convention gives it (data/lerobot), or None.
    """
    shown = [(names or {}).get(name, name) for name in joint_names]
    out = {
        "observation.state": {"dtype": "float32", "shape": (len(shown) + 7,), "names": state_names(shown)},
        "action": {"dtype": "float32", "shape": (len(shown) + 1,), "names": action_names(shown)},
        "ee_delta_action": {"dtype": "float32", "shape": (len(EE_ACTION_NAMES),), "names": EE_ACTION_NAMES},
        "phase": {"dtype": "int64", "shape": (1,), "names": ["phase"]},
    }
    for camera in cameras:
        out[f"observation.images.{camera.name}"] = {"dtype": "video", "shape": (camera.height, camera.width, 3),
                                                    "names": ["height", "width", "channels"]}
    return out


def write_episode(root: Path, fps: int, feature_set: dict, robot_type: str, task: str, rows: list[dict],
                  scale: np.ndarray | None = None) -> None:
    """One episode as a finalized dataset at ``root`` (which must not exist): written beside it and renamed
    into place, so ``root`` exists only whole.

    Args:
        root: the episode's dataset folder.
        fps: frames per second.
        feature_set: :func:`features`.
        robot_type: the robot's name (LeRobot's ``robot_type``).
        task: the episode's task string.
        rows: the frames (:class:`slideplan.demos.frames.Frames`'s rows).
        scale: per state/action joint entry, the factor into the convention's units (None: as simulated).
    """
    _quiet()
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    partial = root.with_name(root.name + ".partial")
    if partial.exists():
        shutil.rmtree(partial)
    dataset = LeRobotDataset.create(REPO_ID, fps, feature_set, root=partial, robot_type=robot_type,
                                    use_videos=True, streaming_encoding=True)
    joints = len(feature_set["action"]["names"]) - 1
    factor = np.ones(joints) if scale is None else scale
    for row in rows:
        state, action = row["state"].copy(), row["action"].copy()
        state[:joints] *= factor
        action[:joints] *= factor
        frame = {"observation.state": state.astype(np.float32), "action": action.astype(np.float32),
                 "ee_delta_action": row["ee_delta"].astype(np.float32), "phase": np.array([row["phase"]], dtype=np.int64),
                 "task": task}
        for key in feature_set:
            if key.startswith("observation.images."):
                frame[key] = row[key.removeprefix("observation.images.")]
        dataset.add_frame(frame)
    dataset.save_episode()
    dataset.finalize()
    os.replace(partial, root)


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
