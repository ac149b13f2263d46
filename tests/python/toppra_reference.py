"""The time parameterization as toppra (Python TOPP-RA) computes it: the cross-check of the C++ one.

slideplan times plans in C++ (cpp/src/timing.cpp), inside the planner call and without the GIL.
This is the earlier Python implementation on toppra, kept for the tests and the timing benchmark
only: the C++ profiles must match it (same limits, durations within 2%).
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

_CORNER_SUBDIVISIONS = 6  # TOPP-RA grid points per waypoint interval at a corner of the path (elsewhere 1)
_CORNER_CURVATURE = 4.0  # an interval is at a corner if |q''(s)| at an end exceeds this many times its median
_STRAIGHT = 1e-3  # |q''(s)| (1/rad) below which a path is straight whatever the median
_MIN_PATH_STEP = 1e-6  # path-parameter step for repeated waypoints, so that time still increases strictly


def time_path(path: np.ndarray, tips: np.ndarray, capped: np.ndarray, limits: dict[str, Any], name: str) -> dict[str, np.ndarray]:
    """:func:`slideplan.plan.timing.time_path` (same arguments, same result) computed by toppra.

    Raises:
        RuntimeError: toppra finds no parameterization (a path it cannot follow at rest-to-rest).
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
        raise RuntimeError(f"{name}: toppra found no rest-to-rest time parameterization")
    sd[[0, -1]] = 0.0  # toppra returns rest to within 1e-9; the contract says exactly zero
    with np.errstate(divide="ignore"):
        grid_dt = 2.0 * np.diff(grid) / (sd[:-1] + sd[1:])
    if not np.all(np.isfinite(grid_dt)):  # toppra stopped the path somewhere in the middle
        raise RuntimeError(f"{name}: toppra found no rest-to-rest time parameterization")
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
