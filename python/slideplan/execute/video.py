"""Frames of a run, written as a video or a strip."""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Callable

import numpy as np

from ..framing import frame_points, view_direction
from ..transforms import move_planar

VIEW_HEADING_RAD = math.radians(30.0)  # the video's camera stands on the +x side of the table (a three-quarter view)...
VIEW_ELEVATION_RAD = math.radians(30.0)  # ...and this far above the table's plane


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


# A video frame's rendering: no multisampling and coarser spheres and capsules than MuJoCo's defaults. With
# software GL (EGL without a GPU) 4x multisampling was two thirds of a 640x480 frame's cost.
VIDEO_QUALITY = {"offsamples": 0, "numslices": 16, "numstacks": 8, "numquads": 1}
MARK_S = 1.5  # a mark (a push, a re-plan) stays on the frames this long (simulated s)


class Recorder:
    """Renders a frame every ``1 / fps`` simulated seconds when a video is asked for, and reports the
    simulated time every tenth of a second to ``progress``; call :meth:`after_step` after each step. An
    ``.mp4`` is encoded as the frames come (by ffmpeg, in its own process: on another core), so that a run
    with its video costs little more than one without; a ``.gif`` or ``.png`` keeps its frames until
    :meth:`write`. :meth:`mark` writes a line of text on the frames that follow (what just happened).

    Args:
        model, data: the MuJoCo model and its data.
        path: the video file (``.mp4``, ``.gif`` or ``.png``), or None for no video.
        fps: frames per simulated second.
        size: (height, width) of a frame in pixels.
        keep_in_view: (N, 3) world points the fixed view camera keeps in its frame (:func:`plan_points`).
        progress: called with the simulated time (s), or None.
    """

    def __init__(self, model, data, path: str | Path | None, fps: int, size: tuple[int, int], keep_in_view,
                 progress: Callable[[float], None] | None = None):
        import mujoco

        self.data, self.path, self.fps, self.progress = data, path, fps, progress
        self.frames: list[np.ndarray] = []  # a .gif's or .png's, until write()
        self.count = 0  # frames rendered
        self.reported = 0.0
        self.renderer, self.camera, self._writer = None, None, None
        self._mark: tuple[str, float] | None = None  # (text, until simulated time)
        if path is not None:
            quality = model.vis.quality
            kept = {name: getattr(quality, name) for name in VIDEO_QUALITY}
            for name, value in VIDEO_QUALITY.items():  # read when the renderer is made; the depth camera keeps its own
                setattr(quality, name, value)
            try:
                self.renderer = mujoco.Renderer(model, *size)
            finally:
                for name, value in kept.items():
                    setattr(quality, name, value)
            # Shadows and reflections are most of a software-rendered frame's cost (22 ms of 40 at 640x480).
            for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION):
                self.renderer.scene.flags[flag] = False
            self.camera = framed_camera(keep_in_view, math.radians(model.vis.global_.fovy), size[1] / size[0])
            if Path(path).suffix.lower() == ".mp4":
                self._writer = _mp4_writer(Path(path), fps)

    @property
    def active(self) -> bool:
        """Whether :meth:`after_step` does anything."""
        return self.renderer is not None or self.progress is not None

    def mark(self, text: str) -> None:
        """Show ``text`` on the frames of the next MARK_S simulated seconds (a push, a re-plan)."""
        self._mark = (text, float(self.data.time) + MARK_S)

    def after_step(self) -> None:
        data = self.data
        if self.renderer is not None and data.time * self.fps >= self.count:
            self.renderer.update_scene(data, self.camera)
            frame = self.renderer.render()
            if self._mark is not None and data.time <= self._mark[1]:
                frame = _labelled(frame, self._mark[0])
            self.count += 1
            if self._writer is not None:
                self._writer.append_data(frame)
            else:
                self.frames.append(frame.copy())
        if self.progress is not None and data.time >= self.reported + 0.1:
            self.reported = data.time
            self.progress(data.time)

    def close(self) -> None:
        """Free the renderer (frames are kept)."""
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None

    def write(self) -> None:
        """Finish the video file, if one was asked for."""
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        elif self.path is not None:
            write_video(self.frames, Path(self.path), self.fps)


@functools.lru_cache(maxsize=4)
def _font(height: int):
    """Pillow's own font at ``height`` pixels, loaded once (not for every marked frame)."""
    from PIL import ImageFont

    return ImageFont.load_default(size=height)


def _labelled(frame: np.ndarray, text: str) -> np.ndarray:
    """``frame`` with ``text`` in white on a dark band along its top."""
    from PIL import Image, ImageDraw

    image = Image.fromarray(frame)
    height = max(16, frame.shape[0] // 16)
    draw = ImageDraw.Draw(image)
    draw.rectangle((0, 0, frame.shape[1], int(1.5 * height)), fill=(20, 20, 20))
    draw.text((height // 2, height // 4), text, fill=(255, 255, 255), font=_font(height))
    return np.asarray(image)


def _mp4_writer(path: Path, fps: int):
    import imageio.v2 as imageio

    path.parent.mkdir(parents=True, exist_ok=True)
    return imageio.get_writer(path, fps=fps, codec="libx264", quality=7, macro_block_size=8)


def write_video(frames: list[np.ndarray], path: Path, fps: int) -> None:
    """Write rendered frames as MP4 or GIF, or a PNG strip of 6 evenly spaced frames.

    Args:
        frames: (H, W, 3) uint8 images.
        path: output file; its suffix picks the format.
        fps: frames per second.
    """
    import imageio.v2 as imageio

    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = path.suffix.lower()
    if suffix == ".png":
        picks = np.linspace(0, len(frames) - 1, min(6, len(frames))).round().astype(int)
        imageio.imwrite(path, np.concatenate([frames[index] for index in picks], axis=1))
    elif suffix == ".gif":
        imageio.mimsave(path, frames, duration=1000 / fps, loop=0)
    else:
        with _mp4_writer(path, fps) as writer:
            for frame in frames:
                writer.append_data(frame)
