"""Planning API: :class:`PlannerConfig`, :func:`plan` and the :class:`PlanResult` it returns.

:func:`plan` turns a :class:`~slideplan.scenes.Scene` and a :class:`~slideplan.objects.ThinObject`
into the C++ core's inputs, runs Algorithm 1 (``_core.plan_sliding``) and wraps the answer in a
:class:`PlanResult`, which reads and writes the plan JSON of docs/design.md section 5
(``slideplan.plan/2``: ``/1`` plus the ``timing`` block of :mod:`slideplan.timing`).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np
import shapely

from . import _core, grasp_cache, jsontext, parameters
from ._fields import as_number, as_numbers, is_number, require_within
from ._limits import MAX_MAGNITUDE, MAX_PLAN_BYTES, MAX_ROBOT_FILE_BYTES, parse_int, read_regular_file, require_waypoints
from .errors import InputError, MeshWarning, require_type
from .objects import ThinObject
from .scenes import Scene, package_search_dirs
from .timing import TimingOptions, core_limits, robot_limits, timing_from_dict
from .transforms import homogeneous, pose_to_row, rotation_from_rpy, yawed_pose

PLANNERS = ("slideplan", "cbirrt", "cbirrt2")
PLAN_SCHEMA = "slideplan.plan/2"
READABLE_SCHEMAS = ("slideplan.plan/1", PLAN_SCHEMA)  # /1: the same fields without timing
STATUSES = ("solved", "timeout", "invalid")

PRESETS = ("default", "paper")
PARAMETERS = parameters.NAMES
"""The parameters proper (the registry's names): PlannerConfig's fields before ``planner``, ``seed``,
``time_limit_s`` and ``preset``."""


class _ConfigMethods:
    """PlannerConfig's methods; its fields come from the parameter registry (below)."""

    def __post_init__(self) -> None:
        # Types here, by each parameter's registry entry; bounds and the pairs (delta_beta < beta0, dz_min <=
        # dz_max) by the core's validator, a pair once both are set (an unset one may come from the hand).
        given = [name for name in PARAMETERS if getattr(self, name) is not None]
        for name in given:
            _check_field(parameters.BY_NAME[name], getattr(self, name))
        if self.planner not in PLANNERS:
            raise InputError(f"unknown planner {self.planner!r} (expected one of: {', '.join(PLANNERS)})", field="planner")
        if self.preset not in PRESETS:
            raise InputError(f"unknown preset {self.preset!r} (expected one of: {', '.join(PRESETS)})", field="preset")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)):
            raise InputError(f"expected an integer, got {self.seed!r}", field="seed")
        if not 0 <= self.seed < 2**64:  # the core's uint64
            raise InputError(f"must be in [0, {2**64}), got {self.seed!r}", field="seed")
        if not is_number(self.time_limit_s) or not math.isfinite(self.time_limit_s) or self.time_limit_s <= 0:
            raise InputError(f"must be > 0 and finite, got {self.time_limit_s!r}", field="time_limit_s")
        try:
            self.to_params().validate(given)
        except ValueError as error:
            problem, name = _core_field_message(str(error))
            raise InputError(problem, field=name) from None

    @classmethod
    def for_scene(cls, scene: Scene, preset: str = "default", **overrides) -> PlannerConfig:
        """The config for a scene: built-in defaults, then the hand's ``[hand] params``, then the preset's
        values (``"paper"``: every parameter the paper gives, :data:`slideplan.parameters.PAPER_VALUES`),
        then ``overrides``.

        Args:
            scene: the scene whose hand gives parameter defaults.
            preset: ``"default"`` or ``"paper"``.
            **overrides: any field, e.g. ``seed=3, u_star=0.03``.

        Raises:
            InputError: an unknown field or preset, or a bad value, naming the field.
        """
        require_type(scene, Scene, "scene", "a Scene (from load_scene)")
        unknown = sorted(set(overrides) - {item.name for item in dataclasses.fields(cls)} - {"preset"})
        if unknown:
            raise InputError(f"unknown planner parameter(s) {unknown}", field="param")
        if preset not in PRESETS:
            raise InputError(f"unknown preset {preset!r} (expected one of: {', '.join(PRESETS)})", field="preset")
        published = parameters.PAPER_VALUES if preset == "paper" else {}
        return cls(**{**scene.hand.params, **published, **overrides, "preset": preset}).resolved(scene)

    def resolved(self, scene: Scene | None = None) -> PlannerConfig:
        """This config with every unset parameter filled: the scene's hand's value, else the built-in one.

        Args:
            scene: the scene whose hand gives defaults (None: built-in defaults only).

        Raises:
            InputError: a value the C++ core's validator refuses, naming the field (a pair names both).
        """
        hand = scene.hand.params if scene is not None else {}
        fills = {name: hand.get(name, parameters.BY_NAME[name].default) for name in PARAMETERS if getattr(self, name) is None}
        return dataclasses.replace(self, **fills) if fills else self

    def sources(self, scene: Scene | None = None) -> dict[str, str]:
        """Where each parameter's value comes from when planning in ``scene``: ``"hand"`` (its
        ``[hand] params``), ``"paper"`` (the paper preset's published value), ``"built-in"``, or
        ``"user"``. A value set explicitly but equal to the hand's, the preset's or the built-in
        default is named by that source."""
        hand = scene.hand.params if scene is not None else {}
        published = parameters.PAPER_VALUES if self.preset == "paper" else {}
        sources = {}
        for name in PARAMETERS:
            value = getattr(self, name)
            if value is None:
                sources[name] = "hand" if name in hand else "built-in"
            elif name in published and value == published[name]:
                sources[name] = "paper"
            elif name in hand and value == hand[name]:
                sources[name] = "hand"
            elif value == parameters.BY_NAME[name].default:
                sources[name] = "built-in"
            else:
                sources[name] = "user"
        return sources

    @classmethod
    def as_published(cls, **overrides) -> PlannerConfig:
        """Algorithm 1 and IsPairValid as published (``preset="paper"``): every parameter the paper gives
        at its value (:data:`slideplan.parameters.PAPER_VALUES`: every departure of
        docs/paper-to-code.md off, ``Delta_beta`` = 0.1 rad, ``Delta_Z`` = [0.5, 2.5] cm, ``N*`` = 100,
        the grasp at ``H_g`` exactly). The fields the paper leaves open (``beta0``, ``u_star``, ...) stay
        unset: ``plan`` takes them from the scene's hand. With ``planner="cbirrt"`` or ``"cbirrt2"``,
        our reading of the baselines (docs/paper-to-code.md).

        Args:
            **overrides: any field, e.g. ``seed=3, planner="cbirrt"``.
        """
        return cls(**{**parameters.PAPER_VALUES, **overrides, "preset": "paper"})

    @property
    def reconfiguration_range(self) -> float:
        """``Delta_Z^* = dz_max - dz_min`` (m), the paper's reconfiguration range."""
        return self.dz_max - self.dz_min

    def with_reconfiguration_range(self, range_m: float) -> PlannerConfig:
        """Return a copy with ``dz_max = dz_min + range_m``.

        Args:
            range_m: reconfiguration range ``Delta_Z^*`` (m), >= 0 (the paper uses 0, 0.005, 0.02).

        Returns:
            The new config.

        Raises:
            InputError: ``range_m`` is negative or not a finite number, or ``dz_min`` is unset
                (call :meth:`resolved` first).
        """
        if self.dz_min is None:
            raise InputError("dz_min is unset: resolve the config for its scene first", field="dz_min")
        if not is_number(range_m) or not math.isfinite(range_m) or range_m < 0:
            raise InputError(f"must be a finite number >= 0 (m), got {range_m!r}", field="reconfiguration_range")
        return dataclasses.replace(self, dz_max=self.dz_min + float(range_m))

    def to_params(self):
        """Build the C++ core's parameter object (not validated: :meth:`_core.PlannerParams.validate`).

        Returns:
            ``_core.PlannerParams`` with every field but ``seed``, ``time_limit_s`` and ``preset``
            (``planner`` becomes ``policy``); unset fields keep the built-in defaults.
        """
        params = _core.PlannerParams()
        for name in PARAMETERS:
            if getattr(self, name) is not None:
                setattr(params, name, getattr(self, name))
        params.policy = self.planner
        return params

    def to_dict(self) -> dict[str, Any]:
        """Return the fields as a plain dict (JSON-ready)."""
        return dataclasses.asdict(self)


def _check_field(parameter: parameters.Parameter, value) -> None:
    """Raise InputError naming ``parameter`` if ``value`` is not of its type (a real: a finite number)."""
    if parameter.kind == "bool":
        if not isinstance(value, (bool, np.bool_)):
            raise InputError(f"expected True or False, got {value!r}", field=parameter.name)
        return
    if parameter.kind == "int":
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise InputError(f"expected an integer, got {value!r}", field=parameter.name)
        if not -(2**31) <= value < 2**31:  # the core's int
            raise InputError(f"must be an {parameter.bounds()}, got {value!r}", field=parameter.name)
    elif not is_number(value) or not math.isfinite(value):
        raise InputError(f"expected a finite number, got {value!r}", field=parameter.name)


def _config_doc() -> str:
    lines = [
        "Planner parameters, one field per entry of the parameter registry (:mod:`slideplan.parameters`).",
        "",
        "A parameter left unset (None) is filled when planning: from the scene's hand (its ``[hand]",
        "params``), else the built-in default (:meth:`resolved`); the plan JSON records where each value",
        "came from (``params.sources``: ``built-in``, ``hand``, ``paper`` or ``user``). So",
        "``PlannerConfig(seed=1)`` plans with the hand's contact depth band and grasp standoff.",
        "",
        "Attributes:",
    ]
    for p in parameters.REGISTRY:
        paper = f"paper: {p.paper!r}" if p.paper is not None else "paper: open"
        lines.append(f"    {p.name}: {p.doc} ({p.bounds()}; default {p.default!r}; {paper}.)")
    lines += [
        "    planner: ``\"slideplan\"`` (Algorithm 1), ``\"cbirrt\"`` or ``\"cbirrt2\"`` (our reading of the",
        "        baselines of V-6, docs/paper-to-code.md).",
        "    seed: random seed; the same seed gives the same plan.",
        "    time_limit_s: planning time budget (s); a plan the limit cuts short is not returned.",
        "    preset: ``\"default\"`` (this project's) or ``\"paper\"`` (:meth:`as_published`), recorded in the plan.",
        "",
        "Raises:",
        "    InputError: on construction, naming the field: a value of the wrong type or out of its bounds,",
        "        an unknown planner or preset, a time limit that is not a positive number; once every",
        "        parameter is set (:meth:`resolved`), an inconsistent pair (``delta_beta < beta0``,",
        "        ``dz_min <= dz_max``), naming both.",
    ]
    return "\n".join(lines)


PlannerConfig = dataclasses.make_dataclass(
    "PlannerConfig",
    [(p.name, p.python_type | None, field(default=None)) for p in parameters.REGISTRY]
    + [("planner", str, field(default="slideplan")), ("seed", int, field(default=0)),
       ("time_limit_s", float, field(default=60.0)), ("preset", str, field(default="default"))],
    bases=(_ConfigMethods,), frozen=True, namespace={"__module__": __name__, "__doc__": _config_doc()},
)


def _core_field_message(message: str) -> tuple[str, str]:
    """``(problem, field)`` of the core validator's "planner parameter NAME must ..." message."""
    prefix = "planner parameter "
    if not message.startswith(prefix):
        return message, "param"
    name, _, problem = message[len(prefix):].partition(" ")
    return problem, name


@dataclass
class PlanResult:
    """One planning run, as stored in the plan JSON (``slideplan.plan/2``, docs/design.md 5).

    It holds everything needed to re-check the plan without the planner
    (:func:`slideplan.verify.verify` does). Arrays are numpy arrays; when ``status`` is
    not ``"solved"`` the configuration and trajectory arrays are empty.

    Attributes:
        status: ``"solved"``, ``"timeout"``, or ``"invalid"`` (a solved plan the verifier rejected).
        planner: ``"slideplan"``, ``"cbirrt"`` or ``"cbirrt2"``.
        seed: the random seed of the run.
        planning_time_s: wall time of planning (s), baselines' precomputation included.
        params: the planner parameters (:meth:`PlannerConfig.to_dict` without planner and seed).
        table: ``{"polygon": (n, 2) array, "height": float}``.
        object: ``{"name": str, "thickness": float, "points": (N, 3) array (input cloud, world
            frame), "com_xy": (2,) array}``.
        robot: :func:`robot_description` of the scene: URDF, mount, chain, held joints, contact
            and grasp frames (4x4 offsets), contact links.
        obstacles: the scene's obstacles, ``Obstacle.to_dict()`` each: ``{"shape": "box", "center",
            "size", "yaw"}``, ``{"shape": "cylinder", "center", "radius", "height"}`` or
            ``{"shape": "object", "name", "polygon", "bottom", "height"}`` (a collision re-check needs them).
        object_motion: ``{"x", "y", "yaw"}``: ``p' = R(yaw) p + (x, y)`` moves the object
            from its start to its final pose (Eq. 2).
        overhang_m: overhang ``u`` of the final pose (m).
        joint_names: the arm's joints, in configuration order.
        start_config, goal_config: (dof,) arrays.
        trajectory: (M, dof) dense sliding path, start to goal.
        fingertip_poses: (M, 7) contact frame ``F`` per waypoint, ``[x, y, z, qx, qy, qz, qw]``.
        grasp: ``{"pose": (7,) pose of the grasp frame, "config": (dof,), "approach": (K, dof)
            dense path from the goal configuration to the grasp configuration}``.
        stats: planner counters (iterations, start_roots, goal_roots, pairs_checked, ...).
        timing: times, velocities and accelerations of ``trajectory`` and ``grasp.approach`` and
            the limits used (:func:`slideplan.timing.parameterize`); None when the plan is not
            solved or was read from a ``slideplan.plan/1`` file.
    """

    SCHEMA = PLAN_SCHEMA

    status: str
    planner: str
    seed: int
    planning_time_s: float
    params: dict[str, Any]
    table: dict[str, Any]
    object: dict[str, Any]
    robot: dict[str, Any]
    obstacles: list[dict[str, Any]]
    object_motion: dict[str, float]
    overhang_m: float
    joint_names: list[str]
    start_config: np.ndarray
    goal_config: np.ndarray
    trajectory: np.ndarray
    fingertip_poses: np.ndarray
    grasp: dict[str, Any]
    stats: dict[str, Any] = field(default_factory=dict)
    timing: dict[str, Any] | None = None

    @property
    def solved(self) -> bool:
        """True if the planner found a plan (and no verifier marked it invalid)."""
        return self.status == "solved"

    @property
    def dof(self) -> int:
        """Number of arm joints."""
        return len(self.joint_names)

    def robot_model(self):
        """The plan's robot as a ``_core.RobotModel`` (:func:`plan_robot` of its ``robot`` block, cached).

        Raises:
            InputError: the URDF or a mesh cannot be loaded, naming the file.
        """
        return plan_robot(self.robot)

    def to_dict(self) -> dict[str, Any]:
        """Return the plan as JSON-ready nested dicts and lists, ``schema`` first."""
        content = {item.name: getattr(self, item.name) for item in dataclasses.fields(self)}
        return {"schema": self.SCHEMA, **_to_plain(content)}

    def to_json(self, indent: int | None = None) -> str:
        """Return the plan JSON text.

        Args:
            indent: None for one line; a number for one line per key and per waypoint
                (:func:`slideplan.jsontext.dumps`).
        """
        return jsontext.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PlanResult:
        """Rebuild a plan from :meth:`to_dict` output (exact round trip).

        Args:
            data: the parsed JSON.

        Returns:
            The plan, with numpy arrays where :meth:`to_dict` had lists.

        Raises:
            InputError: wrong schema, unknown status, missing, unknown or misshapen fields, a path of
                over :data:`~slideplan._limits.MAX_WAYPOINTS` waypoints, or a number that is NaN,
                infinite or beyond :data:`~slideplan._limits.MAX_MAGNITUDE`.
        """
        if not isinstance(data, dict) or data.get("schema") not in READABLE_SCHEMAS:
            found = data.get("schema") if isinstance(data, dict) else type(data).__name__
            raise InputError(f"expected one of {READABLE_SCHEMAS}, got {found!r}", field="schema")
        names = {item.name for item in dataclasses.fields(cls)}
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
            result = cls(
                status=data["status"],
                planner=data["planner"],
                seed=data["seed"],
                planning_time_s=data["planning_time_s"],
                params=_read_params(data["params"]),
                table={**data["table"], "polygon": _array(data["table"]["polygon"], 2, "table.polygon")},
                object={
                    **data["object"],
                    "points": _array(data["object"]["points"], 3, "object.points"),
                    "com_xy": as_numbers(data["object"]["com_xy"], 2, source="", field="object.com_xy"),
                },
                robot=_robot_block(data["robot"]),
                obstacles=[_obstacle_entry(entry, index) for index, entry in enumerate(data["obstacles"])],
                object_motion=_object_motion(data["object_motion"]),
                overhang_m=data["overhang_m"],
                joint_names=list(data["joint_names"]),
                start_config=_array(data["start_config"], field="start_config"),
                goal_config=_array(data["goal_config"], field="goal_config"),
                trajectory=_array(data["trajectory"], dof, "trajectory"),
                fingertip_poses=_array(data["fingertip_poses"], 7, "fingertip_poses"),
                grasp={
                    **data["grasp"],
                    "pose": _array(data["grasp"]["pose"], field="grasp.pose"),
                    "config": _array(data["grasp"]["config"], field="grasp.config"),
                    "approach": _array(data["grasp"]["approach"], dof, "grasp.approach"),
                },
                stats=dict(data["stats"]),
                timing=_read_timing(data),
            )
            _check_scene_blocks(result)
            return result
        except InputError:
            raise
        except (KeyError, TypeError, ValueError) as error:
            raise InputError(f"malformed plan ({type(error).__name__}: {error})", field="plan") from None

    @classmethod
    def load(cls, path: str | Path) -> PlanResult:
        """Read a plan file (``slideplan.plan/1``, or ``/2`` with its ``timing`` block as ``.timing``):
        the one reader of saved plans; what it returns goes wherever :func:`plan`'s result goes.

        Raises:
            InputError: naming the file (and the field): unreadable, not a regular file, over
                :data:`~slideplan._limits.MAX_PLAN_BYTES`, not JSON, or not a plan (:meth:`from_dict`).
        """
        require_type(path, (str, os.PathLike), "path", "a plan file's path")
        data = read_regular_file(path, MAX_PLAN_BYTES, "the plan")
        try:
            text = data.decode()
        except UnicodeDecodeError as error:
            raise InputError(f"not UTF-8 text ({error})", source=str(path)) from None
        try:
            result = cls.from_json(text)
        except InputError as error:
            raise InputError(error.problem, source=str(path), field=error.field) from None
        # A robot file named by a relative path is relative to the plan file, wherever it is opened from.
        here = Path(path).absolute().parent
        robot = result.robot
        robot["urdf"] = _beside(here, robot["urdf"])
        robot["attach"] = [_beside(here, fragment) for fragment in robot["attach"]]
        return result

    @classmethod
    def from_json(cls, text: str) -> PlanResult:
        """Parse plan JSON text (see :meth:`from_dict`).

        Raises:
            InputError: not JSON, or not a valid plan.
        """
        require_type(text, (str, bytes, bytearray), "text", "plan JSON text")
        try:
            data = json.loads(text, parse_int=parse_int)
        except json.JSONDecodeError as error:
            raise InputError(f"invalid JSON ({error})") from None
        except RecursionError:
            raise InputError("invalid JSON (nested too deeply)") from None
        return cls.from_dict(data)


# The plan JSON's fields that are not arrays, and what each must be.
_BLOCK_TYPES = {"status": str, "planner": str, "seed": int, "planning_time_s": (int, float), "params": dict,
                "table": dict, "object": dict, "robot": dict, "obstacles": list, "object_motion": dict,
                "overhang_m": (int, float), "joint_names": list, "grasp": dict, "stats": dict}
_KIND_WORDS = {str: "a string", int: "an integer", (int, float): "a number", dict: "a table of fields", list: "a list"}


def _check_scene_blocks(result: PlanResult) -> None:
    """The table, object and robot blocks of a plan hold what every reader of a plan (solved or not)
    needs: a simple table polygon, an object of at least 3 points with a thickness, link names.

    Raises:
        InputError: naming the field.
    """
    from .geometry import SupportSurface

    SupportSurface.from_vertices(result.table["polygon"], result.table["height"], field="table.polygon")
    points = result.object["points"]
    if len(points) < 3 or shapely.MultiPoint(points[:, :2]).convex_hull.area <= 0.0:
        raise InputError(f"expected at least 3 points not on one line, got {len(points)}", field="object.points")
    for name, rows in (("fingertip_poses", result.fingertip_poses), ("grasp.pose", result.grasp["pose"])):
        if np.size(rows) % 7:
            continue  # misshapen: check_shapes says so
        norms = np.linalg.norm(np.reshape(rows, (-1, 7))[:, 3:], axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-6):
            index = int(np.argmax(np.abs(norms - 1.0)))
            raise InputError(f"the quaternion of row {index} has norm {norms[index]:.6g}, not 1", field=name)
    as_number(result.object["thickness"], source="", field="object.thickness", positive=True)
    for key in ("urdf", "tip_link", "grasp_link"):
        if not isinstance(result.robot.get(key), str) or not result.robot[key]:
            raise InputError(f"expected a name, got {result.robot.get(key)!r}", field=f"robot.{key}")


def _beside(directory: Path, name: str) -> str:
    """A file path of a plan, relative to the plan's ``directory`` unless absolute or a URI."""
    return name if "://" in name or Path(name).is_absolute() else os.path.normpath(directory / name)


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
            entry[key] = _array(entry[key], 2, name)
            if len(entry[key]) < 3:
                raise InputError(f"expected at least 3 [x, y] vertices, got {len(entry[key])}", field=name)
        elif count:
            entry[key] = as_numbers(entry[key], count, source="", field=name)
            if positive and not np.all(entry[key] > 0):
                raise InputError(f"must be > 0, got {entry[key].tolist()}", field=name)
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
        block[key] = _array(block[key], 4, f"robot.{key}")
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
    return timing_from_dict(data["timing"], dof, {"trajectory": len(data["trajectory"]), "approach": len(data["grasp"]["approach"])})


def _to_plain(value: Any) -> Any:
    """Recursively turn numpy arrays and scalars into lists and Python numbers."""
    if isinstance(value, dict):
        return {key: _to_plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_to_plain(item) for item in value]
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    return value


def _array(value: Any, columns: int | None = None, field: str = "") -> np.ndarray:
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


def base_pose_matrix(base_pose) -> np.ndarray:
    """Convert a scene's robot mount ``[x, y, z, roll, pitch, yaw]`` (URDF rpy convention) to 4x4.

    Args:
        base_pose: 6 numbers (m, rad).

    Returns:
        (4, 4) homogeneous matrix.
    """
    x, y, z, roll, pitch, yaw = (float(value) for value in base_pose)
    return homogeneous(rotation_from_rpy(roll, pitch, yaw), (x, y, z))


def robot_description(scene: Scene) -> dict[str, Any]:
    """The robot and hand keys of a scene as stored in the plan JSON's ``robot`` block.

    Returns:
        ``{"urdf", "attach", "base_pose" (4x4), "base_link", "fixed_joints", "package_dirs",
        "tip_link", "tip_offset" (4x4), "grasp_link", "grasp_offset" (4x4), "contact_links",
        "gripper_joints" ({name: [open, closed]}, their open values also in "fixed_joints")}``.
    """
    return {
        "urdf": str(scene.urdf_path),
        "attach": [str(path) for path in scene.attach],
        "base_pose": base_pose_matrix(scene.base_pose),
        "base_link": scene.base_link,
        # A gripper joint is held open while planning.
        "fixed_joints": {**scene.fixed_joints, **{name: opened for name, (opened, _) in scene.hand.gripper_joints.items()}},
        "package_dirs": [str(path) for path in scene.package_dirs],
        "tip_link": scene.hand.tip_link,
        "tip_offset": base_pose_matrix(scene.hand.tip_offset),
        "grasp_link": scene.hand.grasp_link,
        "grasp_offset": base_pose_matrix(scene.hand.grasp_offset),
        "contact_links": list(scene.hand.contact_links),
        "gripper_joints": {name: list(values) for name, values in scene.hand.gripper_joints.items()},
    }


def merge_urdf(urdf: Path, attach: list[Path]) -> str:
    """The URDF text of ``urdf`` with the links and joints of every ``attach`` file appended.

    Args:
        urdf: the robot's URDF file.
        attach: URDF files whose links and joints join the robot (e.g. a finger on the flange).

    Raises:
        InputError: a file cannot be read, is not a regular file, is larger than
            :data:`~slideplan._limits.MAX_ROBOT_FILE_BYTES` or is not a ``<robot>`` document, naming it
            (and an attached one's field, ``robot.attach[i]``).
    """
    if not attach:
        try:
            return read_regular_file(urdf, MAX_ROBOT_FILE_BYTES, "the URDF").decode()
        except UnicodeDecodeError as error:
            raise InputError(f"not UTF-8 text ({error})", source=str(urdf)) from None
    robot = _urdf_root(urdf)
    for index, path in enumerate(attach):
        robot.extend(list(_urdf_root(path, f"robot.attach[{index}]")))
    return ElementTree.tostring(robot, encoding="unicode")


def _urdf_root(path: Path, field: str = "") -> ElementTree.Element:
    """The ``<robot>`` element of a URDF file (see :func:`merge_urdf`)."""
    try:
        element = ElementTree.fromstring(read_regular_file(path, MAX_ROBOT_FILE_BYTES, "the URDF", field))
    except ElementTree.ParseError as error:
        raise InputError(f"not a URDF ({error})", source=str(path), field=field) from None
    if element.tag != "robot":
        raise InputError(f"not a URDF (root element <{element.tag}>, expected <robot>)", source=str(path), field=field)
    return element


def search_dirs(description: dict[str, Any]) -> list[str]:
    """Where the ``package://`` URIs of a robot block resolve: its own ``package_dirs``, then this
    machine's (:func:`~slideplan.scenes.package_search_dirs`; a plan records only its scene's own)."""
    return [str(entry) for entry in package_search_dirs(tuple(Path(entry) for entry in description["package_dirs"]))]


def build_robot(description: dict[str, Any]):
    """Build the C++ robot model from a :func:`robot_description` (or a plan's ``robot`` block).

    Args:
        description: the robot block.

    Returns:
        ``_core.RobotModel``.

    Raises:
        ValueError: naming the file and the key, from the reader or the core.

    Warns:
        MeshWarning: for each hand mesh checked as its triangles (``RobotModel.collision_meshes``).
    """
    from . import _core

    urdf = Path(description["urdf"])
    attach = [Path(path) for path in description["attach"]]
    text = merge_urdf(urdf, attach)
    try:
        robot = _core.RobotModel.from_string(
            text,
            source=str(urdf),
            directory=str(urdf.parent),
            tip_link=description["tip_link"],
            base_pose=np.asarray(description["base_pose"], dtype=float),
            base_link=description["base_link"],
            tip_offset=np.asarray(description["tip_offset"], dtype=float),
            fixed_joints=dict(description["fixed_joints"]),
            package_dirs=search_dirs(description),
        )
    except ValueError as error:
        message = str(error)
        for name in description.get("gripper_joints", {}):  # held at its open value, but written in [hand]
            message = message.replace(f"[robot] fixed_joints.{name}:", f"[hand] gripper_joints.{name} (open):")
        raise ValueError(_blame_fragment(message, urdf, attach)) from None
    exact = [f"'{link}' ({Path(mesh).name}: hull {hull_ratio:.2f} x its volume)"
             for link, mesh, hull_ratio, is_exact in robot.collision_meshes if is_exact]
    if exact:  # one warning per robot model, however many meshes
        warnings.warn(f"{len(exact)} hand mesh(es) checked as their triangles, since a convex hull would fill a concavity "
                      f"of the hand: {', '.join(exact)}; exact, but slower than a hull (convex or primitive collision "
                      "shapes plan faster)", MeshWarning, stacklevel=2)
    return robot


def _blame_fragment(message: str, urdf: Path, attach: list[Path]) -> str:
    """The core's message about the merged URDF, naming the attached file instead of ``urdf`` when the
    link or joint it names comes from that file (the core sees one document)."""
    named = set(re.findall(r"\[([^\]]+)\]|'([^']+)'", message))
    named = {name for pair in named for name in pair if name}
    for path in attach:
        elements = _urdf_root(path)  # read by merge_urdf already
        if named & {element.get("name") for element in elements if element.tag in ("link", "joint")}:
            return message.replace(f"{urdf}:", f"{path} (attached to {urdf.name}):", 1)
    return message


@functools.lru_cache(maxsize=16)
def _cached_robot(key: str):
    return build_robot(json.loads(key))


def plan_robot(description: dict[str, Any]):
    """Return the C++ robot model of a plan's ``robot`` block, cached: parsing the URDF and its
    meshes is not free. The model is immutable, so plans in any number of threads share it
    (docs/design.md 9).

    Args:
        description: a :func:`robot_description` (or a plan's ``robot`` block).

    Returns:
        ``_core.RobotModel``.

    Raises:
        InputError: naming the file and the key, if it cannot be loaded.
    """
    try:
        return _cached_robot(json.dumps(_to_plain(description), sort_keys=True))
    except (ValueError, RuntimeError) as error:
        raise InputError(f"cannot load robot ({error})", source=str(description["urdf"]), field="robot") from None


def collision_world(scene: Scene):
    """The scene's robot, table and obstacles as a ``_core.CollisionWorld`` (its contact links may touch)."""
    from . import _core

    return _core.CollisionWorld(robot_model(scene), _core.SupportSurface(scene.table.vertices, scene.table.height),
                                core_obstacles([obstacle.to_dict() for obstacle in scene.obstacles]), list(scene.hand.contact_links))


def table_reach(scene: Scene, thickness: float, config: PlannerConfig | None = None, *, grid: int = 5,
                yaws: int = 8) -> float:
    """The share of the table where the contact frame reaches a thin object's top
    (:func:`table_reach_map`'s points reached). What the start roots need: near 0, the robot stands
    where it cannot slide.

    Returns:
        A fraction in [0, 1].
    """
    _, reached = table_reach_map(scene, thickness, config, grid=grid, yaws=yaws)
    return float(reached.mean()) if reached.size else 0.0


def table_reach_map(scene: Scene, thickness: float, config: PlannerConfig | None = None, *, grid: int = 5,
                    yaws: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Where on the table the contact frame reaches a thin object's top: on a ``grid`` x ``grid``
    lattice over the table's bounding box (the points inside the table), the fingertip at pitch
    ``beta0`` and the middle of the depth band, at any of ``yaws`` headings (the slide leaves the
    heading free), by a configuration free of collisions but the finger's.

    Args:
        scene: the scene.
        thickness: the object's (m).
        config: planner parameters (``beta0``, ``dz_min``, ``dz_max``); the scene's hand's by default.

    Returns:
        The lattice points inside the table, (n, 2), and whether each is reached, (n,) bool.
    """
    from . import _core

    config = (config or PlannerConfig.for_scene(scene)).resolved(scene)
    robot = robot_model(scene)
    world = collision_world(scene)
    depth = scene.table.height + thickness - 0.5 * (config.dz_min + config.dz_max)
    low, high = scene.table.vertices.min(axis=0), scene.table.vertices.max(axis=0)
    lattice = [low + (high - low) * np.array([i + 0.5, j + 0.5]) / grid for i in range(grid) for j in range(grid)]
    inside = np.array([point for point in lattice if scene.table.polygon.contains(shapely.Point(point))]).reshape(-1, 2)

    def reaches(point: np.ndarray) -> bool:
        for yaw in np.linspace(-math.pi, math.pi, yaws, endpoint=False):
            target = homogeneous(np.asarray(_core.contact_rotation(float(yaw), config.beta0)), (*point, depth))
            joints = robot.ik(target, rng_seed=0, options=_core.contact_ik_options(robot))
            if joints is not None and world.is_valid(joints):
                return True
        return False

    return inside, np.array([reaches(point) for point in inside], dtype=bool)


def robot_model(scene: Scene):
    """Return the scene's C++ robot model (:func:`plan_robot` of its :func:`robot_description`).

    Raises:
        InputError: naming the scene file and the key, if the robot cannot be loaded.
    """
    try:
        return plan_robot(robot_description(scene))
    except InputError as error:
        raise InputError(error.problem, source=scene.source or error.source, field="robot") from None


def core_obstacles(entries: list[dict[str, Any]]) -> list:
    """Plan JSON obstacle entries (``Obstacle.to_dict()``; ``shape`` box, cylinder or object, box if
    absent as in older plans) as the C++ core's obstacles."""
    from . import _core

    obstacles = []
    for entry in entries:
        shape = entry.get("shape", "box")
        if shape == "box":
            obstacles.append(_core.BoxObstacle(yawed_pose(entry["center"], entry["yaw"]), np.asarray(entry["size"], dtype=float)))
        elif shape == "cylinder":
            obstacles.append(_core.CylinderObstacle(yawed_pose(entry["center"], 0.0), entry["radius"], entry["height"]))
        else:
            obstacles.append(_core.PrismObstacle(np.asarray(entry["polygon"], dtype=float), entry["bottom"], entry["height"]))
    return obstacles


@functools.lru_cache(maxsize=32)
def _cached_grasp_map(robot, vertices: tuple, height: float, grasp_link: str, grasp_offset: tuple, thickness: float,
                      params_key: tuple, stored: Path | None):
    from . import _core

    params = _core.PlannerParams()
    for name, value in zip(parameters.GRASP_MAP_NAMES, params_key):
        setattr(params, name, value)
    table = _core.SupportSurface(np.array(vertices, dtype=float), height)
    core_map = _core.GraspMap(robot, table, grasp_link, np.array(grasp_offset, dtype=float).reshape(4, 4), thickness, params)
    grasp_cache.restore(core_map, stored)
    return core_map


def clear_grasp_map_cache() -> None:
    """Forget the grasp maps held in memory: the next plan of every table starts from the stored map (or
    probes anew if the disk cache is off, :mod:`slideplan.grasp_cache`), as a fresh process does."""
    _cached_grasp_map.cache_clear()


def _grasp_map_and_file(scene: Scene, obj: ThinObject, config: PlannerConfig):
    points = np.asarray(obj.points, dtype=float)
    height = float(scene.table.height)
    vertices = tuple(map(tuple, np.asarray(scene.table.vertices, dtype=float)))
    # As the core measures it (z_s is the cloud's mean height) and to the micrometre, as the map keeps
    # it: clouds of one thickness differ in the last bits of their mean and must still share the map.
    thickness = round(float(points[:, 2].mean()) - height, 6)
    params_key = tuple(getattr(config, name) for name in parameters.GRASP_MAP_NAMES)
    try:
        stored = grasp_cache.map_path(robot_description(scene), vertices, height, thickness, params_key)
    except OSError as error:
        raise InputError(f"cannot read the robot ({error})", source=scene.source, field="robot") from None
    core_map = _cached_grasp_map(robot_model(scene), vertices, height, scene.hand.grasp_link,
                                 tuple(base_pose_matrix(scene.hand.grasp_offset).ravel()), thickness, params_key, stored)
    return core_map, stored


def grasp_map(scene: Scene, obj: ThinObject, config: PlannerConfig):
    """The grasp map (``_core.GraspMap``) of the scene's robot and table for this object's thickness and
    the config's grasp parameters, cached in memory and on disk (:mod:`slideplan.grasp_cache`): plans of
    many objects on one table probe each edge stretch once. Its answers depend only on that geometry, so
    a plan is the same with a fresh map or a shared one.

    Raises:
        InputError: the robot cannot be loaded.
    """
    return _grasp_map_and_file(scene, obj, config)[0]


def core_task(scene: Scene, obj: ThinObject, config: PlannerConfig) -> dict[str, Any]:
    """The C++ core's description of one planning problem: keyword arguments of ``_core.plan_sliding``
    (and of the benchmark peer ``_core.ompl_projected_connect``) but the seed.

    Raises:
        InputError: the robot cannot be loaded.
    """
    from . import _core

    return {
        "robot": robot_model(scene),
        "table": _core.SupportSurface(scene.table.vertices, scene.table.height),
        "obstacles": core_obstacles([obstacle.to_dict() for obstacle in scene.obstacles]),
        "contact_links": list(scene.contact_links),
        "object_points": np.asarray(obj.points, dtype=float),
        "object_com_xy": np.asarray(obj.centroid_xy, dtype=float),
        "params": config.to_params(),
        "time_limit": config.time_limit_s,
        "grasp_link": scene.hand.grasp_link,
        "grasp_offset": base_pose_matrix(scene.hand.grasp_offset),
    }


def plan(scene: Scene, obj: ThinObject, config: PlannerConfig | None = None, timing: TimingOptions | None = None, *,
         start_config=None) -> PlanResult:
    """Plan a pre-grasp sliding motion (paper Algorithm 1 with IsPairValid).

    Args:
        scene: table, robot and obstacles.
        obj: the thin object, lying on the scene's table (for re-planning: at its observed pose).
        config: planner parameters, seed, time limit and planner (default:
            :meth:`PlannerConfig.for_scene`, the hand's defaults); its unset parameters are filled
            from the scene's hand, then the built-in defaults (:meth:`PlannerConfig.resolved`).
        timing: limits of the time parameterization, a :class:`slideplan.timing.TimingOptions`
            (default: URDF velocity limits and the documented defaults).
        start_config: planning from a state (beyond the paper, for re-planning during a slide): the
            ``(dof,)`` configuration the arm is in, its finger in contact with ``obj``. The plan
            starts there (no start configuration is drawn); ``None`` draws them from Eq. 3.

    Returns:
        The result; ``status`` is ``"solved"`` or ``"timeout"``. A solved plan carries its
        ``timing``. The planner does not run :func:`slideplan.verify.verify`; call it to re-check a plan.

    Raises:
        InputError: the object is not on the table, the robot cannot be loaded, the core
            rejects the input (message from the core), the timing limits are malformed, or
            ``start_config`` (field ``start_config``) is not a valid sliding configuration with
            its fingertip on the object: the message names the joint, the band and by how much,
            or the colliding links.
        KeyboardInterrupt: Ctrl-C during planning.
    """
    from . import _core

    require_type(scene, Scene, "scene", "a Scene (from load_scene)")
    require_type(obj, ThinObject, "obj", "a ThinObject (from load_object)")
    require_type(config, (PlannerConfig, type(None)), "config", "a PlannerConfig or None")
    config = config or PlannerConfig.for_scene(scene)
    sources = config.sources(scene)
    config = config.resolved(scene)
    robot = robot_model(scene)
    if start_config is not None:
        start_config = as_numbers(start_config, robot.dof, source="", field="start_config")
    limits = robot_limits(robot, str(scene.urdf_path), robot.joint_names, timing)
    try:
        shared_map, stored = _grasp_map_and_file(scene, obj, config)
        # A solved plan is timed in the same call, without the GIL.
        core_result = _core.plan_sliding(**core_task(scene, obj, config), seed=config.seed,
                                         grasp_map=shared_map, timing=core_limits(limits), start_config=start_config)
    except InputError:
        raise
    except _core.InvalidStartConfig as error:
        raise InputError(str(error), field="start_config") from None
    except ValueError as error:
        # The core judges scene, object and parameters together: name them, rather than blame the scene file.
        raise InputError(f"planner rejected the input (scene {scene.source}, object {obj.name or 'unnamed'}): {error}") from None
    except RuntimeError as error:
        raise InputError(str(error), field="timing") from None
    grasp_cache.persist(shared_map, stored)
    result = _wrap_core_result(core_result, scene, obj, config, robot)
    result.params["sources"] = sources
    if result.solved:
        result.timing = {**core_result.timing, "limits": limits}
    return result


def _wrap_core_result(core_result, scene: Scene, obj: ThinObject, config: PlannerConfig, robot) -> PlanResult:
    """Copy a ``_core.PlanResult`` and the inputs that produced it into a :class:`PlanResult`."""
    dof = robot.dof
    motion = core_result.object_motion
    params = {key: value for key, value in config.to_dict().items() if key not in ("planner", "seed")}  # preset included
    return PlanResult(
        status=core_result.status,
        planner=core_result.planner,
        seed=config.seed,
        planning_time_s=float(core_result.planning_time),
        params=params,
        table={"polygon": np.array(scene.table.vertices, dtype=float), "height": float(scene.table.height)},
        object={
            "name": obj.name,
            "thickness": float(obj.thickness),
            "points": np.array(obj.points, dtype=float),
            "com_xy": np.array(obj.centroid_xy, dtype=float),
        },
        robot=robot_description(scene),
        obstacles=[obstacle.to_dict() for obstacle in scene.obstacles],
        object_motion={"x": float(motion[0]), "y": float(motion[1]), "yaw": float(motion[2])},
        overhang_m=float(core_result.overhang),
        joint_names=list(robot.joint_names),
        start_config=np.array(core_result.start_config, dtype=float).reshape(-1),
        goal_config=np.array(core_result.goal_config, dtype=float).reshape(-1),
        trajectory=_array(core_result.trajectory, dof),
        fingertip_poses=np.array([pose_to_row(pose) for pose in core_result.fingertip_poses]).reshape(-1, 7),
        grasp={
            "pose": pose_to_row(core_result.grasp_pose) if core_result.status == "solved" else np.zeros(0),
            "config": np.array(core_result.grasp_config, dtype=float).reshape(-1),
            "approach": _array(core_result.approach, dof),
        },
        stats=dict(core_result.stats),
    )
