"""Bad input reaching the C++ core is a Python exception naming the problem, never a crash."""

import numpy as np
import pytest

from slideplan import InputError, PlannerConfig, _core, load_object, load_scene, plan
from slideplan.paths import data_dir

URDF = str(data_dir() / "robots" / "wam_t42.urdf")


def test_malformed_urdf_names_the_file(tmp_path):
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'>")
    with pytest.raises(ValueError, match="broken.urdf: malformed URDF"):
        _core.RobotModel(str(broken))


def test_missing_urdf_names_the_file(tmp_path):
    with pytest.raises(ValueError, match="missing.urdf: cannot open"):
        _core.RobotModel(str(tmp_path / "missing.urdf"))


def test_missing_contact_frame_is_named():
    with pytest.raises(ValueError, match=r"\[hand\] tip_link 'no_fingertip' is not a link"):
        _core.RobotModel(URDF, tip_link="no_fingertip")


def test_bad_base_pose_is_rejected():
    with pytest.raises(ValueError, match="homogeneous"):
        _core.RobotModel(URDF, base_pose=np.full((4, 4), np.nan))


def test_scene_with_a_malformed_urdf_fails_cleanly_when_planning(tmp_path):
    (tmp_path / "bad.urdf").write_text("<robot name='x'>")
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text('[table]\npolygon = [[0.3, -0.2], [0.7, -0.2], [0.7, 0.2], [0.3, 0.2]]\n'
                          '[robot]\nurdf = "bad.urdf"\nbase_pose = [0, 0, 0.2, 0, 0, 0]\n'
                          '[hand]\ntip_link = "a"\ngrasp_link = "a"\ncontact_links = ["a"]\n')
    scene = load_scene(scene_file)
    obj = load_object("square", table_height=0.0, pose=(0.5, 0.0, 0.0))
    with pytest.raises(InputError, match="bad.urdf"):
        plan(scene, obj, PlannerConfig(time_limit_s=1.0))


def test_polygon_errors_come_from_the_core_too():
    with pytest.raises(ValueError, match="self-intersecting"):
        _core.SupportSurface(np.array([[0, 0], [1, 1], [1, 0], [0, 1.0]]), 0.0)
    with pytest.raises(ValueError, match="at least 3 vertices"):
        _core.SupportSurface(np.array([[0, 0], [1, 1.0]]), 0.0)


def test_unknown_contact_link_is_named():
    robot = _core.RobotModel(URDF)
    table = _core.SupportSurface(np.array([[0.3, -0.2], [0.7, -0.2], [0.7, 0.2], [0.3, 0.2]]), 0.0)
    with pytest.raises(ValueError, match="contact link 'pinky'"):
        _core.CollisionWorld(robot, table, contact_links=["pinky"])


@pytest.mark.parametrize(
    ("points", "message"),
    [
        (np.empty((0, 3)), "at least 3 points"),
        (np.array([[0.5, 0.0, 0.004], [0.51, 0.0, np.nan], [0.5, 0.01, 0.004]]), "NaN or infinite"),
        (np.array([[0.5, 0.0, 0.004], [0.51, 0.0, np.inf], [0.5, 0.01, 0.004]]), "NaN or infinite"),
        (np.array([[0.5, 0.0, -0.01], [0.51, 0.0, -0.01], [0.5, 0.01, -0.01]]), "below the table top"),
        (np.array([[0.9, 0.0, 0.004], [0.91, 0.0, 0.004], [0.9, 0.01, 0.004]]), "not on the table"),
    ],
)
def test_bad_clouds_reaching_the_planner_raise(points, message):
    robot = _core.RobotModel(URDF)
    table = _core.SupportSurface(np.array([[0.3, -0.2], [0.7, -0.2], [0.7, 0.2], [0.3, 0.2]]), 0.0)
    com = np.nan_to_num(points[:, :2].mean(axis=0)) if len(points) else np.zeros(2)
    with pytest.raises(ValueError, match=message):
        _core.plan_sliding(robot, table, [], [], points, com, _core.PlannerParams(), 0, 1.0, "t42_grasp")


@pytest.mark.parametrize("time_limit", [0.0, -1.0, float("nan")])
def test_non_positive_time_limit_is_rejected_by_the_core(time_limit):
    robot = _core.RobotModel(URDF)
    table = _core.SupportSurface(np.array([[0.3, -0.2], [0.7, -0.2], [0.7, 0.2], [0.3, 0.2]]), 0.0)
    points = np.array([[0.5, 0.0, 0.004], [0.51, 0.0, 0.004], [0.5, 0.01, 0.004]])
    with pytest.raises(ValueError, match="time limit"):
        _core.plan_sliding(robot, table, [], [], points, points[:, :2].mean(axis=0), _core.PlannerParams(), 0, time_limit, "t42_grasp")


def test_unreachable_ik_target_returns_none():
    robot = _core.RobotModel(URDF)
    far = np.eye(4)
    far[:3, 3] = (3.0, 0.0, 0.0)
    assert robot.ik(far, rng_seed=1) is None
