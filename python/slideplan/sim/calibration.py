"""The depth camera found from the robot in simulation (:mod:`slideplan.perception.calibration` does the
registration): before the first plan, the arm held over the object in a world of its own (the episode
itself starts with the finger on the object), and again in the episode's first frame, the finger pressing.
Each time the frame the camera takes, where it is mounted, is registered to the robot rendered from
where the camera is believed to be (:meth:`~slideplan.sim.episode.Episode.robot_view`)."""

from __future__ import annotations

import math

import numpy as np

from .. import _core
from ..perception.calibration import CameraFix, calibrate
from ..perception.camera import Camera
from ..plan.robot import robot_model, scene_collision_world
from ..transforms import homogeneous
from .episode import Episode
from .model import Rig

HOVER_M = 0.12  # the fingertip this far above the object's top while the camera calibrates before the plan
HOVER_YAWS = 8  # headings tried for a collision-free configuration there


def hover_config(scene, config, thickness: float, xy) -> np.ndarray | None:
    """A configuration with the fingertip ``HOVER_M`` above the object's top at ``xy``, pitched as for a
    contact (``config.beta0``), free of collisions; None where inverse kinematics finds none."""
    robot, world = robot_model(scene), scene_collision_world(scene)
    height = scene.table.height + thickness + HOVER_M
    for yaw in np.linspace(-math.pi, math.pi, HOVER_YAWS, endpoint=False):
        target = homogeneous(np.asarray(_core.contact_rotation(float(yaw), config.beta0)), (*xy, height))
        joints = robot.ik(target, rng_seed=0, options=_core.contact_ik_options(robot))
        if joints is not None and world.is_valid(joints, _core.ContactMode.FREE):
            return np.asarray(joints, dtype=float)
    return None


def first_fix(scene, truth, config, settings, camera: Camera, mounted: Camera, depth: tuple, seed: int,
              xy) -> CameraFix | None:
    """The camera's fix from a frame of the arm held over ``xy`` (where the object was first perceived), in
    a world of its own: the scene, the object as it truly lies, the camera where it is mounted. None without
    a hover configuration or with too little of the robot in view.

    Args:
        config: the planner's parameters, resolved for the scene (the hand's pitch and depth band).
        settings: the physics (:class:`~slideplan.sim.settings.ExecutionSettings`).
        depth: ``(height, width, noise at 1 m)`` of the camera's frames.
    """
    import mujoco

    hover = hover_config(scene, config, truth.thickness, xy)
    if hover is None:
        return None
    rig = Rig.for_scene(scene, truth, config, list(robot_model(scene).joint_names), hover)
    world = Episode(rig, settings, truth, mounted, believed=camera, depth=depth, seed=seed)
    try:
        world.built.data.qpos[world.built.arm_qpos] = hover
        mujoco.mj_forward(world.built.model, world.built.data)
        return calibrate(world.frames()[0], world.robot_view(), camera, scene.table.height)
    finally:
        world.close()


def episode_fix(world: Episode, camera: Camera, table_height: float,
                table_plane) -> tuple[Camera, tuple[float, float, float]]:
    """The camera where the robot in the episode's next frame puts it (from ``camera``, where it was put
    before), and the table plane as read through it; both unchanged when the frame shows too little of the
    robot."""
    fix = calibrate(world.frames()[0], world.robot_view(), camera, table_height)
    return (camera, table_plane) if fix is None else (fix.corrected(camera), fix.plane(table_plane))
