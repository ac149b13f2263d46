"""Perception on clouds rendered by MuJoCo (slideplan.sim.rendering): accuracy against the ground truth,
a plan from the perceived scene checked against the true geometry, and bad input."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import Point
from typer.testing import CliRunner

from slideplan import InputError, load_scene, perceive
from slideplan.cli import app
from slideplan.world.objects import ThinObject, load_object, load_outline
from slideplan.perception.registration import register_outline
from slideplan.perception.files import write_perception
from slideplan.plan.config import PlannerConfig
from slideplan.plan.result import PlanResult
from slideplan.sim.rendering import Box, place_objects, render_scene
from slideplan.world.geometry import overhang
from slideplan.checks.verify import verify

runner = CliRunner()

# Objects without rotational symmetry, so their yaw is defined; the box is clutter on the table.
SQUARE_OBJECTS = [("L", (0.42, -0.08, 0.4)), ("crescent", (0.55, 0.09, -1.0)), ("E", (0.58, -0.10, 2.0))]
ROUND_OBJECTS = [("Y", (0.45, 0.08, 0.3)), ("crescent", (0.52, -0.08, 2.5))]
CLUTTER = [Box((0.665, 0.0, 0.03), (0.04, 0.04, 0.06), 0.5)]


def rendered(scene_name, specs, **options):
    return render_scene(load_scene(scene_name).table, place_objects(specs), **options)


@pytest.fixture(scope="module")
def square_scene():
    return rendered("square", SQUARE_OBJECTS, clutter=CLUTTER, noise_at_1m=0.002, seed=1)


@pytest.fixture(scope="module")
def round_scene():
    return rendered("round", ROUND_OBJECTS, noise_at_1m=0.003, seed=2)


def angle_difference_deg(first, second):
    return abs(math.degrees(math.remainder(first - second, 2 * math.pi)))


def assert_matches_truth(truth, perception):
    assert abs(perception.table.height - truth.table.height) < 0.002
    assert perception.table.polygon.hausdorff_distance(truth.table.polygon) < 0.01
    assert len(perception.objects) == len(truth.objects)
    for placed in truth.objects:
        center = np.array(placed.outline.centroid.coords[0])
        found = min(perception.objects, key=lambda perceived: np.linalg.norm(perceived.centroid_xy - center))
        assert np.linalg.norm(found.centroid_xy - center) < 0.005, placed.name
        # The perceived pose: where the known outline fits the perceived points best, over all yaws.
        (x, y, yaw), _ = register_outline(found.points, load_outline(placed.name)[0])
        assert np.hypot(x - placed.pose[0], y - placed.pose[1]) < 0.005, placed.name
        assert angle_difference_deg(yaw, placed.pose[2]) < 3.0, placed.name
        overlap = found.footprint.intersection(placed.outline).area / found.footprint.union(placed.outline).area
        assert overlap > 0.75, (placed.name, overlap)
        assert abs(found.thickness - placed.thickness) < 0.001, placed.name


def test_square_table_with_clutter(square_scene):
    perception = perceive(square_scene.points)
    assert_matches_truth(square_scene, perception)
    assert perception.tilt_deg < 0.5
    assert not perception.warnings
    (box,) = perception.obstacles
    truth = CLUTTER[0]
    assert np.linalg.norm(box.center[:2] - truth.center[:2]) < 0.01
    assert abs(box.size[2] - truth.size[2]) < 0.01
    np.testing.assert_allclose(sorted(box.size[:2]), truth.size[:2], atol=0.005)
    assert abs(math.remainder(box.yaw - truth.yaw, math.pi / 2)) < math.radians(5)  # a square's yaw is mod 90 deg


def test_round_table_noisier(round_scene):
    assert_matches_truth(round_scene, perceive(round_scene.points))


def test_written_files_load_as_scene_and_objects(tmp_path, square_scene):
    perception = perceive(square_scene.points)
    scene_path, cloud_paths = write_perception(perception, tmp_path, cloud_suffix=".npy")
    scene = load_scene(scene_path)
    assert scene.table.height == pytest.approx(perception.table.height, abs=1e-6)
    np.testing.assert_allclose(scene.table.vertices, perception.table.vertices, atol=1e-6)
    assert len(scene.obstacles) == 1
    assert scene.urdf_path == load_scene("square").urdf_path
    assert 'urdf = "wam_t42.urdf"' in scene_path.read_text()  # bundled: by name, so the file can move
    for perceived, path in zip(perception.objects, cloud_paths):
        obj = load_object(str(path), table_height=scene.table.height)
        assert obj.thickness == pytest.approx(perceived.thickness, abs=1e-6)
        assert len(obj.points) == len(perceived.points)


def true_geometry_plan(result, truth, placed):
    """The plan with the table and the object replaced by the ground truth (overhang recomputed)."""
    true_object = ThinObject.from_outline(
        placed.outline, thickness=placed.thickness, table_height=truth.table.height, pose=(0, 0, 0)
    )
    table = {"polygon": truth.table.vertices, "height": truth.table.height}
    obj = {**result.object, "thickness": placed.thickness, "points": true_object.points,
           "com_xy": true_object.centroid_xy}
    # The plan's u* and grasp standoff were raised by the perception's edge uncertainty; on the true
    # geometry it owes the hand's own.
    hand = PlannerConfig.for_scene(load_scene("square"))
    params = {**result.params, "u_star": hand.u_star, "grasp_standoff": hand.grasp_standoff}
    swapped = dataclasses.replace(result, table=table, object=obj, params=params)
    return dataclasses.replace(swapped, overhang_m=overhang(truth.table, swapped.moved_object_xy())[0])


def test_perceive_and_plan_passes_verification_against_the_truth(tmp_path, square_scene):
    cloud = tmp_path / "scene.npy"
    np.save(cloud, square_scene.points)
    plan_json = tmp_path / "plan.json"
    result = runner.invoke(app, ["perceive", str(cloud), "--out", str(tmp_path / "out"), "--plan-target", "0",
                                 "--time-limit", "30", "--json", str(plan_json)])
    assert result.exit_code == 0, (result.output, result.stderr)
    plan = PlanResult.from_json(plan_json.read_text())
    hand = PlannerConfig.for_scene(load_scene("square"))
    margin = perceive(square_scene.points).edge_uncertainty
    assert plan.params["grasp_standoff"] == pytest.approx(hand.grasp_standoff + margin)
    assert plan.params["u_star"] == pytest.approx(hand.u_star + margin)
    target = perceive(square_scene.points).objects[0]
    placed = min(square_scene.objects, key=lambda item: np.linalg.norm(np.array(item.outline.centroid.coords[0]) - target.centroid_xy))
    # H_g of the true object lies where the perceived one's does only within the perception's error: the
    # edge uncertainty (which also raised the planned standoff) and the outline's.
    verification = verify(true_geometry_plan(plan, square_scene, placed), grasp_tolerance=(0.01, 0.01))
    assert verification.ok, str(verification)
    # verify() does not ask whether the fingertip touches the object; the object moves rigidly
    # with the fingertip, so it is enough that the first contact lies on the true object.
    assert placed.outline.contains(Point(plan.fingertip_poses[0][:2]))


def test_touching_objects_are_one_cluster_with_a_warning(tmp_path):
    # A thin L lying against a thicker crescent: one cluster, with parts at two heights.
    truth = rendered("square", [("L", (0.47, 0.0, 0.0), 0.004), ("crescent", (0.53, 0.005, 0.0), 0.010)], seed=3)
    perception = perceive(truth.points)
    assert len(perception.objects) == 1
    assert len(perception.warnings) == 1 and "touching objects" in perception.warnings[0]
    cloud = tmp_path / "touching.npy"
    np.save(cloud, truth.points)
    result = runner.invoke(app, ["perceive", str(cloud), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0
    assert result.stderr.startswith("slideplan: warning: object 0 has parts at different heights")
    assert (tmp_path / "out" / "object_0.ply").is_file() and not (tmp_path / "out" / "object_1.ply").exists()
    result = runner.invoke(app, ["perceive", str(cloud), "--out", str(tmp_path / "out"), "--plan-target", "1"])
    assert result.exit_code == 2 and "--plan-target: no object 1: the perceived objects are 0 to 0" in result.stderr


def tilted(points, degrees, about=(0.5, 0.0, 0.0)):
    angle = math.radians(degrees)
    rotation = np.array([[1, 0, 0], [0, math.cos(angle), -math.sin(angle)], [0, math.sin(angle), math.cos(angle)]])
    return (points - about) @ rotation.T + about


def test_tilted_table_names_the_angle(square_scene):
    with pytest.raises(InputError, match=r"tilted 10\.0 deg"):
        perceive(tilted(square_scene.points, 10.0))


def test_camera_frame_cloud_is_refused(square_scene):
    camera = square_scene.camera
    camera_frame = (square_scene.points - camera.position) @ camera.axes()  # world -> camera coordinates
    with pytest.raises(InputError, match="camera frame"):
        perceive(camera_frame)


def test_no_object_on_the_table():
    truth = rendered("square", [])
    with pytest.raises(InputError, match="no object on the table"):
        perceive(truth.points)


def test_no_plane_at_all():
    blob = np.random.default_rng(0).uniform(-0.5, 0.5, size=(30000, 3))
    with pytest.raises(InputError, match="no plane"):
        perceive(blob)


@pytest.mark.parametrize("points, problem", [(np.empty((0, 3)), "empty"), (np.array([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]]), "NaN")])
def test_empty_or_nan_cloud(points, problem):
    with pytest.raises(InputError, match=problem):
        perceive(points)


@pytest.mark.parametrize("setting, value", [("cell_size", -0.005), ("min_height", float("nan")), ("max_thickness", 0.001)])
def test_bad_settings(square_scene, setting, value):
    with pytest.raises(InputError, match=setting):
        perceive(square_scene.points, **{setting: value})


def test_slightly_tilted_table_is_accepted_and_measured(square_scene):
    perception = perceive(tilted(square_scene.points, 2.0))
    assert perception.tilt_deg == pytest.approx(2.0, abs=0.2)
    assert len(perception.objects) == len(square_scene.objects)


def test_cli_bad_cloud_is_one_error_line(tmp_path, square_scene):
    cloud = tmp_path / "tilted.npy"
    np.save(cloud, tilted(square_scene.points, 20.0))
    result = runner.invoke(app, ["perceive", str(cloud), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("slideplan: error: ") and "tilted 20.0 deg" in lines[0]
    assert str(cloud) in lines[0]


def test_the_docs_test_scene_example_runs_and_perceive_plans_from_its_cloud(tmp_path, monkeypatch, capsys):
    # docs/perception.md's example is the one place a user learns to make a test cloud: keep it true.
    text = (Path(__file__).resolve().parents[2] / "docs/perception.md").read_text()
    example = text.split("A test cloud for `perceive`", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    exec(compile(example, "docs/perception.md", "exec"), {})
    assert capsys.readouterr().out.strip().endswith("2 objects found")
    result = CliRunner().invoke(app, ["perceive", "scene.npy", "--out", "perceived", "--plan-target", "0",
                                      "--time-limit", "30", "--json", "plan.json"])
    assert result.exit_code == 0, result.output
    assert verify(PlanResult.load(tmp_path / "plan.json")).ok


def test_a_rerun_into_the_same_folder_leaves_no_object_of_the_earlier_run(tmp_path, square_scene):
    out = tmp_path / "out"
    write_perception(perceive(square_scene.points), out)
    assert sorted(path.name for path in out.glob("object_*")) == ["object_0.ply", "object_1.ply", "object_2.ply"]
    single = rendered("square", [("L", (0.5, 0.0, 0.4))], seed=4)
    write_perception(perceive(single.points), out)
    assert sorted(path.name for path in out.glob("object_*")) == ["object_0.ply"]


@pytest.mark.parametrize("option, value, problem", [
    ("--plan-target", "99", "no object 99: the perceived objects are 0 to 2"),
    ("--plan-target", "-1", "expected an object index >= 0"),
    ("--robot-scene", "nosuch", "nosuch"),
    ("--time-limit", "-1", "--time-limit"),
    ("--seed", "-5", "got -5"),
])
def test_cli_bad_target_or_robot_scene_is_refused_before_anything_is_written(tmp_path, square_scene, option, value, problem):
    cloud = tmp_path / "scene.npy"
    np.save(cloud, square_scene.points)
    result = runner.invoke(app, ["perceive", str(cloud), "--out", str(tmp_path / "out"), option, value])
    assert result.exit_code == 2 and option in result.stderr and problem in result.stderr, result.stderr
    assert not (tmp_path / "out").exists()


def test_a_mount_beyond_any_scene_s_bound_is_refused_before_anything_is_written(tmp_path, square_scene):
    cloud = tmp_path / "scene.npy"
    np.save(cloud, square_scene.points)
    result = runner.invoke(app, ["perceive", str(cloud), "--out", str(tmp_path / "out"), "--robot-base-pose",
                                 "1e300", "0", "0", "0", "0", "0"])
    assert result.exit_code == 2 and "--robot-base-pose" in result.stderr, result.stderr
    assert not (tmp_path / "out").exists()


def test_any_seed_a_plan_takes_perceives_the_same_table(square_scene):
    small, large = perceive(square_scene.points, seed=7), perceive(square_scene.points, seed=2**32 + 7)
    assert abs(large.table.height - small.table.height) < 0.001 and len(large.objects) == len(small.objects)
    for bad in (-5, 2**64, 1.5, True):
        with pytest.raises(InputError) as caught:
            perceive(square_scene.points, seed=bad)
        assert caught.value.field == "seed"


def test_a_cloud_in_millimetres_gets_a_hint_about_units(square_scene):
    with pytest.raises(InputError, match="millimetres"):
        perceive(square_scene.points * 1000.0)


def test_a_second_larger_empty_table_at_the_same_height_is_passed_over(square_scene):
    # A bare 1 m x 1 m table beside the 0.4 m one with the objects: one plane, two patches.
    grid = np.mgrid[1.2:2.2:0.005, -0.5:0.5:0.005].reshape(2, -1).T
    empty = np.column_stack([grid, np.full(len(grid), square_scene.table.height)])
    perception = perceive(np.vstack([square_scene.points, empty]))
    assert perception.table.polygon.hausdorff_distance(square_scene.table.polygon) < 0.01
    assert len(perception.objects) == len(square_scene.objects)
    assert any("passed over" in warning for warning in perception.warnings)


@pytest.mark.parametrize("seed", range(6))
def test_flying_pixels_make_no_phantom_object_and_no_stray_points(seed):
    # A synthetic cloud (uniform table points, a 4 mm square plate) with 1% points uniform in the
    # box around it: before, seed 2 gave a phantom 0.2 mm "object" and seed 5 kept 3.7% strays.
    rng = np.random.default_rng(seed)
    xy = rng.uniform([0.3, -0.2], [0.7, 0.2], size=(40_000, 2))
    plate = shapely.box(0.45, -0.04, 0.53, 0.04)
    z = np.where(shapely.contains_xy(plate, *xy.T), 0.004, 0.0) + rng.normal(0.0, 0.0005, len(xy))
    outliers = rng.uniform([0.3, -0.2, -0.02], [0.7, 0.2, 0.1], size=(400, 3))
    perception = perceive(np.vstack([np.column_stack([xy, z]), outliers]), seed=seed)
    (found,) = perception.objects
    assert abs(found.thickness - 0.004) < 0.0005
    strays = shapely.distance(plate, shapely.points(found.points[:, :2])) > 0.005
    assert strays.mean() < 0.005


def test_a_table_plane_too_large_to_grid_is_refused_before_allocating():
    # Three stray points 100 km away on the table's plane asked for a 20 GB grid (MemoryError).
    rng = np.random.default_rng(0)
    xy = rng.uniform([0.3, -0.2], [0.7, 0.2], size=(40_000, 2))
    z = np.where(shapely.contains_xy(shapely.box(0.45, -0.04, 0.53, 0.04), *xy.T), 0.004, 0.0)
    far = np.array([[1e5, 0.0, 0.0], [1e5, 1e5, 0.0], [0.0, 1e5, 0.0]])
    with pytest.raises(InputError, match=r"span 1e\+05 x .* grid cells .* is the cloud in millimetres"):
        perceive(np.vstack([np.column_stack([xy, z]), far]))


def _plate_on_a_table(height: float) -> np.ndarray:
    """A synthetic scene cloud: the square table at ``height``, a 4 mm plate on it."""
    rng = np.random.default_rng(0)
    xy = rng.uniform([0.3, -0.2], [0.7, 0.2], size=(40_000, 2))
    inside = shapely.contains_xy(shapely.box(0.45, -0.04, 0.53, 0.04), *xy.T)
    return np.column_stack([xy, height + np.where(inside, 0.004, 0.0)])


def test_the_robot_stands_as_high_above_the_perceived_table_as_in_its_scene(tmp_path):
    # A cloud with the floor at z = 0 and the table at 0.72 m once got the WAM at z = 0.2, under the table.
    perception = perceive(_plate_on_a_table(0.72))
    scene_path, _ = write_perception(perception, tmp_path / "out", robot_scene="square")
    scene = load_scene(scene_path)
    assert scene.base_pose[2] - scene.table.height == pytest.approx(load_scene("square").base_pose[2], abs=1e-3)
    given = (0.1, 0.2, 0.5, 0.0, 0.0, 1.0)
    scene_path, _ = write_perception(perception, tmp_path / "given", robot_scene="square", base_pose=given)
    assert load_scene(scene_path).base_pose == pytest.approx(given, abs=1e-9)


def test_a_written_scene_opens_from_another_folder_and_names_no_machine_path(tmp_path):
    """Robot files by package:// as the robot scene named them, bundled ones by name, the scene's own
    files relative to the written scene; no package_dirs of this machine (it once wrote absolute paths
    and every site-packages directory)."""
    perception = perceive(_plate_on_a_table(0.0))
    text = Path(write_perception(perception, tmp_path / "ur5", robot_scene="ur5_square")[0]).read_text()
    assert 'urdf = "package://example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"' in text
    assert 'attach = ["ur5_finger.urdf"]' in text and "package_dirs" not in text and str(Path.home()) not in text
    # A scene of one's own beside its URDF: the written scene names the URDF relative to itself.
    own = tmp_path / "mine"
    own.mkdir()
    (own / "arm.urdf").write_text(load_scene("square").urdf_path.read_text())
    (own / "arm.toml").write_text(Path(load_scene("square").source).read_text().replace('"wam_t42.urdf"', '"arm.urdf"'))
    scene_path, _ = write_perception(perception, tmp_path / "out", robot_scene=own / "arm.toml")
    assert 'urdf = "../mine/arm.urdf"' in scene_path.read_text()
    moved = tmp_path / "elsewhere" / "deep"
    moved.mkdir(parents=True)
    (tmp_path / "elsewhere" / "mine").mkdir()
    (tmp_path / "elsewhere" / "mine" / "arm.urdf").write_text((own / "arm.urdf").read_text())
    (moved / "scene.toml").write_text(scene_path.read_text())
    assert load_scene(moved / "scene.toml").urdf_path == tmp_path / "elsewhere" / "mine" / "arm.urdf"


def test_perceive_warns_when_the_robot_cannot_reach_the_table(tmp_path):
    # The WAM given a mount 1 m below the table top: every plan ran to its time limit, with no hint.
    cloud = tmp_path / "scene.npy"
    np.save(cloud, _plate_on_a_table(0.72))
    warned = runner.invoke(app, ["perceive", str(cloud), "--out", str(tmp_path / "low"), "--robot-base-pose",
                                 "0", "0", "-0.28", "0", "0", "0"])
    assert warned.exit_code == 0, warned.output
    assert "slideplan: warning: the fingertip reaches the table top at beta0 = 1 over only 0% of the table" in warned.stderr
    assert "--robot-base-pose" in warned.stderr
    kept = runner.invoke(app, ["perceive", str(cloud), "--out", str(tmp_path / "kept")])  # the square scene's mount, lifted
    assert kept.exit_code == 0 and "reaches the table top" not in kept.stderr, kept.stderr
