"""Time parameterization of a plan: the ``timing`` block of ``slideplan.plan/2`` (docs/design.md 5).

A plan's paths are dense geometric paths; a controller needs times, velocities and
accelerations. Each segment (the slide, ``trajectory``, and the move to the grasp,
``grasp.approach``) gets a time-optimal profile under

- joint velocity limits from the URDF's ``<limit velocity>`` (a missing, zero or negative value
  falls back to :data:`DEFAULT_JOINT_VELOCITY` with a :class:`LimitWarning` naming the joint);
- joint acceleration limits (URDF has none): :data:`DEFAULT_JOINT_ACCELERATION` unless given;
- a cap on the fingertip speed (default :data:`DEFAULT_FINGERTIP_SPEED`, 5 cm/s) while it slides
  the object, and wherever the approach has the fingertip within :data:`NEAR_TABLE_M` of the
  object's top: the object must follow the finger (Eq. 2) and nothing may hit the table fast.

The profile is TOPP-RA's (time-optimal path parameterization by reachability analysis: the
planner's path must be followed exactly, it lies on the contact manifold), computed in C++
(``cpp/src/timing.cpp``): :func:`slideplan.plan` times a solved plan inside the planner call,
without the GIL, and :func:`parameterize` re-times a plan under other limits. Each segment starts
and ends at rest and gets one entry per waypoint. TOPP-RA enforces the limits at its grid points;
the profile is then checked by finite differences between waypoints and, if any limit is exceeded
there, slowed down uniformly until none is (docs/parameters.md gives how much).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from .. import _core
from .._fields import is_number
from ..errors import InputError, SlideplanWarning
from .result import PlanResult

DEFAULT_JOINT_VELOCITY = 1.0  # rad/s, for joints whose URDF velocity limit is missing, zero or negative
DEFAULT_JOINT_ACCELERATION = 1.0  # rad/s^2: gentle for a cable-driven arm pressing a finger on an object
DEFAULT_FINGERTIP_SPEED = 0.05  # m/s while sliding: the object must follow the fingertip
NEAR_TABLE_M = _core.NEAR_TABLE_M  # approach waypoints with the fingertip this close above the object's top are capped too


class LimitWarning(SlideplanWarning):
    """A URDF velocity limit is missing, zero or negative; the documented default is used."""


@dataclass(frozen=True)
class TimingOptions:
    """Limits of the time parameterization (every field is checked on construction).

    Attributes:
        joint_acceleration: per-joint acceleration limits (rad/s^2): one number for all joints or
            one per joint; default :data:`DEFAULT_JOINT_ACCELERATION`.
        fingertip_speed: largest fingertip speed while sliding and near the table (m/s).
        joint_velocity: per-joint velocity limits (rad/s) replacing the URDF's, or None to read
            them from the URDF.

    Raises:
        InputError: a limit that is not a finite number > 0, naming the field.
    """

    joint_acceleration: float | Sequence[float] = DEFAULT_JOINT_ACCELERATION
    fingertip_speed: float = DEFAULT_FINGERTIP_SPEED
    joint_velocity: Sequence[float] | None = None

    def __post_init__(self) -> None:
        for name in ("joint_acceleration", "fingertip_speed", "joint_velocity"):
            value = getattr(self, name)
            if value is None and name == "joint_velocity":
                continue
            values = [value] if is_number(value) else value
            if not isinstance(values, (list, tuple, np.ndarray)) or not len(values) or not all(
                is_number(item) and math.isfinite(item) and item > 0 for item in values
            ):
                raise InputError(f"expected finite numbers > 0, got {value!r}", field=name)


def urdf_velocity_limits(declared: Sequence[float], urdf: str, joint_names: Sequence[str]) -> np.ndarray:
    """The ``<limit velocity>`` of each joint, with the default where the URDF has none.

    Args:
        declared: the URDF's limits (``RobotModel.velocity_limits``; urdfdom reads a missing
            attribute as 0, so the two cannot be told apart).
        urdf: the URDF's name, for the warning.
        joint_names: the joints, in configuration order (for the warning).

    Returns:
        (dof,) limits (rad/s); :data:`DEFAULT_JOINT_VELOCITY` for a joint whose limit is missing,
        zero or negative, with one :class:`LimitWarning` naming those joints.
    """
    declared = np.asarray(declared, dtype=float)
    defaulted = [f"{name} ({value:g})" if value else f"{name} (0 or missing)" for name, value in zip(joint_names, declared)
                 if not value > 0]
    if defaulted:
        warnings.warn(
            f"{urdf}: velocity limit missing, zero or negative for {', '.join(defaulted)}; "
            f"using the default {DEFAULT_JOINT_VELOCITY} rad/s",
            LimitWarning,
            stacklevel=3,
        )
    return np.where(declared > 0, declared, DEFAULT_JOINT_VELOCITY)


def robot_limits(robot, urdf: str, joint_names: Sequence[str], options: TimingOptions | None = None) -> dict[str, Any]:
    """The limits a parameterization for ``robot`` uses (the ``timing.limits`` block).

    Args:
        robot: the ``_core.RobotModel`` (its URDF velocity limits).
        urdf: the URDF's name, for the warning on missing limits.
        joint_names: the joints, in configuration order.
        options: limits to use instead of the defaults (None: all defaults).

    Returns:
        ``{"joint_velocity": (dof,), "joint_acceleration": (dof,), "fingertip_speed": float}``.

    Raises:
        InputError: a per-joint option of the wrong length.
    """
    options = options or TimingOptions()
    dof = len(joint_names)
    if options.joint_velocity is None:
        velocity = urdf_velocity_limits(robot.velocity_limits, urdf, joint_names)
    else:
        velocity = _per_joint(options.joint_velocity, dof, "joint_velocity")
    return {
        "joint_velocity": velocity,
        "joint_acceleration": _per_joint(options.joint_acceleration, dof, "joint_acceleration"),
        "fingertip_speed": float(options.fingertip_speed),
    }


def resolve_limits(result: PlanResult, options: TimingOptions | None = None) -> dict[str, Any]:
    """The limits a parameterization of ``result`` uses (:func:`robot_limits` of its robot).

    Raises:
        InputError: a per-joint option of the wrong length, or an unreadable URDF.
    """
    return robot_limits(result.robot_model(), result.robot["urdf"], result.joint_names, options)


def core_limits(limits: dict[str, Any]) -> _core.TimingLimits:
    """The C++ form of a ``timing.limits`` block."""
    return _core.TimingLimits(joint_velocity=limits["joint_velocity"], joint_acceleration=limits["joint_acceleration"],
                              fingertip_speed=limits["fingertip_speed"])


def _per_joint(value, dof: int, name: str) -> np.ndarray:
    """One value per joint from a number or a sequence of ``dof`` numbers."""
    values = np.full(dof, float(value)) if is_number(value) else np.asarray(value, dtype=float)
    if values.shape != (dof,):
        raise InputError(f"expected one number or {dof} (one per joint), got {len(values)}", field=name)
    return values


def parameterize(result: PlanResult, options: TimingOptions | None = None) -> dict[str, Any]:
    """Time-parameterize a solved plan's slide and approach (the ``timing`` block), e.g. under other
    limits than :func:`slideplan.plan` used.

    Args:
        result: a solved plan.
        options: limits (None: URDF velocities and the documented defaults).

    Returns:
        ``{"trajectory": segment, "approach": segment, "limits": limits}``, each segment
        ``{"time_from_start": (M,), "velocities": (M, dof), "accelerations": (M, dof)}`` with one
        row per waypoint, starting at t = 0 and at rest, ending at rest.

    Raises:
        InputError: the plan is not solved, an option is malformed, the URDF is unreadable, or a
            path has no rest-to-rest parameterization.
    """
    if not result.solved:
        raise InputError(f"cannot time a plan that is not solved (status {result.status!r})", field="status")
    limits = resolve_limits(result, options)
    try:
        timing = _core.time_plan(
            robot=result.robot_model(), trajectory=np.asarray(result.trajectory, dtype=float),
            trajectory_tips=np.asarray(result.fingertip_poses, dtype=float)[:, :3],
            approach=np.asarray(result.grasp["approach"], dtype=float).reshape(-1, len(result.joint_names)),
            object_top_z=result.object_top, limits=core_limits(limits),
        )
    except (ValueError, RuntimeError) as error:
        raise InputError(str(error), field="timing") from None
    return {**timing, "limits": limits}


def time_path(path: np.ndarray, tips: np.ndarray, capped: np.ndarray, limits: dict[str, Any], name: str) -> dict[str, np.ndarray]:
    """Time one dense joint path from rest to rest (as :func:`parameterize` times each segment).

    Args:
        path: (M, dof) waypoints.
        tips: (M, 3) fingertip positions at the waypoints (world frame).
        capped: (M,) True where the fingertip speed cap applies (an interval is capped when
            either of its ends is).
        limits: as returned by :func:`resolve_limits`.
        name: the segment's name, for error messages.

    Returns:
        ``{"time_from_start": (M,), "velocities": (M, dof), "accelerations": (M, dof)}``.

    Raises:
        InputError: malformed input, or no rest-to-rest parameterization, naming ``timing.<name>``.
    """
    try:
        return _core.time_path(path=np.asarray(path, dtype=float), tips=np.asarray(tips, dtype=float).reshape(-1, 3),
                               capped=[bool(flag) for flag in capped], limits=core_limits(limits))
    except (ValueError, RuntimeError) as error:
        raise InputError(str(error), field=f"timing.{name}") from None
