"""``slideplan demos``: closed-loop (or open-loop) episodes in MuJoCo recorded as a LeRobotDataset v3.0.

The output folder holds the request (``slideplan_demos.json``), one folder per finished episode under
``episodes/`` (its record, and until the merge a finalized dataset of its own when the episode is kept), and
the merged dataset (``meta``, ``data``, ``videos``) once every episode is done. A stopped generation run
again with the same request goes on where it stopped; the episodes a killed worker's pool failed run again
in a fresh pool (:class:`~slideplan.experiments.executors.LocalPoolExecutor`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import hashlib
import json
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..provenance import build_info
from .dataset import convention_for, features, merge, require_lerobot, write_episode, write_json_atomic
from .draw import check_setting, draw, episode_seed
from .frames import PHASES, CameraSpec, Frames

REQUEST_FILE = "slideplan_demos.json"
LOCK_FILE = ".slideplan_demos.lock"
MERGED_FILE = "slideplan_episodes.json"  # in meta/, written once the merge is whole
MAX_EPISODES = 1_000_000
KEEP = ("success", "all")


@dataclasses.dataclass(frozen=True)
class Request:
    """What to generate (the command's options; recorded in the output folder, and a resumed generation must
    ask for the same)."""

    scene: str
    episodes: int
    objects: tuple[str, ...] = ("crescent", "square", "triangle", "circle", "irregular")
    setting: str = "nominal"
    closed: bool = True
    cameras: tuple[str, ...] = ()
    fps: int = 10
    keep: str = "success"
    seed: int = 0

    def checked(self) -> Request:
        """This request, its values checked (each error names its option).

        Raises:
            InputError: a count of 0 or beyond 1e6, an fps outside 1..100, an unknown setting, keep or camera,
                a negative seed, no objects.
        """
        if not 1 <= self.episodes <= MAX_EPISODES:
            raise InputError(f"must be 1..{MAX_EPISODES}, got {self.episodes}", field="--episodes")
        if not 1 <= self.fps <= 100:
            raise InputError(f"must be 1..100, got {self.fps}", field="--fps")
        check_setting(self.setting)
        if self.keep not in KEEP:
            raise InputError(f"must be one of {', '.join(KEEP)}, got {self.keep!r}", field="--keep")
        if self.seed < 0:
            raise InputError(f"must be >= 0, got {self.seed}", field="--seed")
        if not self.objects:
            raise InputError("no objects to draw from", field="--objects")
        names = [CameraSpec.parse(text).name for text in self.cameras]
        if len(set(names)) != len(names):
            raise InputError(f"a camera named twice: {', '.join(self.cameras)}", field="--cameras")
        return self

    def camera_specs(self) -> tuple[CameraSpec, ...]:
        return tuple(CameraSpec.parse(text) for text in self.cameras)


@dataclasses.dataclass(frozen=True)
class Episode:
    """One episode to generate (a task of :mod:`slideplan.experiments.executors`)."""

    request: Request
    index: int
    out: str

    @property
    def task_id(self) -> str:
        return f"episode-{self.index:06d}"


def episode_dir(out: Path, index: int) -> Path:
    return out / "episodes" / f"{index:06d}"


def plan_hash(plan) -> str:
    """The first plan's motion (its joint path and grasp), hashed: the same plan, the same hash."""
    digest = hashlib.sha256(np.ascontiguousarray(plan.trajectory, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(plan.grasp["config"], dtype=np.float64).tobytes())
    return digest.hexdigest()[:16]


FRONT_REACH_M = 0.25  # the hand grasps the overhang past the table's edge: its fingers and wrist reach this far
FRONT_HAND_M = 0.08  # ... at this height above the table
FRONT_AIR_M = 0.2  # the air above the table the lift goes up into


def front_points(scene) -> np.ndarray:
    """What the ``front`` camera keeps in view: the table, the air above it, and the hand's reach past its
    edges at the hand's height (the grasp and the lift happen there: framed on the table alone, the hand
    left the frame as it closed)."""
    import shapely

    table = scene.table.polygon
    corners = np.asarray(table.exterior.coords, dtype=float)[:-1]
    reach = shapely.simplify(table.buffer(FRONT_REACH_M, join_style=shapely.BufferJoinStyle.mitre), 0.005)
    around = np.asarray(reach.exterior.coords, dtype=float)[:-1]
    height = scene.table.height
    return np.vstack([np.column_stack([corners, np.full(len(corners), height)]),
                      np.column_stack([around, np.full(len(around), height + FRONT_HAND_M)]),
                      np.column_stack([corners, np.full(len(corners), height + FRONT_AIR_M)])])


def run_episode(episode: Episode) -> dict:
    """Run and record one episode (in a worker): its folder holds ``record.json`` and, if kept, the
    episode's dataset (``dataset/``). Returns the record."""
    from ..sim.closed_loop import run
    from ..experiments.tasks import cached_scene

    request, out = episode.request, Path(episode.out)
    scene = cached_scene(request.scene)
    drawn = draw(scene, request.objects, request.setting, episode_seed(request.seed, episode.index))
    taken: dict = {}

    def observe(plan, built, runner, robot):
        taken["frames"] = Frames(built, runner, robot, request.fps, request.camera_specs(), front_points(scene))
        taken["plan"], taken["joints"], taken["gripper"] = plan_hash(plan), list(plan.joint_names), built.gripper
        return taken["frames"].after_step

    record = {"index": episode.index, "seed": drawn.seed, "object": drawn.object, "pose": list(drawn.pose),
              "setting": drawn.setting, "mode": "closed" if request.closed else "open", "build": build_info().get("build")}
    try:
        report = run(scene, drawn.object, drawn.pose, seed=drawn.seed, closed=request.closed, setting=request.setting,
                     observe=observe)
        record.update(success=report.success, failed_stage=report.failed_stage, failure=report.failure,
                      replans=report.replans, disturbance=report.disturbance, draws=report.draws)
    except Exception as error:  # noqa: BLE001 - an attempt that failed; recorded, not retried
        record.update(success=False, failed_stage="error", failure=f"{type(error).__name__}: {error}", replans=0,
                      disturbance=None, draws=None)
    finally:
        if "frames" in taken:
            taken["frames"].close()
    frames = taken.get("frames")
    kept = frames is not None and bool(frames.rows) and (request.keep == "all" or record["success"])
    record.update(plan_hash=taken.get("plan"), frames=len(frames.rows) if frames else 0, kept=kept,
                  depth_max_m=dict(frames.depth_max_m) if frames else {})
    folder = episode_dir(out, episode.index)
    folder.mkdir(parents=True, exist_ok=True)
    if (folder / "dataset").exists():  # written by a worker killed before the record: done again
        shutil.rmtree(folder / "dataset")
    if kept:
        convention = convention_for(taken["joints"], list(scene.hand.gripper_joints))
        if convention is not None:
            convention.apply(frames.rows, taken["gripper"])
        robot_type = convention.robot_type if convention else scene.urdf_path.stem
        write_episode(folder / "dataset", request.fps, features(taken["joints"], request.camera_specs(), convention),
                      robot_type, drawn.task(scene.name), frames.rows, bool(record["success"]))
    write_json_atomic(folder / "record.json", record)  # last: an episode with a record is done
    return record


def records(out: Path) -> dict[int, dict]:
    """The finished episodes' records, by index. Before the merge, a kept episode whose dataset is not whole
    (its ``meta/info.json`` or its data missing: a folder written by hand, or by a version before the lock)
    is not finished: it runs again, where merging it asked the dataset hub for the missing files."""
    merged = (out / "meta" / MERGED_FILE).exists()
    found = {}
    for path in sorted((out / "episodes").glob("*/record.json")):
        record = json.loads(path.read_text())
        dataset = path.parent / "dataset"
        if record.get("kept") and not merged and not ((dataset / "meta" / "info.json").exists()
                                                      and any((dataset / "data").glob("**/*.parquet"))):
            continue
        found[int(record["index"])] = record
    return found


def prepare(request: Request, out: Path, *, record: bool = True) -> None:
    """Check the output folder and (``record``) record the request there.

    Raises:
        InputError: the folder holds another dataset, or another generation's request.
    """
    saved = out / REQUEST_FILE
    wanted = dataclasses.asdict(request)
    wanted = json.loads(json.dumps(wanted))  # tuples as the file has them: lists
    if saved.exists():
        earlier = json.loads(saved.read_text())
        changed = sorted(key for key in wanted if earlier.get(key) != wanted[key])
        if changed:
            raise InputError(f"{out} holds a generation asked with other {', '.join(changed)}: give another folder, "
                             "or the same options to resume it", field="--out")
        return
    if out.exists() and any(path.name != LOCK_FILE for path in out.iterdir()):
        what = "a dataset" if (out / "meta" / "info.json").exists() else "other files"
        raise InputError(f"{out} holds {what}: give a new or empty folder", field="--out")
    if not record:
        return
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(saved, {**wanted, "phases": list(PHASES)})


@contextlib.contextmanager
def writing(out: Path):
    """Hold ``out``'s lock while a generation writes there: a second generation into the same folder is
    refused, not interleaved (an advisory lock the system releases when the process ends, killed or not).

    Raises:
        InputError: another generation holds it.
    """
    out.mkdir(parents=True, exist_ok=True)
    with open(out / LOCK_FILE, "a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(f"another slideplan demos is writing to {out} (it holds the lock {out / LOCK_FILE}): "
                             "let it finish, then run the command again to go on, or give another folder",
                             field="--out") from None
        yield


def generate(request: Request, out: str | Path, executor, progress: Callable[[dict], None] | None = None) -> dict:
    """Generate the episodes not yet done, then merge the kept ones into the dataset at ``out``.

    Args:
        request: what to generate (checked here).
        out: the output folder.
        executor: where episodes run (:mod:`slideplan.experiments.executors`).
        progress: called with the tally so far (``{"total", "done", "kept", "lost"}``: episodes asked for, done
            (earlier runs' included), kept, lost), once before the first episode and after each; or None.

    Returns:
        ``{"episodes": N, "kept": K, "successes": S, "lost": L}``: L episodes lost (their worker died: run
        again to redo them).

    Raises:
        InputError: bad options, no ``lerobot`` extra, an output folder holding something else.
    """
    from ..experiments.tasks import cached_scene

    request = request.checked()
    scene = cached_scene(request.scene)
    for name in request.objects:
        draw(scene, (name,), request.setting, 0)  # an unknown object is named now, not in a worker
    out = Path(out)
    prepare(request, out, record=False)  # every option checked before the extra, and nothing written without it
    lerobot_loaded = require_lerobot()
    with writing(out):
        return _generate(request, out, executor, progress, lerobot_loaded)


def _generate(request: Request, out: Path, executor, progress, lerobot_loaded) -> dict:
    """:func:`generate` once the options are checked and the folder is this run's."""
    prepare(request, out)
    done = records(out)
    todo = [Episode(request, index, str(out)) for index in range(request.episodes) if index not in done]
    lost = 0

    def tally() -> None:
        if progress is not None:
            progress({"total": request.episodes, "done": len(done), "kept": sum(r["kept"] for r in done.values()),
                      "lost": lost})

    tally()
    for _, outcome in executor.imap_unordered(run_episode, todo):
        if isinstance(outcome, BaseException):
            lost += 1
        else:
            done[outcome["index"]] = outcome
        tally()
    lerobot_loaded()  # a broken install is named, not only its lost episodes
    kept = [index for index in sorted(done) if done[index]["kept"]]
    merged = out / "meta" / MERGED_FILE
    if lost == 0 and kept and not merged.exists():
        merge([episode_dir(out, index) / "dataset" for index in kept], out)
        write_json_atomic(merged, {"episodes": [dict(done[index], episode_index=position) for position, index in enumerate(kept)],
                                   "attempts": len(done), "phases": list(PHASES)})
    if merged.exists():  # merged whole: the episodes' own datasets are copies (about half the folder)
        for index in kept:
            shutil.rmtree(episode_dir(out, index) / "dataset", ignore_errors=True)
    return {"episodes": len(done), "kept": len(kept), "successes": sum(r["success"] for r in done.values()), "lost": lost}
