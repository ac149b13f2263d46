"""Clutter (the paper's future work): obstacles on the table that the sliding object must not overlap
and the arm must not hit; bad obstacles; the verifier catches an object pushed through one."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import shapely
from handmade_plan import build_grasp_plan
from typer.testing import CliRunner

from slideplan import InputError, PlannerConfig, load_object, load_scene, plan, verify
from slideplan.cli import app


TABLE = """[table]
polygon = [[0.30, -0.20], [0.70, -0.20], [0.70, 0.20], [0.30, 0.20]]
"""


def scene_with(tmp_path, obstacles: str):
    path = tmp_path / "scene.toml"
    path.write_text(TABLE + obstacles)
    return load_scene(path)


def object_overlaps_an_obstacle_along_the_slide(result) -> bool:
    """Independent of the planner and the verifier: the object's points at every waypoint by Eq. 2."""
    from slideplan.transforms import row_to_pose
    from slideplan.transforms import planar_motion
    from slideplan.checks.verify import obstacle_footprints

    footprints = obstacle_footprints(result)
    points = np.asarray(result.object["points"])[:, :2]
    first = row_to_pose(result.fingertip_poses[0])
    for row in result.fingertip_poses:
        x, y, yaw = planar_motion(first, row_to_pose(row))
        moved = points @ np.array([[np.cos(yaw), np.sin(yaw)], [-np.sin(yaw), np.cos(yaw)]]) + (x, y)
        if shapely.contains_xy(footprints, moved[:, 0], moved[:, 1]).any():
            return True
    return False


# A wall 2 cm short of the edge at y = -0.2 m, in front of a square object: the straight slide to
# that (nearest) edge would go through it.
WALL = """[[obstacles]]
center = [0.50, -0.17, 0.05]
size = [0.30, 0.02, 0.10]
"""


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_slide_goes_around_an_obstacle_or_to_another_edge(tmp_path, seed):
    scene = scene_with(tmp_path, WALL)
    obj = load_object("square", table_height=0.0, pose=(0.5, -0.09, 0.0))
    result = plan(scene, obj, PlannerConfig.for_scene(scene, seed=seed, time_limit_s=30.0))
    assert result.solved, result.stats
    verification = verify(result)
    assert verification.ok, verification.violations[:5]
    assert not object_overlaps_an_obstacle_along_the_slide(result)
    final = shapely.MultiPoint(result.moved_object_xy()).convex_hull
    assert not final.intersects(shapely.box(0.35, -0.18, 0.65, -0.16))


def test_an_object_boxed_in_on_every_side_times_out_cleanly(tmp_path):
    walls = "".join(
        f"[[obstacles]]\ncenter = [{x}, {y}, 0.04]\nsize = [{sx}, {sy}, 0.08]\n\n"
        for x, y, sx, sy in ((0.40, 0.0, 0.02, 0.26), (0.60, 0.0, 0.02, 0.26), (0.50, 0.12, 0.22, 0.02), (0.50, -0.12, 0.22, 0.02))
    )
    scene = scene_with(tmp_path, walls)
    obj = load_object("square", table_height=0.0, pose=(0.5, 0.0, 0.0))
    result = plan(scene, obj, PlannerConfig.for_scene(scene, seed=1, time_limit_s=2.0))
    assert result.status == "timeout"
    assert result.planning_time_s < 2.5
    assert result.stats["start_roots"] > 0


def test_verify_catches_an_object_pushed_through_an_obstacle():
    plan_ = copy.deepcopy(build_grasp_plan())
    assert verify(plan_).ok
    # A can on the hand-made slide's path: the object, moved by Eq. 2, passes over it.
    middle = plan_.moved_object_xy().mean(axis=0)
    plan_.obstacles = [{"shape": "cylinder", "center": np.array([middle[0] - 0.02, middle[1], 0.06]), "radius": 0.02,
                        "height": 0.12}]
    violations = verify(plan_).violations
    assert any("object points lie inside an obstacle" in violation for violation in violations), violations[:5]


@pytest.mark.parametrize(
    ("obstacle", "message"),
    [
        ('[[obstacles]]\nshape = "cylinder"\ncenter = [0.5, 0.0]\nradius = 0.03\nheight = 0.1\n',
         "obstacles[0] overlaps the object where it lies"),
        # Named: the second of two (it once said "an obstacle").
        ('[[obstacles]]\nshape = "cylinder"\ncenter = [0.65, 0.15]\nradius = 0.02\nheight = 0.1\n'
         '[[obstacles]]\nshape = "cylinder"\ncenter = [0.5, 0.0]\nradius = 0.03\nheight = 0.1\n',
         "obstacles[1] overlaps the object where it lies"),
        ('[[obstacles]]\nshape = "cylinder"\ncenter = [0.9, 0.0]\nradius = 0.03\nheight = 0.1\n', "off the table"),
        ("[[obstacles]]\ncenter = [0.5, 0.15, 0.0]\nsize = [0.05, 0.05, 0.05]\n", "reaches into the table top"),
        ('[[obstacles]]\nshape = "sphere"\n', "unknown shape 'sphere'"),
        ('[[obstacles]]\nshape = "cylinder"\ncenter = [0.5, 0.15]\nradius = 0.03\nheight = 0.1\nsize = [1, 1, 1]\n',
         "obstacles[0].size"),
    ],
)
def test_bad_obstacles_are_named_errors(tmp_path, obstacle, message):
    path = tmp_path / "scene.toml"
    path.write_text(TABLE + obstacle)
    with pytest.raises(InputError, match=message.replace("[", r"\[").replace("]", r"\]").replace(".", r"\.")):
        scene = load_scene(path)
        obj = load_object("square", table_height=0.0, pose=(0.5, 0.0, 0.0))
        plan(scene, obj, PlannerConfig.for_scene(scene, seed=1, time_limit_s=1.0))


@pytest.mark.parametrize("scene_name", ["clutter_can", "clutter_books", "clutter_boxed"])
def test_cluttered_scenes_plan_around_their_clutter(scene_name, tmp_path):
    result = CliRunner().invoke(app, ["plan", "--scene", scene_name, "--object", "crescent", "--seed", "2", "--time-limit",
                                      "30", "--json", str(tmp_path / "plan.json"), "--png", str(tmp_path / "plan.png")])
    assert result.exit_code == 0, result.output + result.stderr
    assert (tmp_path / "plan.png").stat().st_size > 10_000
    from slideplan import PlanResult

    planned = PlanResult.from_json((tmp_path / "plan.json").read_text())
    assert len(planned.obstacles) == len(load_scene(scene_name).obstacles) > 0
    assert not object_overlaps_an_obstacle_along_the_slide(planned)
