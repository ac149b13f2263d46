"""A perception written for ``slideplan plan``: the perceived scene as a scene file (:func:`scene_toml`) and
the thin objects as clouds beside it (:func:`write_perception`)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .._fields import as_numbers
from .._files import replacing, write_text
from ..errors import InputError
from .tabletop import Perception
from ..world.scenes import load_scene, robot_toml


def _toml_numbers(values) -> str:
    return "[" + ", ".join(f"{float(value):.6g}" for value in values) + "]"


def scene_toml(perception: Perception, robot_scene: str | Path = "square", *, directory: Path | None = None,
               base_pose=None) -> str:
    """The perceived scene in the scene-file format of :func:`slideplan.world.scenes.load_scene`.

    Args:
        perception: what :func:`perceive` found.
        robot_scene: built-in scene name or scene TOML whose robot section is copied (the
            cloud does not show where the robot stands). Its mount keeps its height above its own
            table top: a cloud with the floor at z = 0 and the table at 0.72 m lifts the robot with it.
        directory: where the scene file goes: its robot files are named relative to it (or by
            ``package://``, or by name when bundled), so the folder can move to another machine.
        base_pose: the robot's mount in the cloud's frame (x, y, z, roll, pitch, yaw) instead.

    Returns:
        The TOML text.

    Raises:
        InputError: a base pose that is not 6 finite numbers (field ``base_pose``).
    """
    robot = load_scene(robot_scene)
    if base_pose is None:
        base_pose = np.array(robot.base_pose, dtype=float)
        base_pose[2] += perception.table.height - robot.table.height
        mount = f"its mount {perception.table.height - robot.table.height:+.3f} m in z, as high above the table top"
    else:
        base_pose = as_numbers(base_pose, 6, source="", field="base_pose")
        mount = "the mount given"
    polygon = ", ".join(_toml_numbers(vertex) for vertex in perception.table.vertices)
    lines = [
        f"# Perceived by slideplan perceive (table tilt {perception.tilt_deg:.2f} deg, grid {1000 * perception.cell_size:.1f} mm);",
        f"# robot from {robot.source} ({mount}). {len(perception.objects)} thin objects: object_<i> clouds beside this file.",
        "",
        "[table]",
        f"polygon = [{polygon}]",
        f"height = {perception.table.height:.6g}",
        "",
        *robot_toml(robot, directory, base_pose),
    ]
    for box in perception.obstacles:
        lines += ["", "[[obstacles]]", f"center = {_toml_numbers(box.center)}", f"size = {_toml_numbers(box.size)}",
                  f"yaw = {box.yaw:.6g}"]
    return "\n".join(lines) + "\n"


def write_perception(perception: Perception, out_dir: str | Path, *, robot_scene: str | Path = "square",
                     cloud_suffix: str = ".ply", base_pose=None) -> tuple[Path, list[Path]]:
    """Write ``scene.toml`` and ``object_<i>.ply`` (or ``.npy``) for ``slideplan plan``.

    Args:
        perception: what :func:`perceive` found.
        out_dir: output directory (created).
        robot_scene: scene whose robot section goes into ``scene.toml`` (see :func:`scene_toml`).
        cloud_suffix: ``.ply`` or ``.npy``.
        base_pose: the robot's mount in the cloud's frame instead of ``robot_scene``'s, shifted.

    Returns:
        (the scene file, the object cloud files in object order).

    Raises:
        InputError: an unsupported cloud suffix.
    """
    import plyfile

    if cloud_suffix not in (".ply", ".npy"):
        raise InputError(f"expected .ply or .npy, got {cloud_suffix!r}", field="cloud_suffix")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    # An earlier run's objects must not pass for this run's (it may have found more of them).
    for stale in out_dir.glob("object_*"):
        if re.fullmatch(r"object_\d+\.(ply|npy)", stale.name):
            stale.unlink()
    scene_path = out_dir / "scene.toml"
    write_text(scene_path, scene_toml(perception, robot_scene, directory=out_dir, base_pose=base_pose))
    cloud_paths = []
    for index, perceived in enumerate(perception.objects):
        path = out_dir / f"object_{index}{cloud_suffix}"
        if cloud_suffix == ".npy":
            with replacing(path) as temporary:
                np.save(temporary, perceived.points)
        else:
            vertices = np.array([tuple(point) for point in perceived.points], dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
            with replacing(path) as temporary:
                plyfile.PlyData([plyfile.PlyElement.describe(vertices, "vertex")]).write(str(temporary))
        cloud_paths.append(path)
    return scene_path, cloud_paths
