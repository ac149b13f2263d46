"""One simulated episode's world, built once: the MuJoCo model (from a plan, or from a robot before its first
plan: :class:`~slideplan.sim.model.Rig`) with the object as it truly is, the scene's clutter and the depth camera
where it is mounted; the core robot model; the servos (:class:`~slideplan.sim.runner.Runner`); and what watches
it: noisy depth frames, the video, a listener after every step. ``slideplan run`` and the closed-loop
experiment (:mod:`slideplan.sim.closed_loop`), the demonstrations (which observe a run), the environment
``SlideToEdge-v1`` and ``slideplan ros sim`` all step an :class:`Episode`."""

from __future__ import annotations

import numpy as np

from ..plan.robot import build_robot
from .model import BELIEVED_CAMERA, DEPTH_CAMERA, build_model
from .rendering import camera_depth, noisy_depth
from .runner import Runner
from .settings import ExecutionSettings
from .video import VIDEO_FPS, Recorder, plan_points

DEPTH_DROPOUT = 0.05  # share of a depth frame's pixels that return nothing


class Episode:
    """The world of one episode.

    Args:
        source: a plan (:class:`~slideplan.plan.result.PlanResult`: its robot, table, object cloud and clutter)
            or a :class:`~slideplan.sim.model.Rig` (a robot with no plan yet).
        settings: the physics.
        truth: the object as it truly lies (a :class:`~slideplan.world.objects.ThinObject`).
        mounted: the depth camera where it really is (the model's camera ``depth``).
        believed: where the loop believes that camera is, for :meth:`robot_view`, or None.
        depth: ``(height, width, noise at 1 m)`` of the depth frames :meth:`frames` renders, or None for none.
        seed: seeds the depth noise.
        video: (path or None, frames per simulated second, progress callback or None).
        observe: called once built as ``observe(source, built, runner, robot)``; returns what to call after
            every step (a demonstration's frames), or None.
    """

    def __init__(self, source, settings: ExecutionSettings, truth, mounted, *, believed=None, depth: tuple | None = None,
                 seed: int = 0, video: tuple = (None, VIDEO_FPS, None), observe=None) -> None:
        import mujoco

        self.settings = settings
        self.built = build_model(source, settings, world_object=truth, camera=mounted, believed=believed)
        self.depth_renderer = None
        if depth is not None:
            height, width, self.depth_noise = depth
            self.depth_renderer = mujoco.Renderer(self.built.model, height, width)
            self.depth_renderer.enable_depth_rendering()
            self.noise_rng = np.random.default_rng([seed, 1])
        self.robot = build_robot(source.robot)
        path, fps, progress = video
        keep_in_view = plan_points(source, self.robot) if path is not None else None
        self.recorder = Recorder(self.built.model, self.built.data, path, fps, (480, 640), keep_in_view, progress=progress)
        self.runner = Runner(self.built, settings, None)
        listeners = [self.recorder.after_step] if self.recorder.active else []
        if observe is not None:
            listeners.append(observe(source, self.built, self.runner, self.robot))
        if listeners:
            self.runner.on_frame = listeners[0] if len(listeners) == 1 else lambda: [listener() for listener in listeners]

    def frames(self) -> tuple[np.ndarray, np.ndarray]:
        """A new depth frame and the fingertip's measured pose."""
        model, data = self.built.model, self.built.data
        frame = noisy_depth(camera_depth(self.depth_renderer, model, data, DEPTH_CAMERA), self.depth_noise,
                            DEPTH_DROPOUT, self.noise_rng)
        return frame, np.asarray(self.robot.fk(data.qpos[self.built.arm_qpos]))

    def robot_view(self) -> np.ndarray:
        """The depth image of the robot alone (NaN elsewhere) as the believed camera would see it now: what
        the robot should look like in :meth:`frames` if the camera were where it is believed to be."""
        import mujoco

        model, data, renderer = self.built.model, self.built.data, self.depth_renderer
        depth = camera_depth(renderer, model, data, BELIEVED_CAMERA)
        renderer.enable_segmentation_rendering()
        try:
            renderer.update_scene(data, camera=BELIEVED_CAMERA)
            seen = renderer.render()
        finally:  # segmentation replaced depth rendering: the frames need it back
            renderer.disable_segmentation_rendering()
            renderer.enable_depth_rendering()
        joint = int(np.flatnonzero(model.jnt_qposadr == self.built.arm_qpos[0])[0])
        root = model.body_rootid[model.jnt_bodyid[joint]]  # the robot: the world's child the arm hangs from
        robot = np.flatnonzero(model.body_rootid[model.geom_bodyid] == root)
        shown = (seen[..., 1] == mujoco.mjtObj.mjOBJ_GEOM) & np.isin(seen[..., 0], robot)
        return np.where(shown, depth, np.nan)

    def close(self) -> None:
        self.recorder.close()
        if self.depth_renderer is not None:
            self.depth_renderer.close()
