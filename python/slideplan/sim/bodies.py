"""The world of an execution model: the table (convex prisms) and the object (boxes on a grid, one
free body), added to an ``mujoco.MjSpec`` with their collision groups (:mod:`.contacts`)."""

from __future__ import annotations

import numpy as np
import shapely
import shapely.affinity
from shapely.geometry import Polygon

from ..world.geometry import SupportSurface
from .mjscene import add_prism
from .contacts import ContactModel
from .settings import ExecutionSettings

TABLE_THICKNESS = 0.05


def cloud_footprint(points: np.ndarray) -> Polygon | shapely.MultiPolygon:
    """The outline of a top-surface point cloud: a morphological closing of its points.

    Each point is widened by the cloud's spacing (90th percentile of the nearest-neighbour
    distances of up to 500 of its points; boundary samples are denser than the grid inside), which
    joins neighbours on a grid, and the union is shrunk back by the same amount, so concavities and
    holes wider than 2 spacings stay open.

    Args:
        points: (N, 3) cloud.

    Returns:
        The footprint polygon(s), world frame.
    """
    xy = np.asarray(points, dtype=float)[:, :2]
    sample = xy[:: max(1, len(xy) // 500)]
    distances = np.linalg.norm(sample[:, None, :] - xy[None, :, :], axis=2)
    distances[distances == 0] = np.inf
    radius = max(float(np.percentile(distances.min(axis=1), 90)), 1e-4)
    return shapely.unary_union(shapely.buffer(shapely.points(xy), radius, quad_segs=4)).buffer(-radius, quad_segs=4)


def object_boxes(points: np.ndarray, cell_size: float) -> np.ndarray:
    """Boxes tiling the footprint of a top-surface point cloud on a square grid.

    Each grid cell that meets the footprint (:func:`cloud_footprint`) becomes the bounding box of
    its part of the footprint, so the boxes cover the whole outline (the fingertip finds the object
    wherever the plan touches it) and overfill only where an edge crosses a cell diagonally.

    Args:
        points: (N, 3) cloud.
        cell_size: grid spacing (m).

    Returns:
        (K, 4) boxes ``[centre x, centre y, half width x, half width y]``, K >= 1.
    """
    xy = np.asarray(points, dtype=float)[:, :2]
    footprint = cloud_footprint(points)
    low, high = xy.min(axis=0), xy.max(axis=0)
    counts = np.maximum(np.ceil((high - low) / cell_size).astype(int), 1)
    corner = (low + high) / 2 - counts * cell_size / 2
    cells = shapely.box(*np.stack(np.meshgrid(
        *(corner[axis] + cell_size * np.arange(counts[axis]) for axis in (0, 1))), axis=-1).reshape(-1, 2).T,
        *(np.stack(np.meshgrid(*(corner[axis] + cell_size * np.arange(1, counts[axis] + 1) for axis in (0, 1))),
                   axis=-1).reshape(-1, 2).T))
    parts = shapely.intersection(cells, footprint)
    parts = parts[shapely.area(parts) > 1e-3 * cell_size**2]
    bounds = shapely.bounds(parts)  # (K, 4): xmin, ymin, xmax, ymax
    boxes = np.column_stack([(bounds[:, :2] + bounds[:, 2:]) / 2, (bounds[:, 2:] - bounds[:, :2]) / 2])
    if len(boxes):
        return boxes
    return np.array([[*((low + high) / 2), *np.maximum((high - low) / 2, 1e-3)]])


def add_world(spec, result, settings: ExecutionSettings, points: np.ndarray, com: np.ndarray, contacts: ContactModel) -> None:
    """Add the table prism and the object (boxes on a grid over the top cloud ``points``, one free body
    with its origin at ``com``) to the spec; with ``contacts.feet``, the object rests on the spheres of
    :func:`feet` (under the boxes, or under the cells of a coarser grid of ``contacts.feet_cell``), which
    alone touch the table (:mod:`.contacts`)."""
    import mujoco

    groups = contacts.groups
    height = float(result.table["height"])
    table = SupportSurface.from_vertices(result.table["polygon"], height, field="table.polygon")
    add_prism(spec.worldbody, spec, "slideplan_table", table.polygon, height - TABLE_THICKNESS, height,
              contype=groups.table[0], conaffinity=groups.table[1], friction=[settings.table_friction, 0.005, 0.0001],
              rgba=[0.55, 0.45, 0.35, 1])
    thickness = float(result.object["thickness"])
    boxes = object_boxes(points, settings.cell_size)
    body = spec.worldbody.add_body(name="slideplan_object", pos=[com[0], com[1], height + thickness / 2])
    body.add_freejoint(name="slideplan_object_free")
    for index, (x, y, half_x, half_y) in enumerate(boxes):
        body.add_geom(
            name=f"slideplan_object_{index}",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[half_x, half_y, thickness / 2],
            pos=[x - com[0], y - com[1], 0.0],
            density=settings.object_density,
            contype=groups.shell[0],
            conaffinity=groups.shell[1],
            friction=[settings.table_friction, 0.005, 0.0001],
            rgba=[0.2, 0.5, 0.8, 1],
        )
    if groups.feet is not None:
        under = boxes if contacts.feet_cell is None else object_boxes(points, contacts.feet_cell)
        for index, (x, y, z, radius) in enumerate(feet(under, thickness, contacts.feet)):
            body.add_geom(  # massless (the boxes carry the mass), never drawn (group 3)
                name=f"slideplan_object_foot_{index}",
                type=mujoco.mjtGeom.mjGEOM_SPHERE,
                size=[radius, 0, 0],
                pos=[x - com[0], y - com[1], z],
                density=0.0,
                contype=groups.feet[0],
                conaffinity=groups.feet[1],
                friction=[settings.table_friction, 0.005, 0.0001],
                group=3,
                rgba=[0.2, 0.5, 0.8, 0],
            )
    add_obstacles(spec, getattr(result, "obstacles", None) or [], settings, contacts)
    spec.worldbody.add_light(pos=[0.5, 0, 2.0], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)


def add_obstacles(spec, obstacles: list[dict], settings: ExecutionSettings, contacts: ContactModel) -> None:
    """Add the scene's obstacles (their plan JSON entries): boxes and cylinders fixed to the world where they
    stand (a can, a book on end, a wall), other thin objects as free bodies of the object's density lying
    where they lie (pushed, they move). Each is named ``slideplan_clutter_<index>``."""
    import mujoco

    attributes = dict(contype=contacts.groups.clutter[0], conaffinity=contacts.groups.clutter[1],
                      friction=[settings.table_friction, 0.005, 0.0001], rgba=[0.8, 0.35, 0.25, 1])
    for index, entry in enumerate(obstacles):
        name = f"slideplan_clutter_{index}"
        shape = entry.get("shape", "box")
        if shape == "box":
            yaw = float(entry.get("yaw", 0.0))
            spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.5 * s for s in entry["size"]],
                                    pos=list(entry["center"]), quat=[np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)], **attributes)
        elif shape == "cylinder":
            spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                                    size=[float(entry["radius"]), 0.5 * float(entry["height"]), 0.0], pos=list(entry["center"]),
                                    **attributes)
        else:  # a thin object: its prism, free
            polygon = Polygon(entry["polygon"])
            centre = polygon.centroid
            body = spec.worldbody.add_body(name=name, pos=[centre.x, centre.y, float(entry["bottom"])])
            body.add_freejoint(name=f"{name}_free")
            local = shapely.affinity.translate(polygon, -centre.x, -centre.y)
            add_prism(body, spec, name, local, 0.0, float(entry["height"]), density=settings.object_density, **attributes)




FOOT_RADIUS = 0.001  # m, a corner foot: it stands out of the outline by this much at most


def feet(boxes: np.ndarray, thickness: float, where: str) -> np.ndarray:
    """The spheres the object rests on: ``"corners"``, one at each distinct corner of the boxes
    (where a box on the table touches it; a corner shared by neighbouring boxes once), radius
    ``FOOT_RADIUS``; ``"centres"``, one at the centre of each box's bottom face, radius half the
    thickness (at most half the box's width). Each touches the table's plane with its lowest point.

    Returns:
        (F, 4) ``[x, y, z, radius]``, x and y in the world frame, z from the object's mid-plane.
    """
    if where == "centres":
        radius = np.minimum(np.minimum(boxes[:, 2], boxes[:, 3]), thickness / 2)
        return np.column_stack([boxes[:, :2], radius - thickness / 2, radius])
    corners = np.vstack([boxes[:, :2] + np.column_stack([sx * boxes[:, 2], sy * boxes[:, 3]])
                         for sx in (-1, 1) for sy in (-1, 1)])
    corners = np.unique(np.round(corners / 1e-5).astype(np.int64), axis=0) * 1e-5
    radius = min(FOOT_RADIUS, thickness / 2)
    return np.column_stack([corners, np.full(len(corners), radius - thickness / 2), np.full(len(corners), radius)])
