"""The parts of a MuJoCo scene that the renderer of test clouds (:mod:`slideplan.sim.rendering`) and the execution
model (:mod:`slideplan.sim`) share, built with MjSpec: a polygon's prism as convex meshes, and the fixed
depth camera. MuJoCo collides and renders a vertex-only mesh as its convex hull, so a non-convex outline is
added as convex pieces."""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import Polygon

from ..transforms import quaternion_wxyz


def prism_pieces(polygon: Polygon) -> list[np.ndarray]:
    """Convex pieces covering ``polygon``: itself if convex, else its constrained Delaunay triangles, as
    (k, 2) vertex arrays."""
    if polygon.convex_hull.area - polygon.area <= 1e-9 * polygon.area:
        return [np.asarray(polygon.exterior.coords)[:-1]]
    triangles = shapely.constrained_delaunay_triangles(polygon)
    return [np.asarray(piece.exterior.coords)[:-1] for piece in triangles.geoms]


def add_prism(body, spec, name: str, polygon: Polygon, bottom: float, top: float, **geom) -> None:
    """Add the prism of ``polygon`` between heights ``bottom`` and ``top`` to ``body`` (a spec body, e.g.
    ``spec.worldbody``): one mesh and one geom ``{name}_{i}`` per convex piece, each geom with ``geom``'s
    attributes (friction, contype, rgba, ...)."""
    import mujoco

    for index, piece in enumerate(prism_pieces(polygon)):
        vertices = np.vstack([np.column_stack([piece, np.full(len(piece), z)]) for z in (top, bottom)])
        spec.add_mesh(name=f"{name}_{index}", uservert=vertices.ravel().tolist())
        body.add_geom(name=f"{name}_{index}", type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"{name}_{index}", **geom)


def add_camera(spec, name: str, camera) -> None:
    """Add ``camera`` (a :class:`slideplan.perception.camera.Camera`) as the fixed camera ``name``, and make the
    offscreen buffer large enough for its images."""
    # Camera.axes() are MuJoCo's camera frame (x right, y up, looking along -z).
    spec.worldbody.add_camera(name=name, pos=list(camera.position), fovy=camera.fovy_deg, quat=quaternion_wxyz(camera.axes()))
    spec.visual.global_.offwidth = max(spec.visual.global_.offwidth, camera.width)
    spec.visual.global_.offheight = max(spec.visual.global_.offheight, camera.height)
