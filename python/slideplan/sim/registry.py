"""Every simulation setting in one table, as the planner's parameters are in :mod:`slideplan.parameters`:
each physical parameter of an execution (:class:`~slideplan.sim.settings.ExecutionSettings`) and each
draw of the closed loop's settings (:mod:`slideplan.sim.conditions`), with its unit, what it is, and its
value in the nominal, stress, random and hard settings. The values are read from where the code declares
them; what each one is is said here alone. ``docs/make_simulation.py`` writes the table into
docs/simulation.md (a test keeps the page current); each result row records its setting and its draws.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from . import conditions
from .settings import STRESS_TORSION_FACTOR, ExecutionSettings

# name: (unit, what it is). Every ExecutionSettings field has a row; the others are the settings' draws.
DESCRIBED = {
    "tip_speed": ("m/s", "fingertip speed cap while sliding, near the object on the approach, and while lifting"),
    "joint_velocity": ("rad/s", "joint speed cap; the URDF's lower limits win"),
    "joint_acceleration": ("rad/s^2", "joint acceleration cap, every joint"),
    "finger_stiffness": ("N/m", "stiffness of the finger's vertical compliance; unset: `press_force` at the middle "
                                "of the plan's depth band (200 N/m for the T42)"),
    "press_force": ("N", "normal force at the middle of the depth band when `finger_stiffness` is unset"),
    "finger_damping": ("N s/m", "damping of the finger's compliance"),
    "contact_depth": ("m", "unset: the plan's depths; a number presses this deep at every waypoint (0: not at all)"),
    "torsional_friction": ("m", "torsional friction coefficient of the fingertip's pad"),
    "pad_friction": ("", "sliding friction between the pad (and the fingers) and the object"),
    "table_friction": ("", "sliding friction between the object and the table (and the clutter)"),
    "object_density": ("kg/m^3", "density of the object and of thin clutter (the draws scale it: `mass_scale`)"),
    "cell_size": ("m", "side of the boxes the object is built of"),
    "servo_bandwidth_hz": ("Hz", "closed-loop bandwidth of the arm's joint servos"),
    "joint_armature": ("kg m^2", "reflected inertia of each arm joint's geared motor"),
    "grip_torque": ("N m", "closing torque of each revolute gripper joint"),
    "grip_force": ("N", "closing force of each prismatic gripper joint"),
    "close_speed": ("rad/s", "speed of a revolute gripper joint's closing target"),
    "close_speed_linear": ("m/s", "speed of a prismatic gripper joint's closing target"),
    "lift_height": ("m", "lift of the hand after closing"),
    "hold_s": ("s", "hold after the lift, judged by the world's verdict"),
    "timestep": ("s", "simulation step"),
    "spring_scale": ("", "factor on the finger compliance's stiffness"),
    "reference_lag_s": ("s", "the arm follows its joint references this late"),
    "position_tolerance": ("m", "an executed slide ends within this distance of Eq. 2's pose..."),
    "yaw_tolerance": ("rad", "...and within this turn"),
    "depth_noise_at_1m": ("m", "the depth camera's noise (standard deviation) at 1 m, growing with the square of depth"),
    "camera_error": ("m, deg", "where the depth camera really is against where the loop believes: per axis"),
    "push": ("", "someone moves the object during the slide"),
}
SETTINGS = conditions.SETTINGS


@dataclass(frozen=True)
class Row:
    """One setting: its name, unit, what it is, and its value in each setting (as text)."""

    name: str
    unit: str
    what: str
    values: dict[str, str]


def _number(value) -> str:
    if value is None:
        return "unset"
    return f"{value:g}"


def _range(bounds) -> str:
    return f"U({bounds[0]:g}, {bounds[1]:g})"


def rows() -> list[Row]:
    """The table: every ExecutionSettings field, then the draws that are not fields."""
    nominal = ExecutionSettings()
    stress = dataclasses.replace(nominal, torsional_friction=STRESS_TORSION_FACTOR * nominal.torsional_friction)
    table = []
    for item in dataclasses.fields(ExecutionSettings):
        name = item.name
        base = getattr(nominal, name)
        values = {"nominal": _number(base), "stress": _number(getattr(stress, name)), "random": _number(base),
                  "hard": _number(base)}
        if name == "contact_depth":
            values["stress"] = "the plan's `dz_min`"
        if name in conditions.RANDOM_RANGES:
            values["random"] = _range(conditions.RANDOM_RANGES[name])
        if name in conditions.HARD_RANGES:
            values["hard"] = _range(conditions.HARD_RANGES[name])
        if name == "object_density":
            values["random"] = f"{base:g} x {_range(conditions.RANDOM_RANGES['mass_scale'])}"
            values["hard"] = f"{base:g} x {_range(conditions.HARD_RANGES['mass_scale'])}"
        if name == "reference_lag_s":
            values["hard"] = _number(conditions.HARD_LAG_S)
        if name == "yaw_tolerance":
            values = {setting: f"{math.degrees(getattr(nominal, name)):g} deg" for setting in SETTINGS}
        unit, what = DESCRIBED[name]
        table.append(Row(name, unit, what, values))
    noise = _number(conditions.DEPTH_NOISE_AT_1M)
    table.append(Row("depth_noise_at_1m", *DESCRIBED["depth_noise_at_1m"],
                     {"nominal": noise, "stress": noise, "random": _range(conditions.RANDOM_RANGES["depth_noise_at_1m"]),
                      "hard": noise}))
    table.append(Row("camera_error", *DESCRIBED["camera_error"],
                     {"nominal": "0", "stress": "0", "random": "0",
                      "hard": f"N(0, {1000 * conditions.HARD_CAMERA_POSITION_SD_M:g} mm), "
                              f"N(0, {conditions.HARD_CAMERA_ROTATION_SD_DEG:g} deg) about each axis"}))
    low, high = conditions.HARD_PUSH_DISTANCE_M
    table.append(Row("push", *DESCRIBED["push"],
                     {"nominal": "none", "stress": "none", "random": "none",
                      "hard": f"with probability {conditions.HARD_PUSH_PROBABILITY:g}: {100 * low:g}-{100 * high:g} cm and "
                              f"+-{conditions.HARD_PUSH_TURN_DEG:g} deg at a time uniform over the slide"}))
    return table


def markdown_table() -> str:
    """The table as GitHub markdown (docs/simulation.md)."""
    lines = ["| setting | unit | nominal | stress | random | hard | what it is |", "|---|---|---|---|---|---|---|"]
    for row in rows():
        cells = [f"`{row.name}`", row.unit, *(row.values[setting] for setting in SETTINGS), row.what]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
