"""Scene clouds rendered with MuJoCo, with their ground truth: test data for :mod:`slideplan.perception.tabletop`.

A scene's table (a 3 cm slab), thin objects (their outlines extruded as prisms) and box
clutter stand on a floor; MuJoCo's offscreen renderer takes a depth image from a camera
above the table; the depth image is back-projected through the camera intrinsics (:mod:`slideplan.perception.camera`; vertical
field of view, square pixels) into a world-frame cloud, with depth noise that grows with
the square of the distance (as for structured-light and stereo sensors) and random
dropouts. Needs the ``perception`` extra (``mujoco``); headless machines need
``MUJOCO_GL=egl`` (set here unless the environment sets it; it must be set before anything
imports ``mujoco``).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from shapely.geometry import Polygon

from ..perception.camera import Camera, back_project
from ..world.geometry import SupportSurface
from .mjscene import add_camera, add_prism
from ..world.objects import load_outline, place_outline

TABLE_SLAB_M = 0.03  # table top thickness
FLOOR_BELOW_M = 0.75  # floor this far below the table top, as under an ordinary table
_FAR = 50.0  # far clipping plane, in model extents (MJCF's unit for it): a pixel there saw nothing


@dataclass(frozen=True)
class PlacedObject:
    """A thin object of the scene, as placed (the ground truth).

    Attributes:
        name: the outline's name (``data/objects/<name>.toml`` or a TOML path).
        pose: (x, y, yaw) of the object frame (m, m, rad).
        thickness: prism height (m).
        outline: the outline in the world frame.
    """

    name: str
    pose: tuple[float, float, float]
    thickness: float
    outline: Polygon


@dataclass(frozen=True)
class Box:
    """A box of clutter standing on the table or the floor.

    Attributes:
        center: (x, y, z) of the box centre (m).
        size: full extents (m).
        yaw: rotation about z (rad).
    """

    center: tuple[float, float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0


@dataclass
class RenderedScene:
    """A rendered scene cloud and its ground truth.

    Attributes:
        points: (N, 3) world-frame cloud (dropouts removed).
        table: the true table.
        objects: the true thin objects.
        clutter: the clutter boxes.
        camera: the camera used.
    """

    points: np.ndarray
    table: SupportSurface
    objects: list[PlacedObject]
    clutter: list[Box] = field(default_factory=list)
    camera: Camera | None = None


def place_objects(specs) -> list[PlacedObject]:
    """Read outlines and place them.

    Args:
        specs: iterable of (name or TOML path, (x, y, yaw)) or (name, (x, y, yaw), thickness);
            the thickness defaults to the outline file's.

    Returns:
        The placed objects.
    """
    placed = []
    for spec in specs:
        name, pose = spec[0], tuple(float(value) for value in spec[1])
        outline, thickness, label = load_outline(name)
        thickness = float(spec[2]) if len(spec) > 2 else thickness
        placed.append(PlacedObject(label, pose, thickness, place_outline(outline, pose)))
    return placed


def scene_spec(table: SupportSurface, objects: list[PlacedObject], clutter: list[Box], camera: Camera,
               obstacles: list[dict] = ()):
    """The MuJoCo model (an ``mujoco.MjSpec``, :mod:`slideplan.sim.mjscene`'s parts, as the execution model
    builds them) of a table scene.

    Args:
        table: the table (its top at ``table.height``; a non-convex one as convex pieces).
        objects: the thin objects lying on it (prisms of their outlines).
        clutter: boxes.
        camera: the depth camera (named ``depth``).
        obstacles: a scene's obstacles (plan JSON entries), as the execution model builds them.

    Returns:
        The spec, to compile.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco: headless rendering
    import mujoco

    spec = mujoco.MjSpec()
    spec.visual.map.znear, spec.visual.map.zfar = 0.01, _FAR
    top, world = table.height, spec.worldbody
    world.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1], pos=[0, 0, top - FLOOR_BELOW_M])
    add_prism(world, spec, "table", table.polygon, top - TABLE_SLAB_M, top, rgba=[0.6, 0.5, 0.4, 1])
    for index, placed in enumerate(objects):
        add_prism(world, spec, f"object{index}", placed.outline, top, top + placed.thickness, rgba=[0.2, 0.4, 0.8, 1])
    for box in clutter:
        world.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.5 * size for size in box.size], pos=list(box.center),
                       quat=[math.cos(0.5 * box.yaw), 0.0, 0.0, math.sin(0.5 * box.yaw)], rgba=[0.8, 0.3, 0.2, 1])
    if obstacles:
        from .bodies import add_obstacles
        from .contacts import CURRENT
        from .settings import ExecutionSettings

        add_obstacles(spec, list(obstacles), ExecutionSettings(), CURRENT)
    add_camera(spec, "depth", camera)
    return spec


def depth_image(spec, camera: Camera) -> np.ndarray:
    """Render the depth image (distance along the optical axis, m) of the model's camera.

    Args:
        spec: the model (from :func:`scene_spec`).
        camera: its camera (for the image size).

    Returns:
        (height, width) array, row 0 at the top of the image; NaN where no surface is in view.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")
    import mujoco

    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with mujoco.Renderer(model, camera.height, camera.width) as renderer:
        renderer.enable_depth_rendering()
        return camera_depth(renderer, model, data, "depth")


def camera_depth(renderer, model, data, camera_name: str) -> np.ndarray:
    """Render the depth image of a model's named camera now (as :func:`depth_image`, for a model that
    runs: the closed loop's camera over the arm).

    Args:
        renderer: a ``mujoco.Renderer`` of the camera's image size, depth rendering enabled.
        model, data: the model and its current state.
        camera_name: the camera.

    Returns:
        (height, width) distances along the optical axis (m); NaN where nothing is in view.
    """
    renderer.update_scene(data, camera=camera_name)
    depth = renderer.render().copy()
    depth[depth >= 0.99 * model.vis.map.zfar * model.stat.extent] = np.nan
    return depth


def noisy_depth(depth: np.ndarray, noise_at_1m: float, dropout: float, rng: np.random.Generator) -> np.ndarray:
    """Add sensor noise and dropouts to a depth image.

    Args:
        depth: (height, width) true depths (m).
        noise_at_1m: standard deviation of the depth error at 1 m (m); it scales with depth
            squared (about 1 mm at 0.7 m and 3 mm at 1.2 m for 0.002).
        dropout: fraction of pixels with no return, in [0, 1).
        rng: random generator.

    Returns:
        The noisy depth image, NaN where a pixel dropped out.
    """
    noisy = depth + rng.normal(size=depth.shape) * noise_at_1m * depth**2
    noisy[rng.random(depth.shape) < dropout] = np.nan
    return noisy


def render_scene(
    table: SupportSurface,
    objects: list[PlacedObject],
    *,
    clutter: Sequence[Box] = (),
    camera: Camera | None = None,
    noise_at_1m: float = 0.002,
    dropout: float = 0.05,
    seed: int = 0,
) -> RenderedScene:
    """Render a table scene into a noisy world-frame cloud.

    Args:
        table: the table.
        objects: thin objects on it (see :func:`place_objects`).
        clutter: boxes.
        camera: the camera; default 0.75 m above the table's centroid, 0.15 m towards -x,
            looking at the centroid, 320 x 240 pixels, 45 deg vertical field of view.
        noise_at_1m: depth noise at 1 m (m), see :func:`noisy_depth`.
        dropout: fraction of missing pixels.
        seed: seed of the noise.

    Returns:
        The cloud and the ground truth.
    """
    if camera is None:
        center = table.polygon.centroid
        camera = Camera((center.x - 0.15, center.y, table.height + 0.75), (center.x, center.y, table.height))
    clutter = list(clutter)
    depth = depth_image(scene_spec(table, objects, clutter, camera), camera)
    depth = noisy_depth(depth, noise_at_1m, dropout, np.random.default_rng(seed))
    return RenderedScene(back_project(depth, camera), table, list(objects), clutter, camera)
