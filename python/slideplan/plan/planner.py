"""Planning: :func:`plan` turns a :class:`~slideplan.world.scenes.Scene` and a
:class:`~slideplan.world.objects.ThinObject` into the C++ core's inputs (:func:`core_task`), runs Algorithm 1
(``_core.plan_sliding``, timed in the same call) with the scene's cached grasp map, and wraps the answer
in a :class:`~slideplan.plan.result.PlanResult`."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import numpy as np

from .. import _core, grasp_cache, parameters
from .._fields import as_numbers
from ..errors import InputError, require_type
from ..world.objects import ThinObject
from ..world.scenes import Scene
from .timing import TimingOptions, core_limits, robot_limits
from ..transforms import pose_to_row
from .config import PlannerConfig
from .result import PlanResult
from .robot import base_pose_matrix, core_obstacles, robot_description, robot_model
from .schema import as_array


@functools.lru_cache(maxsize=32)
def _cached_grasp_map(robot, vertices: tuple, height: float, grasp_link: str, grasp_offset: tuple, thickness: float,
                      params_key: tuple, stored: Path | None):
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
        timing: limits of the time parameterization, a :class:`slideplan.plan.timing.TimingOptions`
            (default: URDF velocity limits and the documented defaults).
        start_config: planning from a state (beyond the paper, for re-planning during a slide): the
            ``(dof,)`` configuration the arm is in, its finger in contact with ``obj``. The plan
            starts there (no start configuration is drawn); ``None`` draws them from Eq. 3.

    Returns:
        The result; ``status`` is ``"solved"`` or ``"timeout"``. A solved plan carries its
        ``timing``. The planner does not run :func:`slideplan.checks.verify.verify`; call it to re-check a plan.

    Raises:
        InputError: the object is not on the table, the robot cannot be loaded, the core
            rejects the input (message from the core), the timing limits are malformed, or
            ``start_config`` (field ``start_config``) is not a valid sliding configuration with
            its fingertip on the object: the message names the joint, the band and by how much,
            or the colliding links.
        KeyboardInterrupt: Ctrl-C during planning.
    """
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
        trajectory=as_array(core_result.trajectory, dof),
        fingertip_poses=np.array([pose_to_row(pose) for pose in core_result.fingertip_poses]).reshape(-1, 7),
        grasp={
            "pose": pose_to_row(core_result.grasp_pose) if core_result.status == "solved" else np.zeros(0),
            "config": np.array(core_result.grasp_config, dtype=float).reshape(-1),
            "approach": as_array(core_result.approach, dof),
        },
        stats=dict(core_result.stats),
    )
