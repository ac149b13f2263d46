"""Tracking the object in rendered depth frames (slideplan.perception.tracking)."""

import math

import numpy as np
import pytest

from slideplan import InputError, load_object, load_scene
from slideplan.perception.camera import Camera
from slideplan.sim.rendering import Box, depth_image, noisy_depth, place_objects, scene_spec
from slideplan.perception.tracking import Tracker
from slideplan.transforms import wrap_angle


@pytest.fixture(scope="module")
def square():
    table = load_scene("square").table
    centre = table.polygon.centroid
    return table, Camera((centre.x - 0.15, centre.y, table.height + 0.75), (centre.x, centre.y, table.height))


def frame(table, camera, name, pose, hand, rng):
    """A noisy depth frame of one object at `pose` with a box (`hand`) above part of it."""
    spec = scene_spec(table, place_objects([(name, pose)]), hand, camera)
    return noisy_depth(depth_image(spec, camera), 0.002, 0.05, rng)


def pose_error(tracker, estimate, truth, turn):
    """Distance between the estimated and the true centre of mass (m), and between the estimated and
    the true turn (rad)."""
    moved = tracker.obj.moved(estimate.motion)
    return float(np.linalg.norm(moved.centroid_xy - truth.centroid_xy)), abs(wrap_angle(estimate.motion[2] - turn))


@pytest.mark.parametrize("name", ["crescent", "L", "irregular"])
def test_a_moved_object_is_found_within_2_mm_and_1_degree_median_with_the_hand_over_it(square, name):
    table, camera = square
    rng = np.random.default_rng(7)
    errors = []
    for _ in range(5):
        # Where the tracker last saw it, and where it is now: up to 3 cm and 10 degrees away (a disturbance).
        last = (rng.uniform(0.5, 0.6), rng.uniform(-0.1, 0.1), rng.uniform(-math.pi, math.pi))
        step = (rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03), rng.uniform(-0.17, 0.17))
        now = tuple(a + b for a, b in zip(last, step))
        hand = [Box((now[0] + 0.02, now[1], table.height + 0.06), (0.05, 0.04, 0.03))]  # hides about a third
        reference = load_object(name, table_height=table.height, pose=last)
        truth = load_object(name, table_height=table.height, pose=now)
        tracker = Tracker(reference, camera, table_height=table.height)
        estimate = tracker.track(frame(table, camera, name, now, hand, rng))
        assert estimate.ok, estimate.reason
        errors.append(pose_error(tracker, estimate, truth, step[2]))
    errors = np.array(errors)
    # The target (median 2 mm / 1 degree), and no frame far off it; the crescent's near-circular
    # outer arc leaves its turn the least certain.
    assert np.median(errors[:, 0]) <= 0.002 and errors[:, 0].max() <= 0.003, errors
    assert np.degrees(np.median(errors[:, 1])) <= 1.0 and np.degrees(errors[:, 1]).max() <= 2.0, np.degrees(errors[:, 1])


def test_an_object_hidden_under_the_hand_is_reported_lost_not_guessed(square):
    table, camera = square
    pose = (0.55, 0.0, 0.3)
    hand = [Box((0.55, 0.0, table.height + 0.05), (0.2, 0.2, 0.03))]
    tracker = Tracker(load_object("L", table_height=table.height, pose=pose), camera, table_height=table.height)
    estimate = tracker.track(frame(table, camera, "L", pose, hand, np.random.default_rng(1)))
    assert not estimate.ok
    assert "edge points" in estimate.reason
    assert estimate.motion == (0.0, 0.0, 0.0)


def test_an_object_far_from_the_guess_is_lost_by_tracking_and_found_by_locating_it_on_the_table(square):
    # 15 cm from where it was expected: beyond the tracker's window. Located over the whole table (the
    # hand lifted clear above the old place), tracking from there finds it within the 2 mm.
    table, camera = square
    expected, now = (0.55, 0.0, 0.3), (0.5, -0.14, 0.3)
    hand = [Box((0.55, 0.0, table.height + 0.12), (0.05, 0.04, 0.03))]
    tracker = Tracker(load_object("L", table_height=table.height, pose=expected), camera, table_height=table.height)
    truth = load_object("L", table_height=table.height, pose=now)
    depth = frame(table, camera, "L", now, hand, np.random.default_rng(3))
    assert not tracker.track(depth, (0.0, 0.0, 0.0)).ok
    found = tracker.locate(depth, (0.0, 0.0, 0.0), table.polygon)
    assert found is not None and abs(found[2]) == 0.0
    assert np.linalg.norm(tracker.obj.moved(found).centroid_xy - truth.centroid_xy) < 0.02  # a start, not a fit
    estimate = tracker.track(depth, found)
    assert estimate.ok, estimate.reason
    assert pose_error(tracker, estimate, truth, 0.0)[0] <= 0.002
    # An empty table: nothing to locate.
    empty = noisy_depth(depth_image(scene_spec(table, [], hand, camera), camera), 0.002, 0.05, np.random.default_rng(3))
    assert tracker.locate(empty, (0.0, 0.0, 0.0), table.polygon) is None


def test_a_depth_image_of_another_size_is_an_input_error(square):
    table, camera = square
    tracker = Tracker(load_object("L", table_height=table.height, pose=(0.55, 0.0, 0.0)), camera, table_height=table.height)
    with pytest.raises(InputError, match="depth"):
        tracker.track(np.zeros((10, 10)))


@pytest.mark.parametrize("arguments, field", [
    ({"hand_clearance": 0.0}, "hand_clearance"), ({"window_margin": "wide"}, "window_margin"),
    ({"iterations": 2.5}, "iterations"), ({"table_height": None}, "table_height"),
])
def test_bad_tracker_settings_name_the_field(square, arguments, field):
    table, camera = square
    obj = load_object("L", table_height=table.height, pose=(0.55, 0.0, 0.0))
    with pytest.raises(InputError) as error:
        Tracker(obj, camera, **{"table_height": table.height, **arguments})
    assert error.value.field == field


def test_a_guess_that_is_not_a_pose_is_an_input_error(square):
    table, camera = square
    tracker = Tracker(load_object("L", table_height=table.height, pose=(0.55, 0.0, 0.0)), camera, table_height=table.height)
    with pytest.raises(InputError) as error:
        tracker.track(np.zeros((camera.height, camera.width)), guess=(0.0, 0.0))
    assert error.value.field == "guess"


def test_a_fit_must_put_the_object_under_the_fingertip(square):
    # The finger presses on the object: a contact point far off the object rules every fit out, one on it
    # changes nothing.
    table, camera = square
    pose = (0.55, 0.0, 0.3)
    obj = load_object("L", table_height=table.height, pose=pose)
    depth = frame(table, camera, "L", pose, [], np.random.default_rng(3))
    tracker = Tracker(obj, camera, table_height=table.height)
    free = tracker.track(depth)
    assert free.ok, free.reason
    on = tracker.track(depth, contact=obj.points[0, :2])
    assert on.ok and np.allclose(on.motion, free.motion)
    off = tracker.track(depth, contact=obj.centroid_xy + (0.2, 0.0))
    assert not off.ok and "fingertip" in off.reason
    # Inside the L's convex hull but in its corner, off its material: the finger would press on the table.
    import shapely

    hull = obj.outline.convex_hull
    grid = np.stack(np.meshgrid(*(np.linspace(low, high, 60) for low, high in zip(hull.bounds[:2], hull.bounds[2:]))), -1).reshape(-1, 2)
    grid = grid[shapely.contains_xy(hull.buffer(-0.002), grid[:, 0], grid[:, 1])]
    corner = grid[np.argmax(shapely.distance(obj.outline, shapely.points(grid)))]
    assert obj.outline.distance(shapely.Point(corner)) > 0.01
    bite = tracker.track(depth, contact=corner)
    assert not bite.ok and "fingertip" in bite.reason


def test_a_straight_edge_alone_does_not_fix_the_pose(square):
    # A 40 cm strip with both ends under the hand: its two long edges let the outline slide along them,
    # so no fit says where it is; with the ends in view the same strip is found.
    from shapely.geometry import box as rectangle

    from slideplan.world.objects import ThinObject
    from slideplan.sim.rendering import PlacedObject

    table, camera = square
    strip = ThinObject.from_outline(rectangle(-0.2, -0.03, 0.2, 0.03), thickness=0.004, table_height=table.height,
                                    pose=(0.5, 0.0, 0.0))
    placed = [PlacedObject("strip", (0.5, 0.0, 0.0), 0.004, strip.outline)]
    hands = [Box((x, 0.0, table.height + 0.04), (0.14, 0.2, 0.04)) for x in (0.35, 0.65)]  # above the strip's ends
    tracker = Tracker(strip, camera, table_height=table.height)
    rng = np.random.default_rng(1)
    hidden = noisy_depth(depth_image(scene_spec(table, placed, hands, camera), camera), 0.002, 0.05, rng)
    slid = tracker.track(hidden, guess=(0.02, 0.0, 0.0))
    assert not slid.ok and "does not fix the pose" in slid.reason
    whole = tracker.track(noisy_depth(depth_image(scene_spec(table, placed, [], camera), camera), 0.002, 0.05, rng))
    assert whole.ok, whole.reason
    assert np.hypot(*whole.motion[:2]) < 0.002


def test_a_fit_where_the_frame_shows_the_table_is_refused(square):
    # A ring of low bars (the hand's edges at the object's height) traces the square's outline, with the
    # table seen inside it: the outline fits its edges, but the frame shows no object there. The square
    # itself at the same place is found.
    table, camera = square
    x, z = 0.55, table.height + 0.007
    ring = [Box((x - 0.045, 0.0, z), (0.01, 0.1, 0.006)), Box((x + 0.045, 0.0, z), (0.01, 0.1, 0.006)),
            Box((x, -0.045, z), (0.1, 0.01, 0.006)), Box((x, 0.045, z), (0.1, 0.01, 0.006))]
    tracker = Tracker(load_object("square", table_height=table.height, pose=(x, 0.0, 0.0)), camera, table_height=table.height)
    rng = np.random.default_rng(1)
    traced = tracker.track(noisy_depth(depth_image(scene_spec(table, [], ring, camera), camera), 0.002, 0.05, rng))
    assert not traced.ok and "does not show the object" in traced.reason
    real = tracker.track(frame(table, camera, "square", (x, 0.0, 0.0), [], rng))
    assert real.ok, real.reason


def test_the_icp_core_matches_the_numpy_reference_on_a_rendered_frame(square):
    from icp_reference import icp_reference

    from slideplan.perception.tracking import GRID_CELL_M, INLIER_M, _nearest_grid

    table, camera = square
    rng = np.random.default_rng(11)
    now = (0.56, 0.02, 0.9)
    hand = [Box((now[0] + 0.02, now[1], table.height + 0.06), (0.05, 0.04, 0.03))]
    tracker = Tracker(load_object("E", table_height=table.height, pose=(0.55, 0.0, 0.8)), camera, table_height=table.height)
    guess = (0.0, 0.0, 0.0)
    points, _, _ = tracker.classify(frame(table, camera, "E", now, hand, rng), guess)
    assert len(points) > 100
    grid, low = _nearest_grid(tracker._model, tracker.window_margin)
    starts = [np.array(guess) + offset for offset in ([0, 0, 0], [0.01, -0.01, 0.12], [-0.02, 0.0, -0.12])]
    for exact, iterations in ((True, 40), (False, 8)):
        fits = tracker._icp(points, starts, iterations, exact)
        reference = icp_reference(tracker._model, grid, low, GRID_CELL_M, INLIER_M, points, starts, iterations, exact, tracker._radius)
        for (motion, inliers, rmse), (motion_ref, inliers_ref, rmse_ref) in zip(fits, reference, strict=True):
            np.testing.assert_allclose(motion, motion_ref, atol=1e-9)
            assert inliers == inliers_ref and rmse == pytest.approx(rmse_ref, abs=1e-12)


def test_a_camera_mounted_millimetres_off_still_tracks_with_the_table_plane_it_sees(square):
    # The hard setting's camera: mounted 4 mm low and turned half a degree from where it is believed to
    # be. The table it sees lies millimetres off the scene's height, as high as the object is thick: against
    # the level table no pixel is table or object; against the plane perception fits in the same frames,
    # the object is where the frames show it.
    from slideplan.perception.camera import back_project
    from slideplan.sim.conditions import camera_as_mounted
    from slideplan.perception.tabletop import perceive

    table, believed = square
    draws = {"camera_dx_m": 0.002, "camera_dy_m": -0.003, "camera_dz_m": -0.004,
             "camera_rx_deg": 0.5, "camera_ry_deg": -0.3, "camera_rz_deg": 0.2}
    mounted = camera_as_mounted(believed, draws)
    rng = np.random.default_rng(11)
    start = (0.55, 0.0, 0.4)
    first = noisy_depth(depth_image(scene_spec(table, place_objects([("crescent", start)]), [], mounted), mounted),
                        0.002, 0.05, rng)
    plane = perceive(back_project(first, believed), seed=1).plane
    reference = load_object("crescent", table_height=table.height, pose=start)
    level = Tracker(reference, believed, table_height=table.height)
    seen = Tracker(reference, believed, table_height=table.height, table_plane=plane)
    found = {"level": 0, "plane": 0}
    for step in range(4):
        now = (0.55 + 0.01 * step, 0.005 * step, 0.4 + 0.02 * step)
        depth = noisy_depth(depth_image(scene_spec(table, place_objects([("crescent", now)]), [], mounted), mounted),
                            0.002, 0.05, rng)
        turn = now[2] - start[2]  # the motion taking the object at start to now: R(turn) p + shift
        shift = np.subtract(now[:2], [[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]] @ np.array(start[:2]))
        guess = (float(shift[0]), float(shift[1]), turn)
        found["level"] += level.track(depth, guess).ok
        estimate = seen.track(depth, guess)
        found["plane"] += estimate.ok
        assert np.hypot(*np.subtract(estimate.motion[:2], guess[:2])) < 0.02  # the camera's error, not more
    assert found == {"level": 0, "plane": 4}, found
