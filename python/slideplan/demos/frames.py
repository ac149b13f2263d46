"""A demonstration's frames, taken from a run as it steps: every ``1 / fps`` simulated seconds the arm's
state, what its servos are told (the action), the phase, and the cameras' images."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np

from ..errors import InputError
from ..transforms import rotation_vector

PHASES = ("slide", "clear", "reach", "approach", "grasp", "lift", "hold")  # execute.runner's and the loop's moves'
CAMERAS = ("front", "scene")  # front: facing the robot across the table; scene: the closed loop's depth camera, in colour
_SPEC = re.compile(r"^(?P<name>[a-z]+):(?P<width>\d+)x(?P<height>\d+)(?P<depth>:depth)?$")
_MAX_SIDE = 1024


@dataclasses.dataclass(frozen=True)
class CameraSpec:
    """A camera of the dataset: ``NAME:WxH`` on the command line (RGB), or ``NAME:WxH:depth`` (RGB and depth)."""

    name: str
    width: int
    height: int
    depth: bool = False

    @classmethod
    def parse(cls, text: str) -> CameraSpec:
        """Read ``NAME:WxH`` or ``NAME:WxH:depth``.

        Raises:
            InputError: not that form, an unknown name (one of :data:`CAMERAS`) or a side outside 16..1024.
        """
        match = _SPEC.match(text.strip())
        if match is None:
            raise InputError(f"{text!r} is not NAME:WxH or NAME:WxH:depth (e.g. front:256x256)", field="--cameras")
        name, width, height = match["name"], int(match["width"]), int(match["height"])
        if name not in CAMERAS:
            raise InputError(f"unknown camera {name!r} (one of {', '.join(CAMERAS)})", field="--cameras")
        if not (16 <= width <= _MAX_SIDE and 16 <= height <= _MAX_SIDE):
            raise InputError(f"{text!r}: each side must be 16..{_MAX_SIDE} pixels", field="--cameras")
        return cls(name, width, height, bool(match["depth"]))


def state_names(joint_names: list[str]) -> list[str]:
    """``observation.state``'s names: the arm's joints (rad or m), the gripper's closing (0 open, 1 closed)
    and the fingertip's pose (position m, rotation vector rad)."""
    return [*joint_names, "gripper", "tip_x", "tip_y", "tip_z", "tip_rx", "tip_ry", "tip_rz"]


def action_names(joint_names: list[str]) -> list[str]:
    """``action``'s names: each joint's servo target and the gripper's commanded closing."""
    return [*joint_names, "gripper"]


EE_ACTION_NAMES = ["dx", "dy", "dz", "drx", "dry", "drz", "gripper"]  # the fingertip's step to the target, in the world


class Frames:
    """Takes a frame every ``1 / fps`` simulated seconds; hand :meth:`after_step` to the run as the
    listener of each step (:func:`slideplan.sim.closed_loop.run`'s ``observe``).

    Args:
        built: the run's MuJoCo model (:class:`slideplan.sim.model.Model`).
        runner: its servos (:class:`slideplan.sim.runner.Runner`: the phase).
        robot: the core robot model (the fingertip's pose).
        fps: frames per simulated second.
        cameras: the images to take.
        front_points: (N, 3) world points the ``front`` camera keeps in view (the table and the air above it).
    """

    def __init__(self, built, runner, robot, fps: int, cameras: tuple[CameraSpec, ...], front_points) -> None:
        import mujoco

        from ..sim.model import DEPTH_CAMERA
        from ..sim.video import framed_camera

        self.built, self.runner, self.robot, self.fps = built, runner, robot, fps
        model = built.model
        gripper = built.gripper
        self._gripper_qpos = model.jnt_qposadr[model.actuator_trnid[gripper.actuators, 0]] if len(gripper) else None
        self.rows: list[dict] = []
        self.front_points = np.asarray(front_points, dtype=float)
        self.depth_max_m: dict[str, float] = {}  # a depth camera's range: 0..255 in its video is 0..this (m)
        self._cameras = []
        for spec in cameras:
            renderer = mujoco.Renderer(model, spec.height, spec.width)
            for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION):
                renderer.scene.flags[flag] = False  # most of a software-rendered frame's cost
            view = DEPTH_CAMERA if spec.name == "scene" else framed_camera(front_points, math.radians(model.vis.global_.fovy),
                                                                           spec.width / spec.height)
            self._cameras.append((spec, renderer, view))

    def closing(self, targets: np.ndarray) -> float:
        """How far ``targets`` (gripper joint values) are from open to closed: 0 open, 1 closed (past 1: squeezing)."""
        gripper = self.built.gripper
        if not len(gripper):
            return 0.0
        span = gripper.closed - gripper.opened
        return float(np.mean((targets - gripper.opened) / np.where(span == 0.0, 1.0, span)))

    def after_step(self) -> None:
        if self.built.data.time * self.fps >= len(self.rows) - 1e-9:
            row = self.snapshot()
            if self.rows:  # a frame's action is what the servos are told next: the targets at the next frame
                previous = self.rows[-1]
                previous["action"] = row["action"]
                previous["ee_delta"] = _ee_delta(previous["tip"], self.robot.fk(row["action"][:-1]), row["action"][-1])
            self.rows.append(row)

    def snapshot(self) -> dict:
        """The frame now: ``state``, ``action`` (the servos' targets now), ``ee_delta``, ``phase``, ``tip`` (the
        fingertip's 4x4 pose) and an image per camera (by its name)."""
        built, robot, data = self.built, self.robot, self.built.data
        q = np.array(data.qpos[built.arm_qpos])
        target = np.array(data.ctrl[built.arm_actuators])
        tip, goal = np.asarray(robot.fk(q)), robot.fk(target)
        gripper = self.closing(data.qpos[self._gripper_qpos]) if self._gripper_qpos is not None else 0.0
        command = self.closing(data.ctrl[built.gripper.actuators]) if len(built.gripper) else 0.0
        row = {
            "state": np.concatenate([q, [gripper], tip[:3, 3], rotation_vector(tip[:3, :3])]),
            "action": np.concatenate([target, [command]]),
            "ee_delta": _ee_delta(tip, goal, command),
            "phase": PHASES.index(self.runner.phase),
            "tip": tip,
        }
        for spec, renderer, view in self._cameras:
            renderer.update_scene(data, camera=view)
            row[spec.name] = renderer.render().copy()
            if spec.depth:
                row[f"{spec.name}_depth"] = self._depth(spec.name, renderer)
        return row

    def _depth(self, name: str, renderer) -> np.ndarray:
        """The camera's depth image (its scene already updated) as a video frame: each pixel's distance along
        the optical axis, 0..``depth_max_m[name]`` as grey levels 0..255 (nothing in view: 255). The range is
        set at the first frame: 1.25 times the farthest of ``front_points`` from the camera, in 0.1 m steps
        (about 4-6 mm a level for a table at arm's length)."""
        if name not in self.depth_max_m:
            eye = np.mean([renderer.scene.camera[index].pos for index in range(2)], axis=0)
            farthest = float(np.max(np.linalg.norm(self.front_points - eye, axis=1)))
            self.depth_max_m[name] = math.ceil(12.5 * farthest) / 10.0
        renderer.enable_depth_rendering()
        try:
            depth = renderer.render()
        finally:
            renderer.disable_depth_rendering()
        levels = np.clip(np.rint(255.0 * depth / self.depth_max_m[name]), 0, 255).astype(np.uint8)
        return np.repeat(levels[:, :, None], 3, axis=2)  # grey: lerobot's videos are 3-channel

    def close(self) -> None:
        for _, renderer, _ in self._cameras:
            renderer.close()


def _ee_delta(tip: np.ndarray, goal, command: float) -> np.ndarray:
    """The end-effector action: the fingertip's step from ``tip`` to ``goal`` (world m, rotation vector rad), the gripper."""
    goal = np.asarray(goal)
    return np.concatenate([goal[:3, 3] - tip[:3, 3], rotation_vector(goal[:3, :3] @ tip[:3, :3].T), [command]])
