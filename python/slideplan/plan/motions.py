"""Kinematic motions, no physics: straight fingertip lines solved a centimetre at a time, ways timed from
rest to rest (:func:`rest_to_rest`), joint references read off timed paths, a plan's segment times, and the reach to a slide's
first contact (a move the plan does not hold: the arm starts wherever it is), checked for collisions with
the table, clutter and object. The MuJoCo runner (:mod:`slideplan.sim.runner`), the closed loop
(:mod:`slideplan.loop.decisions`) and the ROS node (:mod:`slideplan.ros.task`, :mod:`slideplan.ros.execution`) move
the arm with them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely

from .. import _core
from ..errors import InputError
from ..world.objects import ThinObject
from .config import PlannerConfig
from .result import PlanResult
from .timing import NEAR_TABLE_M, time_path

def straight_up(robot, config: np.ndarray, height: float) -> np.ndarray | None:
    """Configurations taking the fingertip from where it is at ``config`` ``height`` straight up:
    :func:`straight_line` by (0, 0, ``height``)."""
    return straight_line(robot, config, (0.0, 0.0, height))


def straight_line(robot, config: np.ndarray, offset) -> np.ndarray | None:
    """Configurations taking the fingertip from where it is at ``config`` along the straight line to
    ``offset`` (m, world frame) from there, its orientation kept (its yaw free for an arm with fewer than
    six joints, as the planner's contact), ``_core.LIFT_STEP_M`` apart, each IK seeded by the one before;
    None where a step has no IK or turns a joint more than ``_core.LIFT_JOINT_STEP_RAD``. The core's
    ``straight_line``, the one the planner's lift check makes with the grasp frame: one IK call for the
    whole move may land on another branch of the arm, and the joint-linear move there swings the hand
    through the table and the object."""
    return _core.straight_line(robot, np.asarray(config, dtype=float), np.asarray(offset, dtype=float),
                               options=_core.contact_ik_options(robot), rng_seed=0)


def rest_to_rest(robot, path: np.ndarray, limits: dict[str, Any], name: str, *, capped: bool = True,
                 top: float | None = None) -> dict[str, np.ndarray]:
    """The timing of ``path``'s configurations from rest to rest under ``limits``
    (:func:`slideplan.plan.timing.time_path`, the fingertip where ``robot`` puts it): the moves a plan does not
    hold (the lift after the grasp, the closed loop's look from clear, its reach to a new contact, a slide
    re-timed from where it stopped). ``name`` names it in a timing error.

    Args:
        capped: the fingertip's speed capped all the way (True) or nowhere (False).
        top: the object's top (m): capped only where the fingertip is within ``NEAR_TABLE_M`` above it, as a
            plan's approach is (the look from clear: up off the object, across high above it, and back down).

    Returns:
        ``{"time_from_start": (M,), "velocities": (M, dof), "accelerations": (M, dof)}``.
    """
    tips = np.array([np.asarray(robot.fk(config))[:3, 3] for config in path])
    near = np.full(len(path), capped) if top is None else tips[:, 2] < top + NEAR_TABLE_M
    return time_path(path, tips, near, limits, name)


def reference(path: np.ndarray, times: np.ndarray, t: float) -> np.ndarray:
    """Joint reference at time ``t`` by linear interpolation (held at the ends)."""
    if t >= times[-1]:
        return path[-1]
    index = int(np.searchsorted(times, t, side="right")) - 1
    index = max(0, min(index, len(times) - 2))
    span = times[index + 1] - times[index]
    fraction = 0.0 if span <= 0 else (t - times[index]) / span
    return path[index] + fraction * (path[index + 1] - path[index])


def references(path: np.ndarray, times: np.ndarray, at: np.ndarray) -> np.ndarray:
    """:func:`reference` at each of the times ``at`` (s), as one (len(at), dof) array."""
    path, times, at = np.asarray(path, dtype=float), np.asarray(times, dtype=float), np.asarray(at, dtype=float)
    if len(times) < 2:
        return np.repeat(path[-1:], len(at), axis=0)
    index = np.clip(np.searchsorted(times, at, side="right") - 1, 0, len(times) - 2)
    span = times[index + 1] - times[index]
    fraction = np.where(span <= 0, 0.0, (at - times[index]) / np.where(span <= 0, 1.0, span))
    out = path[index] + fraction[:, None] * (path[index + 1] - path[index])
    out[at >= times[-1]] = path[-1]
    return out



def timing_of(timing: dict[str, Any] | None, key: str, length: int) -> np.ndarray | None:
    """``timing[key].time_from_start`` of a ``slideplan.plan/2`` timing block, if it fits the path."""
    if not timing or key not in timing:
        return None
    times = np.asarray(timing[key].get("time_from_start", []), dtype=float)
    if times.shape != (length,) or not np.all(np.isfinite(times)) or np.any(np.diff(times) < 0):
        raise InputError(f"expected {length} non-decreasing times", field=f"timing.{key}.time_from_start")
    return times - times[0]


def plan_times(result: PlanResult, key: str, length: int) -> np.ndarray:
    """:func:`timing_of` a plan that must be timed: its ``key`` segment's times from its start.

    Raises:
        InputError: the plan has no timing block, or its times do not fit the path.
    """
    times = timing_of(result.timing, key, length)
    if times is None:
        raise InputError("the plan has no timing block", field="timing")
    return times


# ----------------------------------------------------------------------------- the reach to a first contact

REACH_CLEARANCE_M = 0.15  # or by way of this much higher, where the direct move collides
REACH_STEP_RAD = 0.02  # the reach is checked for collisions this densely (joint space)


class Unreachable(Exception):
    """No collision-free reach to the first contact (the message says why, naming the links)."""


def collision_world(result: PlanResult, obj: ThinObject):
    """The plan's robot, table, clutter and object (a prism over its cloud's hull) for collision checks."""
    world = result.collision_world()
    hull = np.asarray(shapely.MultiPoint(obj.points[:, :2]).convex_hull.exterior.coords)[:-1]
    world.set_object(hull, float(result.table["height"]) + obj.thickness)
    return world


def dense(configs: list[np.ndarray]) -> np.ndarray:
    """Joint-linear segments between ``configs``, no step longer than REACH_STEP_RAD."""
    path = [configs[0]]
    for start, end in zip(configs, configs[1:]):
        count = max(1, int(math.ceil(np.abs(end - start).max() / REACH_STEP_RAD)))
        path.extend(start + (end - start) * fraction for fraction in np.linspace(0.0, 1.0, count + 1)[1:])
    return np.array(path)


def reach_path(result: PlanResult, obj: ThinObject, current, *, pressed: bool = False) -> np.ndarray:
    """From the arm's configuration ``current`` to the slide's first contact: joint-linear to a
    configuration with the fingertip the plan's ``approach_height`` above the object there (the planner
    kept only a first contact it can rise from so), or else by way of one
    REACH_CLEARANCE_M higher still, or else up to that height first, across and down (every link clear
    of table, clutter and object on the way), then
    down onto the contact (the finger may touch the object there, as while sliding). ``pressed``: the
    finger is on the table or the object now (a slide ended): it rises as high straight up first.

    Raises:
        Unreachable: no IK above the contact, or a collision on every way, naming the links.
    """
    robot = result.robot_model()
    start = np.asarray(result.start_config, dtype=float)
    world = collision_world(result, obj)

    top = float(result.table["height"]) + obj.thickness
    tip = np.asarray(robot.fk(start))
    hover = float(result.params.get("approach_height", PlannerConfig().approach_height))  # older plans: the default

    def above(height: float, seed: np.ndarray, pose: np.ndarray = tip) -> np.ndarray:
        """A configuration with the fingertip (at the start's pose) ``height`` above the object's top (the
        start presses below it): the high way points, reached by joint-linear moves checked for collisions."""
        target = pose.copy()
        target[2, 3] = max(target[2, 3], top) + height
        config = robot.ik(target, seed=seed, rng_seed=0, options=_core.contact_ik_options(robot))
        if config is None:
            raise Unreachable(f"no inverse kinematics {100 * height:.0f} cm above the object at the first contact")
        return np.asarray(config)

    def blocked(path: np.ndarray, mode) -> list:
        """The colliding pairs of the first configuration of ``path`` in collision, or []."""
        for config in path:
            if not world.is_valid(config, mode):
                return world.collisions(config, mode)
        return []

    def up_from(config: np.ndarray, what: str) -> np.ndarray:
        """Straight up from ``config`` to ``hover`` above the object's top, a centimetre at a time (one IK
        call for the whole height may land on another branch of the arm)."""
        z = float(np.asarray(robot.fk(config))[2, 3])
        way = straight_up(robot, config, max(z, top) + hover - z)
        if way is None:
            raise Unreachable(f"no inverse kinematics straight up {100 * hover:.0f} cm above the object {what}")
        return dense(list(way))

    up = up_from(start, "at the first contact")
    above_contact, down = up[-1], up[::-1]
    if blocked(down, _core.ContactMode.SLIDING):
        raise Unreachable(f"the move down onto the first contact from {100 * hover:.0f} cm above collides")
    current = np.asarray(current, dtype=float)
    rise = np.zeros((0, len(current)))
    if pressed:
        rise = up_from(current, "from where the finger is")
        if blocked(rise, _core.ContactMode.SLIDING):
            raise Unreachable("lifting the finger off collides")
        current, rise = rise[-1], rise[:-1]
    pairs: list = []
    high = hover + REACH_CLEARANCE_M
    # Straight across; by way of high above the contact; or up first, across high, and down (a joint-linear
    # move from a finger on the object to high above a new contact can dip into the object on the way).
    ways = (lambda: [current, above_contact], lambda: [current, above(high, above_contact), above_contact],
            lambda: [current, above(high, current, np.asarray(robot.fk(current))), above(high, above_contact),
                     above_contact])
    for way in ways:
        try:
            path = dense(way())
        except Unreachable:  # no inverse kinematics that high: the next way
            continue
        pairs = blocked(path, _core.ContactMode.FREE)
        if not pairs:
            return np.vstack([rise, path, down[1:]])
    names = ", ".join(f"{first}-{second}" for first, second in pairs[:3])
    raise Unreachable(f"the joint-space move from the current configuration to above the first contact collides "
                           f"({names}), also by way of {100 * high:.0f} cm above it: move the arm clear first")
