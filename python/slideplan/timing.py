"""Time parameterization of a plan: the ``timing`` block of ``slideplan.plan/2`` (docs/design.md 5).

A plan's paths are dense geometric paths; a controller needs times, velocities and
accelerations. :func:`parameterize` gives each segment (the slide, ``trajectory``, and the
move to the grasp, ``grasp.approach``) a time-optimal profile under

- joint velocity limits from the URDF's ``<limit velocity>`` (a missing, zero or negative value
  falls back to :data:`DEFAULT_JOINT_VELOCITY` with a :class:`LimitWarning` naming the joint);
- joint acceleration limits (URDF has none): :data:`DEFAULT_JOINT_ACCELERATION` unless given;
- a cap on the fingertip speed (default :data:`DEFAULT_FINGERTIP_SPEED`, 5 cm/s) while it slides
  the object, and wherever the approach has the fingertip within :data:`NEAR_TABLE_M` of the
  object's top: the object must follow the finger (Eq. 2) and nothing may hit the table fast.

Why toppra: these are path-following limits on a fixed path (the planner's path must be followed
exactly, it lies on the contact manifold), which is what TOPP-RA solves, time-optimally and in
milliseconds (the seidel LP solver, in Cython). Ruckig generates jerk-limited motions between
states and would leave the path.

Each segment starts and ends at rest and gets one entry per waypoint. TOPP-RA enforces the limits
at its grid points only; the profile is then checked by finite differences between waypoints (as
tests/python/test_timing.py checks it, independent of toppra) and, if any limit is exceeded there,
slowed down uniformly until none is (:func:`_stretch_factor`; docs/parameters.md gives how much).
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from ._fields import is_number
from .errors import InputError
from .planning import plan_robot

if TYPE_CHECKING:
    from .planning import PlanResult

DEFAULT_JOINT_VELOCITY = 1.0  # rad/s, for joints whose URDF velocity limit is missing, zero or negative
DEFAULT_JOINT_ACCELERATION = 1.0  # rad/s^2: gentle for a cable-driven arm pressing a finger on an object
DEFAULT_FINGERTIP_SPEED = 0.05  # m/s while sliding: the object must follow the fingertip
NEAR_TABLE_M = 0.02  # approach waypoints with the fingertip this close above the object's top are capped too
SEGMENTS = ("trajectory", "approach")  # timing keys; "approach" times grasp.approach
_CORNER_SUBDIVISIONS = 6  # TOPP-RA grid points per waypoint interval at a corner of the path (elsewhere 1)
_CORNER_CURVATURE = 4.0  # an interval is at a corner if |q''(s)| at an end exceeds this many times its median
_STRAIGHT = 1e-3  # |q''(s)| (1/rad) below which a path is straight whatever the median
_MIN_PATH_STEP = 1e-6  # path-parameter step for repeated waypoints, so that time still increases strictly


class LimitWarning(UserWarning):
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


def urdf_velocity_limits(robot_block: dict[str, Any], joint_names: Sequence[str]) -> np.ndarray:
    """The ``<limit velocity>`` of each joint of a plan's robot.

    Args:
        robot_block: the plan's ``robot`` block (its URDF, attached fragments, chain).
        joint_names: the joints, in configuration order (for messages).

    Returns:
        (dof,) limits (rad/s); :data:`DEFAULT_JOINT_VELOCITY` for a joint whose limit is missing,
        zero or negative, with one :class:`LimitWarning` naming those joints.

    Raises:
        InputError: the robot cannot be loaded, naming the file.
    """
    declared = np.asarray(plan_robot(robot_block).velocity_limits, dtype=float)
    # urdfdom reads a missing velocity attribute as 0, so the two cannot be told apart.
    defaulted = [f"{name} ({value:g})" if value else f"{name} (0 or missing)" for name, value in zip(joint_names, declared)
                 if not value > 0]
    if defaulted:
        warnings.warn(
            f"{robot_block['urdf']}: velocity limit missing, zero or negative for {', '.join(defaulted)}; "
            f"using the default {DEFAULT_JOINT_VELOCITY} rad/s",
            LimitWarning,
            stacklevel=2,
        )
    return np.where(declared > 0, declared, DEFAULT_JOINT_VELOCITY)


def resolve_limits(result: PlanResult, options: TimingOptions | None = None) -> dict[str, Any]:
    """The limits a parameterization of ``result`` uses (the ``timing.limits`` block).

    Args:
        result: the plan (its robot URDF and joint names).
        options: limits to use instead of the defaults (None: all defaults).

    Returns:
        ``{"joint_velocity": (dof,), "joint_acceleration": (dof,), "fingertip_speed": float}``.

    Raises:
        InputError: a per-joint option of the wrong length, or an unreadable URDF.
    """
    options = options or TimingOptions()
    dof = len(result.joint_names)
    if options.joint_velocity is None:
        velocity = urdf_velocity_limits(result.robot, result.joint_names)
    else:
        velocity = _per_joint(options.joint_velocity, dof, "joint_velocity")
    return {
        "joint_velocity": velocity,
        "joint_acceleration": _per_joint(options.joint_acceleration, dof, "joint_acceleration"),
        "fingertip_speed": float(options.fingertip_speed),
    }


def _per_joint(value, dof: int, name: str) -> np.ndarray:
    """One value per joint from a number or a sequence of ``dof`` numbers."""
    values = np.full(dof, float(value)) if is_number(value) else np.asarray(value, dtype=float)
    if values.shape != (dof,):
        raise InputError(f"expected one number or {dof} (one per joint), got {len(values)}", field=name)
    return values


def parameterize(result: PlanResult, options: TimingOptions | None = None) -> dict[str, Any]:
    """Time-parameterize a solved plan's slide and approach (the ``timing`` block).

    Args:
        result: a solved plan.
        options: limits (None: URDF velocities and the documented defaults).

    Returns:
        ``{"trajectory": segment, "approach": segment, "limits": limits}``, each segment
        ``{"time_from_start": (M,), "velocities": (M, dof), "accelerations": (M, dof)}`` with one
        row per waypoint, starting at t = 0 and at rest, ending at rest.

    Raises:
        InputError: the plan is not solved, an option is malformed, the URDF is unreadable, or the
            path cannot be parameterized (toppra fails).
    """
    if not result.solved:
        raise InputError(f"cannot time a plan that is not solved (status {result.status!r})", field="status")
    limits = resolve_limits(result, options)
    robot = plan_robot(result.robot)
    object_top = float(result.table["height"]) + float(result.object["thickness"])
    approach = np.asarray(result.grasp["approach"], dtype=float).reshape(-1, len(result.joint_names))
    approach_tips = np.array([np.asarray(robot.fk(config))[:3, 3] for config in approach]).reshape(-1, 3)
    return {
        "trajectory": time_path(
            np.asarray(result.trajectory, dtype=float),
            np.asarray(result.fingertip_poses, dtype=float)[:, :3],
            np.ones(len(result.trajectory), dtype=bool),
            limits,
            "trajectory",
        ),
        "approach": time_path(approach, approach_tips, approach_tips[:, 2] < object_top + NEAR_TABLE_M, limits, "approach"),
        "limits": limits,
    }


def time_path(path: np.ndarray, tips: np.ndarray, capped: np.ndarray, limits: dict[str, Any], name: str) -> dict[str, np.ndarray]:
    """Time one dense joint path from rest to rest (TOPP-RA, then the finite-difference check).

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
        InputError: toppra finds no parameterization (a path it cannot follow at rest-to-rest).
    """
    count, dof = path.shape
    if count < 2:
        return {"time_from_start": np.zeros(count), "velocities": np.zeros((count, dof)), "accelerations": np.zeros((count, dof))}
    import toppra  # here, not at the top: see _path_speed_constraint
    from scipy.interpolate import CubicSpline

    # Path parameter: joint-space arc length, so that |dq/ds| is about 1 everywhere.
    steps = np.maximum(np.linalg.norm(np.diff(path, axis=0), axis=1), _MIN_PATH_STEP)
    waypoint_s = np.concatenate([[0.0], np.cumsum(steps)])
    geometric_path = toppra.SplineInterpolator(waypoint_s, path, bc_type="natural")
    # Grid points: the waypoints, and more at corners (the approach's straight pieces meet at
    # corners), where the path's direction changes between waypoints faster than toppra would see.
    # On the benchmark plans this halves the slow-down of _stretch_factor at less cost than
    # subdividing every interval.
    curvature = np.linalg.norm(geometric_path(waypoint_s, 2), axis=1)
    corner = np.maximum(curvature[:-1], curvature[1:]) > max(_CORNER_CURVATURE * np.median(curvature), _STRAIGHT)
    subdivisions = np.where(corner, _CORNER_SUBDIVISIONS, 1)
    if count == 2:
        subdivisions[:] = 2  # rest to rest needs a grid point in between
    grid = np.concatenate(
        [np.linspace(waypoint_s[i], waypoint_s[i + 1], subdivisions[i], endpoint=False) for i in range(count - 1)]
        + [waypoint_s[-1:]]
    )
    at_waypoints = np.concatenate([[0], np.cumsum(subdivisions)])
    tip_rate = np.linalg.norm(CubicSpline(waypoint_s, tips, bc_type="natural")(grid, 1), axis=1)
    grid_capped = np.repeat(capped[:-1] | capped[1:], subdivisions).tolist() + [bool(capped[-1])]
    speed = _path_speed_constraint()(limits["joint_velocity"], tip_rate, np.array(grid_capped), limits["fingertip_speed"])
    acceleration = toppra.constraint.JointAccelerationConstraint(
        limits["joint_acceleration"], discretization_scheme=toppra.constraint.DiscretizationType.Collocation
    )
    solver = toppra.algorithm.TOPPRA([speed, acceleration], geometric_path, gridpoints=grid, solver_wrapper="seidel")
    sdd, sd, _ = solver.compute_parameterization(0.0, 0.0)
    if sd is None or not np.all(np.isfinite(sd)):
        raise InputError("toppra found no rest-to-rest time parameterization of this path", field=f"timing.{name}")
    sd[[0, -1]] = 0.0  # toppra returns rest to within 1e-9; the contract says exactly zero
    with np.errstate(divide="ignore"):
        grid_dt = 2.0 * np.diff(grid) / (sd[:-1] + sd[1:])
    if not np.all(np.isfinite(grid_dt)):  # toppra stopped the path somewhere in the middle
        raise InputError("toppra found no rest-to-rest time parameterization of this path", field=f"timing.{name}")
    grid_t = np.concatenate([[0.0], np.cumsum(grid_dt)])
    s_rate, s_accel = sd[at_waypoints], np.append(sdd, sdd[-1])[at_waypoints]  # accel. of the interval that starts there
    first, second = geometric_path(waypoint_s, 1), geometric_path(waypoint_s, 2)
    times = grid_t[at_waypoints]
    velocities = first * s_rate[:, None]
    velocities[[0, -1]] = 0.0  # at rest, written as 0.0 rather than -0.0
    accelerations = first * s_accel[:, None] + second * (s_rate**2)[:, None]
    scale = _stretch_factor(path, tips, capped, times, velocities, accelerations, limits)
    return {"time_from_start": times * scale, "velocities": velocities / scale, "accelerations": accelerations / scale**2}


def _stretch_factor(path, tips, capped, times, velocities, accelerations, limits) -> float:
    """The uniform slow-down (>= 1) after which every limit holds at and between waypoints.

    Slowing time by ``c`` divides velocities by ``c`` and accelerations by ``c**2``. Checked: the
    reported velocities and accelerations; finite differences of positions (velocity), of
    velocities (acceleration), second differences of positions (acceleration, from rest at the
    ends) and of fingertip positions over capped intervals (speed).

    Args:
        path: (M, dof) waypoints.
        tips: (M, 3) fingertip positions.
        capped: (M,) where the fingertip cap applies.
        times: (M,) time from start.
        velocities, accelerations: (M, dof) at the waypoints.
        limits: as returned by :func:`resolve_limits`.

    Returns:
        ``c >= 1``.
    """
    vmax, amax, tip_max = limits["joint_velocity"], limits["joint_acceleration"], limits["fingertip_speed"]
    dt = np.diff(times)[:, None]
    mean_velocity = np.diff(path, axis=0) / dt
    padded = np.vstack([np.zeros((1, path.shape[1])), mean_velocity, np.zeros((1, path.shape[1]))])
    half_spans = np.concatenate([[dt[0]], (dt[:-1] + dt[1:]) / 2.0, [dt[-1]]])  # rest before and after
    half_spans[[0, -1]] /= 2.0  # from rest: q1 - q0 = a dt^2 / 2, so the span to the mean velocity is dt / 2
    second_difference = np.diff(padded, axis=0) / half_spans
    capped_intervals = capped[:-1] | capped[1:]
    tip_speed = np.linalg.norm(np.diff(tips, axis=0), axis=1)[capped_intervals] / dt[capped_intervals, 0]
    linear = max(
        np.max(np.abs(velocities) / vmax),
        np.max(np.abs(mean_velocity) / vmax),
        np.max(tip_speed / tip_max, initial=0.0),
    )
    quadratic = max(
        np.max(np.abs(accelerations) / amax),
        np.max(np.abs(np.diff(velocities, axis=0)) / dt / amax),
        np.max(np.abs(second_difference) / amax),
    )
    return max(1.0, linear, math.sqrt(quadratic))


@functools.cache
def _path_speed_constraint():
    """The class of the TOPP-RA bound on the path speed ``s'`` (built on first use, see below).

    Both limits it holds are first-order: ``|q_j'(s)| s' <= v_max_j`` per joint and
    ``|p'(s)| s' <= v_tip`` where capped; toppra takes them as an upper bound on ``x = s'^2`` at
    each grid point. Built lazily because importing toppra (matplotlib, scipy) takes about 1 s,
    which reading a plan should not pay.
    """
    import toppra

    class PathSpeedConstraint(toppra.constraint.LinearConstraint):
        """Bounds on ``s'^2`` per grid point.

        Args:
            joint_velocity: (dof,) joint velocity limits (rad/s).
            tip_rate: ``|dp/ds|`` of the fingertip at each grid point.
            capped: True at the grid points where the fingertip cap applies.
            fingertip_speed: the cap (m/s).
        """

        def __init__(self, joint_velocity, tip_rate, capped, fingertip_speed):
            super().__init__()
            self.dof = len(joint_velocity)
            self.joint_velocity, self.tip_rate, self.capped = joint_velocity, tip_rate, capped
            self.fingertip_speed = fingertip_speed

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
            """toppra's hook: only ``xbound`` is set (the other six terms are None)."""
            rates = np.abs(path(gridpoints, 1))
            with np.errstate(divide="ignore"):
                joint_bound = np.min(np.where(rates > 0, self.joint_velocity / rates, np.inf), axis=1)
                tip_bound = np.where(self.capped & (self.tip_rate > 0), self.fingertip_speed / self.tip_rate, np.inf)
            bound = np.minimum(np.minimum(joint_bound, tip_bound), 1e6)  # toppra needs a finite bound where nothing moves
            xbound = np.column_stack([np.zeros(len(gridpoints)), bound**2])
            return None, None, None, None, None, None, xbound

    return PathSpeedConstraint


def timing_from_dict(data: Any, dof: int, counts: dict[str, int]) -> dict[str, Any]:
    """Read and check a plan's ``timing`` block (``slideplan.plan/2``).

    Args:
        data: the parsed ``timing`` value.
        dof: number of joints.
        counts: waypoints per segment, ``{"trajectory": M, "approach": K}``.

    Returns:
        The block with numpy arrays.

    Raises:
        InputError: naming the field (e.g. ``timing.trajectory.time_from_start``): missing keys,
            wrong lengths, times not starting at 0 or not strictly increasing, or not at rest at
            the ends.
    """
    if not isinstance(data, dict) or set(data) != {*SEGMENTS, "limits"}:
        found = sorted(data) if isinstance(data, dict) else type(data).__name__
        raise InputError(f"expected keys {sorted({*SEGMENTS, 'limits'})}, got {found}", field="timing")
    block = {}
    for name in SEGMENTS:
        field = f"timing.{name}"
        segment = data[name]
        if not isinstance(segment, dict) or set(segment) != {"time_from_start", "velocities", "accelerations"}:
            raise InputError("expected keys time_from_start, velocities, accelerations", field=field)
        try:
            times = np.asarray(segment["time_from_start"], dtype=float).reshape(-1)
            velocities = np.asarray(segment["velocities"], dtype=float).reshape(-1, dof)
            accelerations = np.asarray(segment["accelerations"], dtype=float).reshape(-1, dof)
        except (TypeError, ValueError) as error:
            raise InputError(f"not numbers of the joints' shape ({error})", field=field) from None
        if not len(times) == len(velocities) == len(accelerations) == counts[name]:
            raise InputError(f"expected {counts[name]} entries (one per waypoint), got {len(times)}", field=field)
        if len(times) and (times[0] != 0.0 or np.any(np.diff(times) <= 0) or not np.all(np.isfinite(times))):
            raise InputError("must start at 0 and increase strictly", field=f"{field}.time_from_start")
        if len(times) and (np.any(velocities[0] != 0) or np.any(velocities[-1] != 0)):
            raise InputError("the first and last velocities must be zero", field=f"{field}.velocities")
        block[name] = {"time_from_start": times, "velocities": velocities, "accelerations": accelerations}
    limits = data["limits"]
    try:
        block["limits"] = {
            "joint_velocity": np.asarray(limits["joint_velocity"], dtype=float).reshape(dof),
            "joint_acceleration": np.asarray(limits["joint_acceleration"], dtype=float).reshape(dof),
            "fingertip_speed": float(limits["fingertip_speed"]),
        }
    except (KeyError, TypeError, ValueError) as error:
        raise InputError(f"expected joint_velocity and joint_acceleration ({dof} each) and fingertip_speed ({error})",
                         field="timing.limits") from None
    return block
