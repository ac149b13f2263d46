"""One demonstration's draw: the object, where it lies and the seeds, from an episode's seed. The
demonstrations (:mod:`slideplan.demos.generate`) and the environment (:mod:`slideplan.demos.env`) draw
with this one function, so an episode of a dataset can be reset in the environment."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..sim.conditions import SETTINGS
from ..errors import InputError
from ..world.objects import load_outline, sample_pose_on_table
from ..world.scenes import Scene

# An object kept this far inside the table's edges: one drawn overhanging already is no demonstration.
EDGE_MARGIN_M = 0.01


@dataclasses.dataclass(frozen=True)
class Draw:
    """What an episode starts from (its closed-loop run's arguments)."""

    seed: int  # the episode's seed: the camera's noise, perception, the planner and the setting's draws
    object: str  # a built-in object name or an outline file
    pose: tuple[float, float, float]  # where it really lies (x m, y m, yaw rad)
    setting: str

    def task(self, scene_name: str) -> str:
        """The episode's task string (LeRobot's ``task``)."""
        return f"slide the {object_label(self.object)} to the edge of the {scene_name} table, then grasp and lift it"


def object_label(object_name: str) -> str:
    """An object's name as a task string says it (a file's stem)."""
    return object_name.rsplit("/", 1)[-1].rsplit(".", 1)[0]


def check_setting(setting: str) -> None:
    """Raises InputError (``--setting``) for a setting that is not one of the closed loop's."""
    if setting not in SETTINGS:
        raise InputError(f"unknown setting {setting!r} (one of {', '.join(SETTINGS)})", field="--setting")


def draw(scene: Scene, objects: tuple[str, ...], setting: str, seed: int) -> Draw:
    """The episode of ``seed``: an object drawn from ``objects`` and a pose with it wholly on the table
    (uniform, :func:`slideplan.world.objects.sample_pose_on_table`, kept :data:`EDGE_MARGIN_M` inside).

    Args:
        scene: the scene (its table).
        objects: the objects to draw from (built-in names or outline files).
        setting: the physics setting (one of :data:`SETTINGS`); its own draws come from ``seed`` in the run.
        seed: the episode's seed (>= 0): the same seed, the same draw, in any process.

    Raises:
        InputError: no objects, an unknown setting or object, a negative seed, or an object too large for the table.
    """
    if not objects:
        raise InputError("no objects to draw from", field="--objects")
    check_setting(setting)
    if seed < 0:
        raise InputError(f"must be >= 0, got {seed}", field="--seed")
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x5EED]))
    name = objects[int(rng.integers(len(objects)))]
    outline, _, _ = load_outline(name)
    pose = sample_pose_on_table(outline, scene.table, rng, margin=EDGE_MARGIN_M)
    return Draw(seed=seed, object=name, pose=tuple(float(v) for v in pose), setting=setting)


def episode_seed(seed: int, index: int) -> int:
    """Episode ``index``'s seed in a dataset generated with ``seed`` (distinct for distinct pairs)."""
    return int(np.random.SeedSequence([seed, index]).generate_state(1, dtype=np.uint32)[0])
