"""The depth camera's mounting error found from what it sees of the robot (slideplan.perception.calibration)."""

import numpy as np
import pytest

from slideplan import load_scene
from slideplan.perception.calibration import calibrate, pose_offset
from slideplan.perception.camera import pixel_points
from slideplan.sim.conditions import camera_as_mounted
from slideplan.sim.rendering import Box, depth_image, noisy_depth, scene_spec
from slideplan.sim.closed_loop import default_camera

# Boxes standing in for an arm over the table: a forearm, a wrist and a finger, at several heights and turns.
ARM = [Box((0.45, -0.05, 0.16), (0.2, 0.06, 0.05), 0.5), Box((0.55, 0.02, 0.1), (0.05, 0.04, 0.08), -0.3),
       Box((0.58, 0.03, 0.045), (0.015, 0.015, 0.05), 0.0)]
ERROR = {"camera_dx_m": 0.006, "camera_dy_m": -0.008, "camera_dz_m": 0.004,
         "camera_rx_deg": 0.6, "camera_ry_deg": -0.8, "camera_rz_deg": 0.5}


def _views(scene, arm, draws):
    """A noisy frame of the arm from where the camera is mounted, and the arm alone as the believed camera
    would see it (NaN off the arm)."""
    believed = default_camera(scene)
    mounted = camera_as_mounted(believed, draws)
    table = scene.table
    seen = noisy_depth(depth_image(scene_spec(table, [], arm, mounted), mounted), 0.002, 0.05, np.random.default_rng(4))
    expected = depth_image(scene_spec(table, [], arm, believed), believed)
    points = pixel_points(expected, believed)
    expected[~(points[..., 2] > table.height + 0.005)] = np.nan  # the arm alone: no table
    return believed, mounted, seen, expected


def test_the_camera_is_put_where_it_is_mounted_from_the_arm_it_sees():
    scene = load_scene("square")
    believed, mounted, seen, expected = _views(scene, ARM, ERROR)
    drawn = pose_offset(believed, mounted)
    assert drawn["dx_m"] == pytest.approx(0.006) and drawn["ry_deg"] == pytest.approx(-0.8)
    fix = calibrate(seen, expected, believed, scene.table.height)
    assert fix is not None and fix.rmse_m < 0.002
    # Where a point of the table seen by the mounted camera is read: through the believed camera a centimetre
    # off, through the corrected one within 1.5 mm, over the whole table.
    table = np.array([[x, y, scene.table.height, 1.0] for x in (0.3, 0.5, 0.7) for y in (-0.2, 0.0, 0.2)])

    def misread(camera):
        return np.linalg.norm((table @ (camera.optical_pose() @ np.linalg.inv(mounted.optical_pose())).T - table)[:, :3], axis=1)

    assert misread(believed).min() > 0.008
    assert misread(fix.corrected(believed)).max() < 0.0015, misread(fix.corrected(believed))
    # The table as the believed camera reads it is tilted and off its height by the error; read through the
    # corrected camera it is level, at its height.
    points = pixel_points(seen, believed).reshape(-1, 3)
    points = points[np.isfinite(points).all(axis=1) & (np.abs(points[:, 2] - scene.table.height) < 0.015)]
    tilted = np.linalg.lstsq(np.column_stack([points[:, :2], np.ones(len(points))]), points[:, 2], rcond=None)[0]
    corners = np.array([[0.3, -0.2], [0.7, 0.2], [0.3, 0.2], [0.7, -0.2]])  # the table's
    heights = lambda plane: corners @ plane[:2] + plane[2]  # noqa: E731
    assert np.max(np.abs(heights(tilted) - scene.table.height)) > 0.004
    assert np.max(np.abs(heights(np.asarray(fix.plane(tilted))) - scene.table.height)) < 0.0015


def test_a_frame_with_too_little_of_the_arm_fixes_nothing():
    scene = load_scene("square")
    believed, _, seen, expected = _views(scene, [Box((0.55, 0.0, 0.05), (0.01, 0.01, 0.01))], ERROR)
    assert calibrate(seen, expected, believed, scene.table.height) is None


def test_a_run_starts_through_the_camera_the_arm_held_over_the_object_puts():
    # The hard setting's draw for seed 8 mounts the camera 1.4 cm and about 1 deg off; before its plan a run
    # holds the arm over the object, and perceives and plans through the camera found from it.
    from slideplan.sim.closed_loop import Start

    scene = load_scene("square")
    start = Start.of(scene, "crescent", (0.55, -0.08, 0.4), seed=8, setting="hard")
    point = np.array([0.55, -0.08, scene.table.height, 1.0])

    def misread(camera):
        read = camera.optical_pose() @ np.linalg.inv(start.mounted.optical_pose()) @ point
        return float(np.linalg.norm(read[:3] - point[:3]))

    assert misread(start.camera) > 0.01 and misread(start.seen_through) < 0.002
    # The object as perceived lies where it truly is, within the perception's own error.
    assert np.linalg.norm(np.subtract(start.perceived.centroid_xy, start.truth.centroid_xy)) < 0.004
