"""SlideToEdge's frozen benchmark protocol: tiers of tasks written in a data file
(``data/benchmark/slide_to_edge.toml``), each task an episode of the environment that a seed draws.

A tier is one of the closed loop's settings (``nominal``, ``random``, ``hard``); a task is a table, a seed
and what that seed draws (the object and its pose, :func:`slideplan.demos.draw.draw`), on the held-out
object split the file names (objects no default ``slideplan demos`` draw uses). The file is written once
(``benchmarks/freeze_protocol.py``) and never edited: a build under which a task's seed draws another
object or pose changes scores, and :meth:`Task.check` refuses it. Success is the world's verdict of every
run (:mod:`slideplan.checks.verdict`), as the environment judges it.
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

from ..errors import InputError
from ..paths import data_dir

PROTOCOL_FILE = "benchmark/slide_to_edge.toml"
POSE_TOLERANCE = 1e-6  # a task's pose as drawn (m, rad): the file keeps 9 decimals (rounding 5e-10)


@dataclasses.dataclass(frozen=True)
class Task:
    """One episode of a tier: ``reset(seed=seed)`` of the environment on ``scene``, drawing from the
    protocol's objects, draws ``object`` at ``pose``."""

    tier: str
    index: int
    scene: str
    seed: int
    object: str
    pose: tuple[float, float, float]

    @property
    def task_id(self) -> str:
        return f"{self.tier}-{self.index:03d}"

    def check(self, drawn_object: str, drawn_pose) -> None:
        """Raises InputError when the environment drew another episode than the protocol's (this build
        changes scores: the protocol's version must change with it)."""
        if drawn_object != self.object or any(abs(a - b) > POSE_TOLERANCE for a, b in zip(drawn_pose, self.pose)):
            raise InputError(f"task {self.task_id}: seed {self.seed} draws {drawn_object} at {tuple(drawn_pose)}, the "
                             f"protocol has {self.object} at {self.pose}: this build changes the benchmark's episodes",
                             field="protocol")


@dataclasses.dataclass(frozen=True)
class Protocol:
    """The frozen protocol: the environment's id its scores are for, the held-out object split, and the
    tiers' tasks."""

    env_id: str
    split: str
    objects: tuple[str, ...]
    settings: dict[str, str]  # tier -> the closed loop's setting
    tasks: dict[str, tuple[Task, ...]]  # tier -> its tasks, in order

    @property
    def tiers(self) -> tuple[str, ...]:
        return tuple(self.tasks)

    def tier(self, name: str, episodes: int | None = None) -> tuple[Task, ...]:
        """The first ``episodes`` tasks of tier ``name`` (all: None).

        Raises:
            InputError: an unknown tier (``--tier``), or ``episodes`` outside 1..the tier's count (``--episodes``).
        """
        if name not in self.tasks:
            raise InputError(f"unknown tier {name!r} (one of {', '.join(self.tasks)})", field="--tier")
        tasks = self.tasks[name]
        if episodes is None:
            return tasks
        if not 1 <= episodes <= len(tasks):
            raise InputError(f"must be 1..{len(tasks)} (tier {name}'s tasks), got {episodes}", field="--episodes")
        return tasks[:episodes]


def load_protocol(path: str | Path | None = None) -> Protocol:
    """The protocol in ``path`` (default: the bundled :data:`PROTOCOL_FILE`)."""
    path = Path(path) if path is not None else data_dir() / PROTOCOL_FILE
    table = tomllib.loads(path.read_text())
    settings, tasks = {}, {}
    for tier in table["tiers"]:
        settings[tier["name"]] = tier["setting"]
        tasks[tier["name"]] = tuple(Task(tier["name"], index, entry["scene"], int(entry["seed"]), entry["object"],
                                         (float(entry["x"]), float(entry["y"]), float(entry["yaw"])))
                                    for index, entry in enumerate(tier["tasks"]))
    return Protocol(table["env_id"], table["split"], tuple(table["objects"]), settings, tasks)


def format_protocol(protocol: Protocol, header: str) -> str:
    """The protocol as its TOML file (``header``: its comment lines)."""
    lines = [*(f"# {line}" if line else "#" for line in header.splitlines()), "",
             f'env_id = "{protocol.env_id}"', f'split = "{protocol.split}"',
             "objects = [" + ", ".join(f'"{name}"' for name in protocol.objects) + "]"]
    for tier, tasks in protocol.tasks.items():
        lines += ["", "[[tiers]]", f'name = "{tier}"', f'setting = "{protocol.settings[tier]}"', "tasks = ["]
        for task in tasks:
            x, y, yaw = (f"{value:.9f}" for value in task.pose)
            lines.append(f'  {{scene = "{task.scene}", seed = {task.seed}, object = "{task.object}", '
                         f"x = {x}, y = {y}, yaw = {yaw}}},")
        lines.append("]")
    return "\n".join(lines) + "\n"


def rounded(pose) -> tuple[float, float, float]:
    """A pose as the file keeps it."""
    return tuple(float(f"{value:.9f}") for value in pose)

