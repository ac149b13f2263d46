"""The plan file's contract (``slideplan.plan/1`` and ``/2``, docs/design.md 5): every check of a plan
document, its timing block included, made by :func:`plan_fields` for the one loader
(:meth:`slideplan.plan.result.PlanResult.load`), and the checks of a plan's arrays that the readers
which run a plan add (:func:`check_shapes`, :func:`check_ends`)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import shapely

from .. import parameters
from .._fields import as_number, as_numbers, is_number, require_within
from .._limits import MAX_MAGNITUDE, require_waypoints
from ..errors import InputError
from ..world.geometry import SupportSurface
from .config import PlannerConfig

CONFIG_TOLERANCE = 1e-9  # rad: configurations that must be the same (approach ends)

PLAN_SCHEMA = "slideplan.plan/2"
READABLE_SCHEMAS = ("slideplan.plan/1", PLAN_SCHEMA)  # /1: the same fields without timing
STATUSES = ("solved", "timeout", "invalid")

# The plan JSON's fields that are not arrays, and what each must be.
_BLOCK_TYPES = {"status": str, "planner": str, "seed": int, "planning_time_s": (int, float), "params": dict,
                "table": dict, "object": dict, "robot": dict, "obstacles": list, "object_motion": dict,
                "overhang_m": (int, float), "joint_names": list, "grasp": dict, "stats": dict}
_KIND_WORDS = {str: "a string", int: "an integer", (int, float): "a number", dict: "a table of fields", list: "a list"}


def _check_scene_blocks(fields: dict[str, Any]) -> None:
    """The table, object and robot blocks of a plan hold what every reader of a plan (solved or not)
    needs: a simple table polygon, an object of at least 3 points with a thickness, link names.

    Raises:
        InputError: naming the field.
    """
    SupportSurface.from_vertices(fields["table"]["polygon"], fields["table"]["height"], field="table.polygon")
    points = fields["object"]["points"]
    if len(points) < 3 or shapely.MultiPoint(points[:, :2]).convex_hull.area <= 0.0:
        raise InputError(f"expected at least 3 points not on one line, got {len(points)}", field="object.points")
    for name, rows in (("fingertip_poses", fields["fingertip_poses"]), ("grasp.pose", fields["grasp"]["pose"])):
        if np.size(rows) % 7:
            continue  # misshapen: check_shapes says so
        norms = np.linalg.norm(np.reshape(rows, (-1, 7))[:, 3:], axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-6):
            index = int(np.argmax(np.abs(norms - 1.0)))
            raise InputError(f"the quaternion of row {index} has norm {norms[index]:.6g}, not 1", field=name)
    as_number(fields["object"]["thickness"], source="", field="object.thickness", positive=True)
    for key in ("urdf", "tip_link", "grasp_link"):
        if not isinstance(fields["robot"].get(key), str) or not fields["robot"][key]:
            raise InputError(f"expected a name, got {fields['robot'].get(key)!r}", field=f"robot.{key}")


def _require_finite(data: dict[str, Any]) -> None:
    """Refuse a plan dict holding a NaN, an infinite or an implausibly large number (beyond
    :data:`MAX_MAGNITUDE`) anywhere (JSON parsers accept ``NaN`` and ``1e999``; a trajectory with one
    would be executed or exported as it is), naming where.

    Raises:
        InputError: the dotted field of the first such number.
    """
    stack: list[tuple[str, Any]] = [("", data)]
    while stack:  # not recursive: a deeply nested file must not overflow Python's stack
        name, value = stack.pop()
        if isinstance(value, dict):
            stack.extend((f"{name}.{key}" if name else str(key), item) for key, item in value.items())
        elif isinstance(value, list):
            # A rectangular list of numbers (a path, a cloud) is checked at once, not number by number.
            numbers = _numbers_or_none(value)
            if numbers is None:
                stack.extend((f"{name}[{index}]", item) for index, item in enumerate(value))
            else:
                require_within(numbers, MAX_MAGNITUDE, field=name)
        elif isinstance(value, float):  # integers (seeds, counts) may be larger
            require_within(value, MAX_MAGNITUDE, field=name)


def _numbers_or_none(value: list) -> np.ndarray | None:
    """``value`` as a float array if it is a rectangular list of numbers, else None."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None


# Per obstacle shape, its plan entry's numeric keys: how many numbers (0: one), or "xy" (polygon rows),
# and whether they must be > 0.
_OBSTACLE_KEYS = {
    "box": {"center": (3, False), "size": (3, True), "yaw": (0, False)},
    "cylinder": {"center": (3, False), "radius": (0, True), "height": (0, True)},
    "object": {"polygon": ("xy", False), "bottom": (0, False), "height": (0, True)},
}


def _obstacle_entry(entry: Any, index: int) -> dict[str, Any]:
    """A checked obstacle entry of a plan with arrays; older plans' entries (boxes) get their shape.

    Raises:
        InputError: an unknown shape, a missing key or a value of the wrong size or sign, naming
            ``obstacles[index].key``.
    """
    field = f"obstacles[{index}]"
    if not isinstance(entry, dict):
        raise InputError(f"expected a table of the obstacle's keys, got {entry!r}", field=field)
    entry = {"shape": "box", **entry}
    keys = _OBSTACLE_KEYS.get(entry["shape"])
    if keys is None:
        raise InputError(f"unknown shape {entry['shape']!r} (expected one of {sorted(_OBSTACLE_KEYS)})", field=f"{field}.shape")
    missing = sorted(set(keys) - entry.keys())
    if missing:
        raise InputError(f"a {entry['shape']} needs {missing}", field=field)
    for key, (count, positive) in keys.items():
        name = f"{field}.{key}"
        if count == "xy":
            entry[key] = as_array(entry[key], 2, name)
            if len(entry[key]) < 3:
                raise InputError(f"expected at least 3 [x, y] vertices, got {len(entry[key])}", field=name)
        elif count:
            entry[key] = as_numbers(entry[key], count, source="", field=name, positive=positive)
        else:
            entry[key] = as_number(entry[key], source="", field=name, positive=positive)
    return entry


def _robot_block(robot: dict[str, Any]) -> dict[str, Any]:
    """A plan's checked robot block with 4x4 arrays; plans written before [hand] existed get its defaults.

    Raises:
        InputError: a name that is not a string, a list that is not of names, joint values that are
            not numbers, naming ``robot.<key>``.
    """
    identity = np.eye(4)
    block = {"attach": [], "base_link": "", "fixed_joints": {}, "gripper_joints": {}, "package_dirs": [],
             "tip_offset": identity, "grasp_offset": identity, **robot}
    for key in ("urdf", "base_link", "tip_link", "grasp_link"):
        if not isinstance(block.get(key), str):
            raise InputError(f"expected a name, got {block.get(key)!r}", field=f"robot.{key}")
    for key in ("attach", "package_dirs", "contact_links"):
        if not isinstance(block.get(key), list) or not all(isinstance(item, str) for item in block[key]):
            raise InputError(f"expected a list of names, got {block.get(key)!r}", field=f"robot.{key}")
    if not isinstance(block["fixed_joints"], dict) or not all(is_number(value) for value in block["fixed_joints"].values()):
        raise InputError(f"expected joint names with numbers, got {block['fixed_joints']!r}", field="robot.fixed_joints")
    gripper = block["gripper_joints"]
    if not isinstance(gripper, dict) or not all(isinstance(values, list) and len(values) == 2 and all(map(is_number, values))
                                                for values in gripper.values()):
        raise InputError(f"expected joint names with [open, closed], got {gripper!r}", field="robot.gripper_joints")
    for key in ("base_pose", "tip_offset", "grasp_offset"):
        block[key] = as_array(block[key], 4, f"robot.{key}")
    return block


def _read_params(params: dict[str, Any]) -> dict[str, Any]:
    """A plan's params block, checked by the one validator of planner parameters.

    Raises:
        InputError: a parameter missing, of the wrong type or out of its bounds, naming ``params.<name>``.
    """
    missing = [name for name in parameters.VERIFY_NAMES if name not in params]
    if missing:
        raise InputError(f"missing {missing}", field="params")
    fields = {item.name for item in dataclasses.fields(PlannerConfig)} - {"planner", "seed"}
    try:
        PlannerConfig(**{name: value for name, value in params.items() if name in fields})
    except InputError as error:
        raise InputError(error.problem, field=f"params.{error.field}" if error.field else "params") from None
    return dict(params)


def _object_motion(motion: dict[str, Any]) -> dict[str, Any]:
    """A plan's object_motion block: x, y (m) and yaw (rad)."""
    for key in ("x", "y", "yaw"):
        as_number(motion.get(key), source="", field=f"object_motion.{key}")
    return dict(motion)


def _read_timing(data: dict[str, Any]) -> dict[str, Any] | None:
    """The checked ``timing`` block of a plan dict, or None if it has none (``/1``, or null)."""
    if data.get("timing") is None:
        return None
    dof = len(data["joint_names"])
    return timing_block(data["timing"], dof, {"trajectory": len(data["trajectory"]), "approach": len(data["grasp"]["approach"])})


def as_array(value: Any, columns: int | None = None, field: str = "") -> np.ndarray:
    """A float array; with ``columns``, 2-D with that many columns (an empty list becomes (0, columns)).

    Raises:
        InputError: (with ``field``) not numbers, or rows of another length; ValueError without.
    """
    def fail(problem: str) -> Exception:
        return InputError(problem, field=field) if field else ValueError(problem)

    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise fail(f"expected numbers ({error})") from None
    if columns is None:
        return array
    if array.size == 0:
        return array.reshape(0, columns)
    if array.ndim != 2 or array.shape[1] != columns:
        raise fail(f"expected rows of {columns} numbers, got shape {array.shape}")
    return array


def plan_fields(data: Any, names: list[str]) -> dict[str, Any]:
    """Check a parsed plan document and return :class:`~slideplan.plan.result.PlanResult`'s fields with
    numpy arrays: the one place every field of a plan file is checked.

    Args:
        data: the parsed JSON.
        names: the plan's field names (``PlanResult``'s).

    Raises:
        InputError: wrong schema, unknown status, missing, unknown or misshapen fields, a path of
            over :data:`~slideplan._limits.MAX_WAYPOINTS` waypoints, or a number that is NaN,
            infinite or beyond :data:`~slideplan._limits.MAX_MAGNITUDE`.
    """
    if not isinstance(data, dict) or data.get("schema") not in READABLE_SCHEMAS:
        found = data.get("schema") if isinstance(data, dict) else type(data).__name__
        raise InputError(f"expected one of {READABLE_SCHEMAS}, got {found!r}", field="schema")
    names = set(names)
    if data["schema"] != PLAN_SCHEMA:
        names.discard("timing")
    missing = sorted(names - data.keys())
    unknown = sorted(data.keys() - names - {"schema"})
    if missing or unknown:
        raise InputError(f"missing fields {missing}, unknown fields {unknown}", field="plan")
    require_waypoints(data)
    _require_finite(data)  # before the types: an integer of over 20 digits is read as a float (parse_int)
    for name, kind in _BLOCK_TYPES.items():
        if not isinstance(data[name], kind) or isinstance(data[name], bool):
            raise InputError(f"expected {_KIND_WORDS[kind]}, got {type(data[name]).__name__}", field=name)
    if data["status"] not in STATUSES:
        raise InputError(f"unknown status {data['status']!r} (expected one of {STATUSES})", field="status")
    if not all(isinstance(name, str) for name in data["joint_names"]):
        raise InputError("expected a list of joint names", field="joint_names")
    dof = len(data["joint_names"])
    try:
        fields = dict(
            status=data["status"],
            planner=data["planner"],
            seed=data["seed"],
            planning_time_s=data["planning_time_s"],
            params=_read_params(data["params"]),
            table={**data["table"], "polygon": as_array(data["table"]["polygon"], 2, "table.polygon")},
            object={
                **data["object"],
                "points": as_array(data["object"]["points"], 3, "object.points"),
                "com_xy": as_numbers(data["object"]["com_xy"], 2, source="", field="object.com_xy"),
            },
            robot=_robot_block(data["robot"]),
            obstacles=[_obstacle_entry(entry, index) for index, entry in enumerate(data["obstacles"])],
            object_motion=_object_motion(data["object_motion"]),
            overhang_m=data["overhang_m"],
            joint_names=list(data["joint_names"]),
            start_config=as_array(data["start_config"], field="start_config"),
            goal_config=as_array(data["goal_config"], field="goal_config"),
            trajectory=as_array(data["trajectory"], dof, "trajectory"),
            fingertip_poses=as_array(data["fingertip_poses"], 7, "fingertip_poses"),
            grasp={
                **data["grasp"],
                "pose": as_array(data["grasp"]["pose"], field="grasp.pose"),
                "config": as_array(data["grasp"]["config"], field="grasp.config"),
                "approach": as_array(data["grasp"]["approach"], dof, "grasp.approach"),
            },
            stats=dict(data["stats"]),
            timing=_read_timing(data),
        )
        _check_scene_blocks(fields)
        return fields
    except InputError:
        raise
    except (KeyError, TypeError, ValueError) as error:
        raise InputError(f"malformed plan ({type(error).__name__}: {error})", field="plan") from None


SEGMENTS = ("trajectory", "approach")  # timing keys; "approach" times grasp.approach


def timing_block(data: Any, dof: int, counts: dict[str, int]) -> dict[str, Any]:
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


def check_shapes(result) -> list[str]:
    """Check that the plan's arrays fit together.

    Args:
        result: the plan.

    Returns:
        Violations: a trajectory without waypoints, arrays whose sizes disagree with the
        joint count or with each other.
    """
    dof = len(result.joint_names)
    violations = []
    trajectory = np.asarray(result.trajectory)
    shapes = {
        "trajectory": (trajectory.shape, (max(len(trajectory), 1), dof)),
        "fingertip_poses": (np.shape(result.fingertip_poses), (max(len(trajectory), 1), 7)),
        "start_config": (np.shape(result.start_config), (dof,)),
        "goal_config": (np.shape(result.goal_config), (dof,)),
        "grasp.pose": (np.shape(result.grasp["pose"]), (7,)),
        "grasp.config": (np.shape(result.grasp["config"]), (dof,)),
        "grasp.approach": (np.shape(result.grasp["approach"]), (max(len(result.grasp["approach"]), 1), dof)),
        "object.points": (np.shape(result.object["points"]), (max(len(result.object["points"]), 1), 3)),
    }
    for name, (actual, expected) in shapes.items():
        if tuple(actual) != expected:
            violations.append(f"{name}: shape {tuple(actual)}, expected {expected}")
    return violations


def check_ends(result) -> list[str]:
    """Check that the plan's pieces join: the trajectory runs from ``start_config`` to ``goal_config``,
    and the approach from there to ``grasp.config`` (arrays of the right shapes: :func:`check_shapes`)."""
    violations = []
    trajectory = np.asarray(result.trajectory)
    for name, config, index in (("start_config", result.start_config, 0), ("goal_config", result.goal_config, -1)):
        gap = float(np.max(np.abs(trajectory[index] - config)))
        if gap > CONFIG_TOLERANCE:
            violations.append(f"{name}: differs from trajectory[{index % len(trajectory)}] by {gap:.3g} rad")
    approach = np.asarray(result.grasp["approach"])
    for name, end, index in (("goal_config", result.goal_config, 0), ("grasp.config", result.grasp["config"], -1)):
        gap = float(np.max(np.abs(approach[index] - end)))
        if gap > CONFIG_TOLERANCE:
            violations.append(f"approach[{index % len(approach)}]: differs from {name} by {gap:.3g} rad")
    return violations
