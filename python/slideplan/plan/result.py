"""A plan: :class:`PlanResult`, what :func:`slideplan.plan` returns and the plan JSON holds
(``slideplan.plan/2``, docs/design.md 5), read by the one loader (:meth:`PlanResult.load`, every check
in :mod:`slideplan.plan.schema`) and written by :meth:`PlanResult.to_json`. Reading a plan does not
import the planner."""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import jsontext
from .._limits import MAX_PLAN_BYTES, parse_int, read_regular_file
from ..errors import InputError, require_type
from ..transforms import move_planar
from . import schema
from .robot import collision_world, plan_robot


@dataclass
class PlanResult(jsontext.Document):
    """One planning run, as stored in the plan JSON (``slideplan.plan/2``, docs/design.md 5).

    It holds everything needed to re-check the plan without the planner
    (:func:`slideplan.checks.verify.verify` does). Arrays are numpy arrays; when ``status`` is
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
            the limits used (:func:`slideplan.plan.timing.parameterize`); None when the plan is not
            solved or was read from a ``slideplan.plan/1`` file.
    """

    SCHEMA = schema.PLAN_SCHEMA

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

    @property
    def object_top(self) -> float:
        """The height of the object's top in the world (m): the table's plus the object's thickness."""
        return float(self.table["height"]) + float(self.object["thickness"])

    def robot_model(self):
        """The plan's robot as a ``_core.RobotModel`` (:func:`plan_robot` of its ``robot`` block, cached).

        Raises:
            InputError: the URDF or a mesh cannot be loaded, naming the file.
        """
        return plan_robot(self.robot)

    def moved_object_xy(self) -> np.ndarray:
        """The object points' xy at the final pose, ``P'_o``, by the recorded object motion (Eq. 2).

        Returns:
            (N, 2) array.
        """
        motion = self.object_motion
        return move_planar(np.asarray(self.object["points"])[:, :2], (motion["x"], motion["y"], motion["yaw"]))

    def collision_world(self):
        """The plan's robot, table and obstacles as a ``_core.CollisionWorld`` (sliding: no object)."""
        return collision_world(self.robot_model(), self.table["polygon"], self.table["height"], self.obstacles,
                               self.robot["contact_links"])

    def to_dict(self) -> dict[str, Any]:
        """Return the plan as JSON-ready nested dicts and lists, ``schema`` first."""
        content = {item.name: getattr(self, item.name) for item in dataclasses.fields(self)}
        return {"schema": self.SCHEMA, **to_plain(content)}

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
        return cls(**schema.plan_fields(data, [item.name for item in dataclasses.fields(cls)]))

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


def _beside(directory: Path, name: str) -> str:
    """A file path of a plan, relative to the plan's ``directory`` unless absolute or a URI."""
    return name if "://" in name or Path(name).is_absolute() else os.path.normpath(directory / name)


def to_plain(value: Any) -> Any:
    """Recursively turn numpy arrays and scalars into lists and Python numbers."""
    if isinstance(value, dict):
        return {key: to_plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_plain(item) for item in value]
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    return value
