"""What the planning node plans: a cloud in the world, perceived (:func:`perceived_task`), planned and
verified with the reach to its first contact (:func:`plan_task`); a request it refuses says why (:class:`Refused`)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .. import jsontext
from ..errors import InputError
from ..plan.motions import Unreachable, reach_path, straight_up
from ..perception.registration import seen_target
from ..world.objects import ThinObject, load_outline
from ..plan.config import PlannerConfig
from ..plan.robot import base_pose_matrix
from ..plan.result import PlanResult
from ..world.scenes import Scene


LIFT_M = 0.05  # the lift after the grasp


class Refused(Exception):
    """A request that cannot be served: ``status`` names what failed, the message says why."""

    def __init__(self, status: str, reason: str) -> None:
        super().__init__(reason)
        self.status = status


def cloud_in_world(points: np.ndarray, camera_pose) -> np.ndarray:
    """The finite points of a cloud (any shape ending in 3) moved from the camera's frame into the world
    by ``camera_pose`` (x y z roll pitch yaw)."""
    pose = base_pose_matrix(camera_pose)
    flat = np.asarray(points, dtype=float).reshape(-1, 3)
    flat = flat[np.isfinite(flat).all(axis=1)]
    return flat @ pose[:3, :3].T + pose[:3, 3]


def perceived_task(scene: Scene, world_points: np.ndarray, target: int, seed: int,
                   table_plane=None, object_name: str = "") -> tuple[Scene, ThinObject, int, tuple, float]:
    """The perceived scene (its table and clutter, the robot from ``scene``), the object ``target``, how
    many objects were seen, the table plane (``table_plane``: the plane of an earlier cloud of the
    same camera, :func:`slideplan.perception.tabletop.perceive`'s) and how far the perceived edges may be off (m).
    With ``object_name`` (a catalogue name or an outline TOML) the object is its known outline registered to
    the target's points, as the simulated loop has it (:func:`slideplan.perception.registration.seen_target`);
    without, the target's points themselves.

    Raises:
        Refused: an empty cloud (``no_cloud``), nothing perceived (``perception``), or a target that is
            not one of the objects seen (``target``).
    """
    from ..perception.tabletop import perceive

    if len(world_points) == 0:
        raise Refused("no_cloud", "the latest cloud on /camera/points has no finite points")
    try:
        perception = perceive(world_points, seed=seed, table_plane=table_plane, source="/camera/points")
    except InputError as error:
        raise Refused("perception", error.problem) from None
    if not perception.objects:
        raise Refused("perception", "no thin object on the table in the latest cloud")
    if not 0 <= target < len(perception.objects):
        raise Refused("target", f"target {target} is not one of the {len(perception.objects)} objects seen (0 to "
                                f"{len(perception.objects) - 1}, largest first)")
    outline = load_outline(object_name) if object_name else None
    seen, pose = seen_target(perception.objects, index=target, outline=None if outline is None else outline[0])
    if outline is None:
        obj = ThinObject.from_points(seen.points, table_height=perception.table.height, name=f"object {target}")
    else:
        obj = ThinObject.from_outline(outline[0], thickness=outline[1], table_height=perception.table.height, pose=pose,
                                      name=outline[2])
    return perception.scene(scene), obj, len(perception.objects), perception.plane, perception.edge_uncertainty


def lift_path(result: PlanResult) -> np.ndarray:
    """From the grasp straight up LIFT_M, a centimetre at a time (:func:`slideplan.plan.motions.straight_up`).

    Raises:
        Refused: (``lift``) no IK for the lifted grasp.
    """
    lifted = straight_up(result.robot_model(), np.asarray(result.grasp["config"], dtype=float), LIFT_M)
    if lifted is None:
        raise Refused("lift", f"no inverse kinematics for the {100 * LIFT_M:.0f} cm lift")
    return lifted


@dataclass
class Task:
    """A plan being served: the plan, the object as perceived, the reach, and what the request said."""

    result: PlanResult
    obj: ThinObject
    scene: Scene
    reach: np.ndarray
    config: PlannerConfig
    summary: dict = field(default_factory=dict)
    table_plane: tuple | None = None
    planned_at: float = 0.0  # the node's (ROS) time when the plan was made


def plan_task(scene: Scene, points: np.ndarray, joints: np.ndarray | None, *, camera_pose, target: int, seed: int,
              time_limit: float, table_plane=None, object_name: str = "") -> Task:
    """Perceive a cloud (camera frame; ``table_plane`` as :func:`perceived_task`), plan for object
    ``target`` and the reach from ``joints``.

    Raises:
        Refused: no joint state yet (``no_joint_state``), a failed perception, an unsolved plan
            (``timeout`` or the planner's status), a plan that fails the verifier (``invalid``) or no reach.
    """
    from ..checks.pipeline import for_perceived, plan_checked

    started = time.perf_counter()
    perceived_scene, obj, seen, plane, margin = perceived_task(scene, cloud_in_world(points, camera_pose), target, seed,
                                                               table_plane, object_name)
    perceived = time.perf_counter()
    if joints is None:
        raise Refused("no_joint_state", "no message on /joint_states yet: the arm's configuration is unknown")
    config = for_perceived(PlannerConfig.for_scene(perceived_scene, seed=seed, time_limit_s=time_limit), margin)
    try:
        checked = plan_checked(perceived_scene, obj, config)
    except InputError as error:
        raise Refused("plan", error.problem) from None
    result = checked.result
    if checked.verification is None:
        raise Refused(result.status, f"no plan within {time_limit:g} s ({result.status})")
    if not checked.ok:
        raise Refused("invalid", f"the plan fails verification: {checked.verification.violations[0]}")
    try:
        reach = reach_path(result, obj, joints)
    except Unreachable as error:
        raise Refused("reach", str(error)) from None
    summary = {"status": "solved", "planning_time_s": round(result.planning_time_s, 4),
               "perceive_s": round(perceived - started, 4), "total_s": round(time.perf_counter() - started, 4),
               "overhang_m": round(result.overhang_m, 4), "objects_seen": seen, "replans": 0}
    return Task(result, obj, perceived_scene, reach, config, summary, plane)


def one_line(content: dict) -> str:
    """A response message: one line of JSON, no NaN."""
    return jsontext.dumps(content, indent=None, allow_nan=False)
