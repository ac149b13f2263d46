"""What an execution reports: :class:`Execution`, and the plan features it is read against."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import jsontext
from ..plan.result import PlanResult
from ..transforms import row_to_pose, wrap_angle
from ..transforms import contact_angles

EXECUTION_SCHEMA = "slideplan.execution/1"
STAGES = ("slide", "release", "grasp", "simulation")


@dataclass
class Execution(jsontext.Document):
    """What happened when a plan was executed (:func:`execute`).

    Attributes:
        success: the object ended within tolerance of Eq. 2, stayed on the table and was lifted.
        failed_stage: None, or where it failed: ``"slide"`` (the object did not follow the finger),
            ``"release"`` (it fell off the table), ``"grasp"`` (not lifted) or ``"simulation"``
            (the simulation went unstable; poses are then None).
        failure: one line saying what went wrong ("" on success).
        predicted_motion: Eq. 2's ``{x, y, yaw}`` from the plan.
        actual_motion: the object's measured planar motion after the slide (same convention), or None.
        position_error_m: distance between the measured and predicted centre of mass, or None.
        yaw_error_deg: measured minus predicted yaw (degrees, wrapped), or None.
        overhang_m: overhang ``u`` at the measured pose, or None.
        com_margin_m: signed distance of the measured centre of mass inside the table edge, or None.
        planned_com_margin_m: the same at the planned final pose.
        normal_force_n: mean, min and max fingertip normal force while sliding (N).
        lifted: the grasp lifted the object and held it.
        tip_path_m: the plan's fingertip path length (m).
        yaw_travel_deg: the plan's total fingertip yaw travel (degrees).
        sim_time_s: simulated time (s).
        wall_time_s: wall time of the simulation (s).
        settings: the :class:`ExecutionSettings` used.
    """

    JSON_ALLOWS_NAN = False

    success: bool
    failed_stage: str | None
    failure: str
    predicted_motion: dict[str, float]
    actual_motion: dict[str, float] | None
    position_error_m: float | None
    yaw_error_deg: float | None
    overhang_m: float | None
    com_margin_m: float | None
    planned_com_margin_m: float
    normal_force_n: dict[str, float]
    lifted: bool
    tip_path_m: float
    yaw_travel_deg: float
    sim_time_s: float
    wall_time_s: float
    settings: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Return the report as JSON-ready dicts, ``schema`` first (no NaN anywhere)."""
        return {"schema": EXECUTION_SCHEMA, **dataclasses.asdict(self)}

    def summary(self) -> str:
        """One line: the verdict and the numbers."""
        if self.failed_stage == "simulation":
            return f"failed: {self.failure}"
        verdict = "ok" if self.success else f"failed at {self.failed_stage}: {self.failure}"
        return (
            f"{verdict}; Eq. 2 error {1000 * self.position_error_m:.1f} mm / {self.yaw_error_deg:.1f} deg, "
            f"overhang {100 * self.overhang_m:.1f} cm, CoM {1000 * self.com_margin_m:.1f} mm inside the table, "
            f"normal force {self.normal_force_n['mean']:.1f} N, lifted {'yes' if self.lifted else 'no'} "
            f"({self.sim_time_s:.1f} s simulated in {self.wall_time_s:.1f} s, "
            f"{self.sim_time_s / max(self.wall_time_s, 1e-9):.1f}x real time)"
        )



def path_features(result: PlanResult) -> tuple[float, float]:
    """Fingertip path length and total yaw travel of a plan's sliding trajectory.

    Args:
        result: a solved plan.

    Returns:
        ``(path_m, yaw_travel_rad)``.
    """
    poses = [row_to_pose(row) for row in result.fingertip_poses]
    positions = np.array([pose[:3, 3] for pose in poses])
    yaws = [contact_angles(pose)[0] for pose in poses]
    path = float(np.sum(np.linalg.norm(np.diff(positions, axis=0), axis=1))) if len(poses) > 1 else 0.0
    travel = float(sum(abs(wrap_angle(b - a)) for a, b in zip(yaws, yaws[1:])))
    return path, travel

