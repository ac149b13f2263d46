"""Physical parameters of an execution (docs/execution.md gives the defaults and why)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .._fields import as_number
from ..errors import InputError


@dataclass(frozen=True)
class ExecutionSettings:
    """Physical parameters of an execution (defaults: docs/execution.md).

    The three limits time, with :func:`slideplan.plan.timing.parameterize` (TOPP-RA), the slide and the
    approach of a plan without a ``timing`` block, and the lift of every plan. Each field's unit and meaning,
    and its value in each of the closed loop's settings, are :mod:`slideplan.sim.registry`'s table
    (docs/simulation.md).
    """

    tip_speed: float = 0.05
    joint_velocity: float = 1.0
    joint_acceleration: float = 2.0
    finger_stiffness: float | None = None
    press_force: float = 4.0
    finger_damping: float = 4.0
    contact_depth: float | None = None
    torsional_friction: float = 0.01
    pad_friction: float = 1.0
    table_friction: float = 0.4
    object_density: float = 1000.0
    cell_size: float = 0.0125
    servo_bandwidth_hz: float = 15.0
    joint_armature: float = 0.01
    grip_torque: float = 0.5
    grip_force: float = 20.0
    close_speed: float = 1.5
    close_speed_linear: float = 0.05
    lift_height: float = 0.05
    hold_s: float = 1.0
    timestep: float = 0.001
    spring_scale: float = 1.0
    reference_lag_s: float = 0.0
    position_tolerance: float = 0.005
    yaw_tolerance: float = math.radians(3.0)

    def __post_init__(self) -> None:
        for item in dataclasses.fields(self):
            value = getattr(self, item.name)
            if item.name in _OPTIONAL and value is None:
                continue
            as_number(value, source="", field=item.name, positive=item.name not in _NON_NEGATIVE)
            if item.name == "reference_lag_s" and value < 0:
                raise InputError(f"must be >= 0, got {value!r}", field=item.name)


    def spring_stiffness(self, dz_min: float, dz_max: float) -> float:
        """The finger compliance's stiffness for a hand whose contact-depth band is [dz_min, dz_max] (N/m)."""
        stiffness = self.finger_stiffness if self.finger_stiffness is not None else self.press_force / (0.5 * (dz_min + dz_max))
        return self.spring_scale * stiffness


_OPTIONAL = ("contact_depth", "finger_stiffness")
_NON_NEGATIVE = ("contact_depth", "reference_lag_s")  # may be 0: no press, no lag (contact_depth: any sign)
STRESS_TORSION_FACTOR = 0.5


def stress_settings(dz_min: float) -> ExecutionSettings:
    """The stress setting: torsional friction halved, the finger pressing ``dz_min`` deep throughout.

    Args:
        dz_min: the plan's `dz_min`, the shallowest depth of its band (m).
    """
    nominal = ExecutionSettings()
    return dataclasses.replace(
        nominal, torsional_friction=STRESS_TORSION_FACTOR * nominal.torsional_friction, contact_depth=dz_min
    )
