"""Frames of a run, written as a video or a strip."""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np


class Recorder:
    """Renders a frame every ``1 / fps`` simulated seconds when a video is asked for, and reports the
    simulated time every tenth of a second to ``progress``; call :meth:`after_step` after each step.

    Args:
        model, data: the MuJoCo model and its data.
        path: the video file (``.mp4``, ``.gif`` or ``.png``), or None for no video.
        fps: frames per simulated second.
        size: (height, width) of a frame in pixels.
        look_at: (x, y, z) the view camera looks at.
        progress: called with the simulated time (s), or None.
    """

    def __init__(self, model, data, path: str | Path | None, fps: int, size: tuple[int, int], look_at,
                 progress: Callable[[float], None] | None = None):
        import mujoco

        self.data, self.path, self.fps, self.progress = data, path, fps, progress
        self.frames: list[np.ndarray] = []
        self.reported = 0.0
        self.renderer, self.camera = None, None
        if path is not None:
            self.renderer = mujoco.Renderer(model, *size)
            # Shadows and reflections are most of a software-rendered frame's cost (22 ms of 40 at 640x480).
            for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION):
                self.renderer.scene.flags[flag] = False
            self.camera = mujoco.MjvCamera()
            self.camera.lookat[:] = look_at
            self.camera.distance, self.camera.azimuth, self.camera.elevation = 1.1, 210.0, -30.0

    @property
    def active(self) -> bool:
        """Whether :meth:`after_step` does anything."""
        return self.renderer is not None or self.progress is not None

    def after_step(self) -> None:
        data = self.data
        if self.renderer is not None and data.time * self.fps >= len(self.frames):
            self.renderer.update_scene(data, self.camera)
            self.frames.append(self.renderer.render().copy())
        if self.progress is not None and data.time >= self.reported + 0.1:
            self.reported = data.time
            self.progress(data.time)

    def close(self) -> None:
        """Free the renderer (frames are kept)."""
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None

    def write(self) -> None:
        """Write the frames to the video file, if one was asked for."""
        if self.path is not None:
            write_video(self.frames, Path(self.path), self.fps)


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
        with imageio.get_writer(path, fps=fps, codec="libx264", quality=7, macro_block_size=8) as writer:
            for frame in frames:
                writer.append_data(frame)
