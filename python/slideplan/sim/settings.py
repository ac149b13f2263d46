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
    approach of a plan without a ``timing`` block, and the lift of every plan.

    Attributes:
        tip_speed: fingertip speed cap (m/s) while sliding, on the approach within
            :data:`slideplan.plan.timing.NEAR_TABLE_M` of the object's top, and while lifting.
        joint_velocity: joint speed cap (rad/s); the URDF's lower limits win.
        joint_acceleration: joint acceleration cap (rad/s^2), every joint.
        finger_stiffness: stiffness of the finger's vertical compliance (N/m); None: ``press_force``
            at the middle of the plan's contact-depth band (200 N/m for the T42's 1-3 cm, 571 N/m for
            the 2-12 mm of a rigid finger's force control).
        press_force: the normal force at the middle of the band when ``finger_stiffness`` is None (N).
        finger_damping: damping of that compliance (N s/m).
        contact_depth: None follows the plan's depths; a number presses this deep (m) at every
            waypoint instead (the stress setting uses ``dz_min``; 0 does not press at all).
        torsional_friction: torsional friction coefficient of the fingertip pad (m).
        pad_friction: sliding friction coefficient between the pad (and the fingers) and the object.
        table_friction: sliding friction coefficient between object and table.
        object_density: density of the object (kg/m^3).
        cell_size: side of the object's boxes (m).
        servo_bandwidth_hz: closed-loop bandwidth of the arm's joint servos (Hz).
        joint_armature: reflected inertia of each arm joint's geared motor (kg m^2), added to the link
            inertia the servo gains follow: without it a light wrist link alone set the Z1's last joint's
            stiffness to 7 N m/rad, and the pad's friction turned the fingertip 5 deg off its reference.
        grip_torque: closing torque of each revolute gripper joint (N m).
        grip_force: closing force of each prismatic gripper joint (N).
        close_speed: speed of a revolute gripper joint's closing target (rad/s).
        close_speed_linear: speed of a prismatic gripper joint's closing target (m/s).
        lift_height: lift of the hand after closing (m).
        hold_s: hold time after the lift (s).
        timestep: simulation step (s).
        spring_scale: factor on the finger compliance's stiffness (the hard setting's draw).
        reference_lag_s: the arm follows its joint references this late (s; the hard setting's 30 ms).
        position_tolerance: a slide succeeds within this position error (m)...
        yaw_tolerance: ... and this yaw error (rad) of Eq. 2.
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
