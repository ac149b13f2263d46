"""The physics a closed-loop run meets (:func:`slideplan.sim.closed_loop.run`): the settings ``nominal``,
``stress``, ``random`` and ``hard``, each run's draws from its seed alone (the same for open and closed
loop), and the pushes that disturb a slide.

The ``hard`` setting is fixed in advance and is not to be tuned: frictions, mass and the finger's spring
drawn in :data:`HARD_RANGES`; a camera pose error the planner and the tracker do not know
(:func:`camera_as_mounted`); the arm following its references :data:`HARD_LAG_S` late; and with
probability :data:`HARD_PUSH_PROBABILITY` a push at a time uniform over the slide
(:func:`hard_push`). As in every setting, the object's initial pose is the one perceived.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .settings import ExecutionSettings, stress_settings
from ..perception.camera import Camera

SETTINGS = ("nominal", "stress", "random", "hard")
RANDOM_RANGES = {  # the random setting draws each uniformly in its range, per run
    "table_friction": (0.25, 0.6),
    "pad_friction": (0.6, 1.2),
    "torsional_friction": (0.002, 0.02),  # m
    "mass_scale": (0.5, 2.0),
    "depth_noise_at_1m": (0.001, 0.004),  # m
}
HARD_RANGES = {  # fixed in advance: uniform per run
    "table_friction": (0.15, 0.8),
    "pad_friction": (0.4, 1.5),
    "torsional_friction": (0.001, 0.03),  # m
    "mass_scale": (0.3, 3.0),
    "spring_scale": (0.5, 1.5),  # on the finger compliance's stiffness
}
HARD_CAMERA_POSITION_SD_M = 0.005  # per axis
HARD_CAMERA_ROTATION_SD_DEG = 0.5  # about each axis
HARD_LAG_S = 0.03
HARD_PUSH_PROBABILITY = 0.5
HARD_PUSH_DISTANCE_M = (0.01, 0.04)
HARD_PUSH_TURN_DEG = 15.0  # uniform in +-
HARD_PUSH_COM_INSIDE_M = 0.01  # a push leaving the centre of mass closer to an edge than this is redrawn
PUSH_CANDIDATES = 64  # redraws at most; a push none of them allows is not made (the row says so)
DEPTH_NOISE_AT_1M = 0.002  # m, nominal, stress and hard (as slideplan.sim.rendering)


@dataclass(frozen=True)
class Disturbance:
    """The object moved by someone ``after_s`` seconds into the slide: by ``(dx, dy)`` (m) and turned
    by ``dyaw`` (rad) about its centre of mass."""

    dx: float
    dy: float
    dyaw: float
    after_s: float

    def apply(self, built) -> None:
        """Move the object of an execution model (:class:`slideplan.sim.model.Model`) by this much,
        about its centre of mass, and leave it at rest."""
        import mujoco

        model, data = built.model, built.data
        joint = model.body_jntadr[built.object_body]
        address = model.jnt_qposadr[joint]
        data.qpos[address:address + 2] += (self.dx, self.dy)
        turn = np.array([math.cos(self.dyaw / 2), 0.0, 0.0, math.sin(self.dyaw / 2)])
        quaternion = np.zeros(4)
        mujoco.mju_mulQuat(quaternion, turn, data.qpos[address + 3:address + 7].copy())
        data.qpos[address + 3:address + 7] = quaternion
        data.qvel[model.jnt_dofadr[joint]:][:6] = 0.0


def setting_draws(setting: str, seed: int) -> dict[str, float]:
    """The physical parameters of a run: the defaults (nominal, stress) or the random or hard setting's
    draws, from a generator seeded by ``seed`` alone (the same for open and closed loop).

    The hard setting's draws also hold the camera's error (``camera_dx_m`` ... ``camera_rz_deg``), the
    arm's lag (``lag_s``), and the push: ``push`` (1 or 0), ``push_fraction`` (of the planned slide's
    time), ``push_seed`` (of its candidates, :func:`hard_push`).

    Raises:
        InputError: an unknown setting (field ``setting``).
    """
    if setting not in SETTINGS:
        raise InputError(f"expected one of {', '.join(SETTINGS)}, got {setting!r}", field="setting")
    nominal = ExecutionSettings()
    if setting in ("nominal", "stress"):
        return {"table_friction": nominal.table_friction, "pad_friction": nominal.pad_friction,
                "torsional_friction": nominal.torsional_friction * (0.5 if setting == "stress" else 1.0),
                "mass_scale": 1.0, "depth_noise_at_1m": DEPTH_NOISE_AT_1M}
    if setting == "random":
        rng = np.random.default_rng([seed, 24])
        return {name: float(rng.uniform(*bounds)) for name, bounds in RANDOM_RANGES.items()}
    rng = np.random.default_rng([seed, 53])
    draws = {name: float(rng.uniform(*bounds)) for name, bounds in HARD_RANGES.items()}
    draws["depth_noise_at_1m"] = DEPTH_NOISE_AT_1M
    draws.update({f"camera_d{axis}_m": float(rng.normal(0.0, HARD_CAMERA_POSITION_SD_M)) for axis in "xyz"})
    draws.update({f"camera_r{axis}_deg": float(rng.normal(0.0, HARD_CAMERA_ROTATION_SD_DEG)) for axis in "xyz"})
    draws["lag_s"] = HARD_LAG_S
    draws["push"] = float(rng.uniform() < HARD_PUSH_PROBABILITY)
    draws["push_fraction"] = float(rng.uniform())
    draws["push_seed"] = float(rng.integers(2**31))
    return draws


def execution_settings(setting: str, draws: dict[str, float], dz_min: float) -> ExecutionSettings:
    """The execution's physical parameters for a setting and its draws (:func:`setting_draws`)."""
    base = stress_settings(dz_min) if setting == "stress" else ExecutionSettings()
    return dataclasses.replace(base, table_friction=draws["table_friction"], pad_friction=draws["pad_friction"],
                               torsional_friction=draws["torsional_friction"],
                               object_density=base.object_density * draws["mass_scale"],
                               spring_scale=draws.get("spring_scale", 1.0), reference_lag_s=draws.get("lag_s", 0.0))


def camera_as_mounted(camera: Camera, draws: dict[str, float]) -> Camera:
    """Where the camera really is: ``camera`` (where the planner and the tracker believe it is) moved by
    the draws' position error and turned by their rotation error about the world axes at its centre.
    Without camera error in the draws, ``camera`` itself."""
    if "camera_dx_m" not in draws:
        return camera
    from scipy.spatial.transform import Rotation

    pose = camera.optical_pose()
    turn = Rotation.from_euler("xyz", [draws[f"camera_r{axis}_deg"] for axis in "xyz"], degrees=True).as_matrix()
    pose[:3, :3] = turn @ pose[:3, :3]
    pose[:3, 3] += [draws[f"camera_d{axis}_m"] for axis in "xyz"]
    return Camera.from_optical_pose(pose, width=camera.width, height=camera.height, fovy_deg=camera.fovy_deg)


def push_candidates(seed: int, after_s: float, count: int = PUSH_CANDIDATES) -> list[Disturbance]:
    """The hard setting's push and its redraws, in order: 1-4 cm in a direction uniform in the table's
    plane, turned uniformly within +-15 deg, ``after_s`` into the slide."""
    rng = np.random.default_rng([int(seed), 53, 2])
    pushes = []
    for _ in range(count):
        distance, direction = rng.uniform(*HARD_PUSH_DISTANCE_M), rng.uniform(-math.pi, math.pi)
        turn = math.radians(rng.uniform(-HARD_PUSH_TURN_DEG, HARD_PUSH_TURN_DEG))
        pushes.append(Disturbance(distance * math.cos(direction), distance * math.sin(direction), turn, after_s))
    return pushes


def hard_push(candidates: list[Disturbance], table, com_xy) -> Disturbance | None:
    """The first candidate that leaves the object's centre of mass (now at ``com_xy``) at least
    :data:`HARD_PUSH_COM_INSIDE_M` inside ``table`` (a :class:`~slideplan.world.geometry.SupportSurface`), or None."""
    com = np.asarray(com_xy, dtype=float)
    for push in candidates:
        if table.edge_margin(com + (push.dx, push.dy)) >= HARD_PUSH_COM_INSIDE_M:
            return push
    return None
