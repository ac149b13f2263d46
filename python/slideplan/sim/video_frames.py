"""A run's video frames rendered and encoded, in a process of its own (:class:`RenderProcess`).

Software rendering (EGL without a GPU) and encoding cost a 640x480 frame about 3 ms of the stepping
process; rendering in a thread of that process does not overlap the stepping (it slowed the stepping by a
fifth and made 17 frames a second), so the frames are made on the other core: the stepping process sends
each frame's state (a few hundred bytes) and this module's :class:`FrameWriter` turns it into the picture.
"""

from __future__ import annotations

import copy
import functools
import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

# A video frame's rendering: no multisampling and coarser spheres and capsules than MuJoCo's defaults. With
# software GL (EGL without a GPU) 4x multisampling was two thirds of a 640x480 frame's cost.
VIDEO_QUALITY = {"offsamples": 0, "numslices": 16, "numstacks": 8, "numquads": 1}
# x264's cheapest preset: ffmpeg spent 1.15 s on the demo execute's 422 frames, against 1.9 s with "veryfast" and
# 2.6 s with the default "medium"; the file is 1.1 MB instead of 0.3 MB.
X264_PRESET = "ultrafast"


class FrameWriter:
    """Renders a model's states from one free camera and writes them as a video.

    Args:
        model: the MuJoCo model (copied: the copy's visual quality is :data:`VIDEO_QUALITY`, the caller's
            renderers keep theirs).
        camera: the free camera as (look-at point (3,), distance, azimuth in degrees, elevation in degrees).
        path: the video file: ``.mp4`` (encoded as the frames come), ``.gif`` or ``.png`` (a strip of 6 frames).
        fps: frames per second of the video.
        size: (height, width) of a frame in pixels.
    """

    def __init__(self, model, camera, path: str | Path, fps: int, size: tuple[int, int]):
        import mujoco

        model = copy.copy(model)
        for name, value in VIDEO_QUALITY.items():  # read when the renderer is made
            setattr(model.vis.quality, name, value)
        self.model, self.data, self.path, self.fps = model, mujoco.MjData(model), Path(path), fps
        self.renderer = mujoco.Renderer(model, *size)
        # Shadows and reflections are most of a software-rendered frame's cost (22 ms of 40 at 640x480).
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION):
            self.renderer.scene.flags[flag] = False
        self.camera = mujoco.MjvCamera()
        self.camera.lookat[:], self.camera.distance, self.camera.azimuth, self.camera.elevation = camera
        self.frames: list[np.ndarray] = []  # a .gif's or .png's, until finish()
        self._writer = _mp4_writer(self.path, fps) if self.path.suffix.lower() == ".mp4" else None

    def add(self, qpos, mocap_pos, mocap_quat, label: str | None) -> None:
        """Render the state with these positions (MuJoCo's ``qpos``, ``mocap_pos``, ``mocap_quat``), with
        ``label`` written along the frame's top (or None), and append it to the video."""
        import mujoco

        data = self.data
        data.qpos[:], data.mocap_pos[:], data.mocap_quat[:] = qpos, mocap_pos, mocap_quat
        mujoco.mj_kinematics(self.model, data)  # what a picture needs: the bodies', cameras' and lights' poses
        mujoco.mj_comPos(self.model, data)
        mujoco.mj_camlight(self.model, data)
        self.renderer.update_scene(data, self.camera)
        frame = self.renderer.render()
        if label is not None:
            frame = _labelled(frame, label)
        if self._writer is not None:
            self._writer.append_data(frame)
        else:
            self.frames.append(frame.copy())

    def close(self) -> None:
        """No more frames: free the renderer (the frames are kept)."""
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None

    def finish(self) -> None:
        """Finish the video file."""
        self.close()
        if self._writer is not None:
            self._writer.close()
        else:
            write_video(self.frames, self.path, self.fps)


class RenderProcess:
    """A :class:`FrameWriter` in a child process: :meth:`add` sends a state and returns at once (the pipe holds
    a few seconds of frames before it waits for the child), :meth:`finish` waits for the file.

    The child is a fresh interpreter (``python -c``), not a fork: the stepping process may hold a GL
    context of its own, and a spawned ``multiprocessing`` child would import the caller's main script again.

    Args:
        as for :class:`FrameWriter` (``model`` is pickled to the child, so the caller's is untouched).
    """

    def __init__(self, model, camera, path: str | Path, fps: int, size: tuple[int, int]):
        self.path = Path(path)
        package_root = str(Path(__file__).resolve().parents[2])  # the slideplan this process imported
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [package_root, os.environ.get("PYTHONPATH")])))
        env.setdefault("MUJOCO_GL", "egl")
        env.setdefault("LP_NUM_THREADS", "0")  # software GL renders in the child's own thread, not on the stepping core too
        self._errors = tempfile.TemporaryFile()  # not a pipe: a child that writes much to it never blocks
        self._child = subprocess.Popen([sys.executable, "-c", f"from {__name__} import serve; serve()"],
                                       stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=self._errors, env=env)
        self._send((model, tuple(camera), str(path), fps, tuple(size)))

    def add(self, qpos, mocap_pos, mocap_quat, label: str | None) -> None:
        """Send one frame's state (copied) to the child."""
        self._send((np.array(qpos), np.array(mocap_pos), np.array(mocap_quat), label))

    def close(self) -> None:
        """No more frames: the child finishes the file on its own (:meth:`finish` waits for it)."""
        if not self._child.stdin.closed:
            try:
                self._child.stdin.close()
            except BrokenPipeError:
                pass

    def finish(self) -> None:
        """Wait for the child to write the video (again: nothing).

        Raises:
            OSError: the child failed (the last line of its error output in the message, all of it in a note).
        """
        self.close()
        if self._errors.closed:
            return
        code = self._child.wait()
        self._errors.seek(0)
        errors = self._errors.read().decode(errors="replace").strip()
        self._errors.close()
        if code != 0:  # an OSError: the file was not written (the CLI's one-line error, exit 2)
            error = OSError(f"{self.path}: the video's render process failed (exit {code}): "
                            f"{errors.splitlines()[-1] if errors else 'no message'}")
            error.add_note(errors)  # the child's whole error output, in a traceback
            raise error

    def _send(self, message) -> None:
        if self._child.stdin.closed:
            return
        try:
            pickle.dump(message, self._child.stdin, protocol=pickle.HIGHEST_PROTOCOL)
            self._child.stdin.flush()
        except BrokenPipeError:  # the child has died: finish() says why
            self.finish()


def serve() -> None:
    """The child's side of :class:`RenderProcess`: a FrameWriter's arguments, then frames, read from stdin
    until it closes."""
    os.nice(5)  # the stepping comes first: the frames (and ffmpeg, started from here) wait for a free core
    stream = sys.stdin.buffer
    writer = FrameWriter(*pickle.load(stream))
    while True:
        try:
            frame = pickle.load(stream)
        except EOFError:
            break
        writer.add(*frame)
    writer.finish()


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
    return imageio.get_writer(path, fps=fps, codec="libx264", quality=7, macro_block_size=8,
                              ffmpeg_params=["-preset", X264_PRESET])


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
