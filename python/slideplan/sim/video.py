"""Frames of a run, written as a video or a strip."""

from __future__ import annotations

import contextlib
import math
import os
from pathlib import Path
from typing import Callable

import numpy as np

from .._files import temporary_path
from ..perception.framing import frame_points, view_direction
from ..transforms import move_planar
from .video_frames import RenderProcess

VIEW_HEADING_RAD = math.radians(30.0)  # the video's camera stands on the +x side of the table (a three-quarter view)...
VIEW_ELEVATION_RAD = math.radians(30.0)  # ...and this far above the table's plane
# Frames per simulated second: the render process must keep pace with the stepping (about 14x real time
# here), and at 20 a video cost 1.5x the run without one (docs/benchmarks/video.md); the slide moves 3 mm a frame.
VIDEO_FPS = 15


def plan_points(result, robot) -> np.ndarray:
    """What a video of a plan's execution must show: the table's corners, the object at its start and
    planned final poses, and the hand (fingertip and grasp frame) along the slide, the approach and the lift.

    Args:
        result: the plan (solved).
        robot: its core robot model.

    Returns:
        (N, 3) world points.
    """
    height = float(result.table["height"])
    polygon = np.asarray(result.table["polygon"], dtype=float)
    start = np.asarray(result.object["points"], dtype=float)
    motion = result.object_motion
    final = move_planar(start[:, :2], (float(motion["x"]), float(motion["y"]), float(motion["yaw"])))
    configs = np.concatenate([np.asarray(result.trajectory, dtype=float), np.asarray(result.grasp["approach"], dtype=float)])
    link, offset = result.robot["grasp_link"], np.asarray(result.robot["grasp_offset"], dtype=float)
    hand = [np.asarray(robot.fk(q))[:3, 3] for q in configs] + [np.asarray(robot.frame_pose(q, link, offset))[:3, 3] for q in configs]
    lifted = np.asarray(hand[-1]) + (0.0, 0.0, 0.1)  # above the grasp: the lift
    return np.vstack([np.column_stack([polygon, np.full(len(polygon), height)]), start,
                      np.column_stack([final, start[:, 2]]), np.asarray(hand), lifted])


def framed_camera(points, fov_y: float, aspect: float):
    """A MuJoCo free camera, from the video's fixed direction, that keeps ``points`` in its frame."""
    import mujoco

    back = view_direction(VIEW_HEADING_RAD, VIEW_ELEVATION_RAD)
    look_at, position = frame_points(points, back, fov_y, aspect)
    camera = mujoco.MjvCamera()
    camera.lookat[:] = look_at
    camera.distance = float(np.linalg.norm(position - look_at))
    # MuJoCo looks along (cos el cos az, cos el sin az, sin el), from the camera to the look-at point.
    camera.azimuth = math.degrees(math.atan2(-back[1], -back[0]))
    camera.elevation = -math.degrees(VIEW_ELEVATION_RAD)
    return camera


MARK_S = 1.5  # a mark (a push, a re-plan) stays on the frames this long (simulated s)


class Recorder:
    """Sends a frame every ``1 / fps`` simulated seconds to a render process when a video is asked for
    (:class:`slideplan.sim.video_frames.RenderProcess`: rendered and encoded on another core, so that a
    run with its video costs little more than one without), and reports the simulated time every tenth of a
    second to ``progress``; call :meth:`after_step` after each step. :meth:`mark` writes a line of text on the
    frames that follow (what just happened).

    Args:
        model, data: the MuJoCo model and its data.
        path: the video file (``.mp4``, ``.gif`` or ``.png``), or None for no video.
        fps: frames per simulated second.
        size: (height, width) of a frame in pixels.
        keep_in_view: (N, 3) world points the fixed view camera keeps in its frame (:func:`plan_points`).
        progress: called with the simulated time (s), or None.
        frames: makes the frames, called as ``frames(model, camera, path, fps, size)`` (default
            :class:`~slideplan.sim.video_frames.RenderProcess`; :class:`~slideplan.sim.video_frames.FrameWriter`
            renders in this process).
    """

    def __init__(self, model, data, path: str | Path | None, fps: int, size: tuple[int, int], keep_in_view,
                 progress: Callable[[float], None] | None = None, frames=RenderProcess):
        self.data, self.fps, self.size, self.progress = data, fps, size, progress
        self.count = 0  # frames sent
        self.reported = 0.0
        self.camera, self._frames = None, None
        self._mark: tuple[str, float] | None = None  # (text, until simulated time)
        self._path = self._partial = None  # the video's file, and where it is written until finished
        if path is not None:
            self.camera = framed_camera(keep_in_view, math.radians(model.vis.global_.fovy), size[1] / size[0])
            view = (np.array(self.camera.lookat), self.camera.distance, self.camera.azimuth, self.camera.elevation)
            self._path, self._partial = Path(path), temporary_path(path)
            self._frames = frames(model, view, self._partial, fps, size)

    @property
    def active(self) -> bool:
        """Whether :meth:`after_step` does anything."""
        return self._frames is not None or self.progress is not None

    def mark(self, text: str) -> None:
        """Show ``text`` on the frames of the next MARK_S simulated seconds (a push, a re-plan)."""
        self._mark = (text, float(self.data.time) + MARK_S)

    def after_step(self) -> None:
        data = self.data
        if self._frames is not None and data.time * self.fps >= self.count:
            label = self._mark[0] if self._mark is not None and data.time <= self._mark[1] else None
            self._frames.add(data.qpos, data.mocap_pos, data.mocap_quat, label)
            self.count += 1
        if self.progress is not None and data.time >= self.reported + 0.1:
            self.reported = data.time
            self.progress(data.time)

    def close(self) -> None:
        """No more frames (the video is finished by :meth:`write`)."""
        if self._frames is not None:
            self._frames.close()

    def write(self) -> None:
        """Finish the video file, if one was asked for (waits for the render process).

        Raises:
            OSError: the render process failed (:meth:`slideplan.sim.video_frames.RenderProcess.finish`).
        """
        if self._frames is not None:
            frames, self._frames = self._frames, None
            try:
                frames.finish()
                os.replace(self._partial, self._path)  # whole or not at all: a failed run keeps the file that was there
            except OSError as error:  # named by the file asked for, not the temporary one
                raise OSError(str(error).replace(str(self._partial), str(self._path))) from None
            finally:
                with contextlib.suppress(OSError):
                    os.unlink(self._partial)
