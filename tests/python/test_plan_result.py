"""PlanResult JSON (slideplan.plan/2), PlannerConfig checks, and the pose/quaternion helpers."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from slideplan.errors import InputError
from slideplan.plan.config import PlannerConfig
from slideplan.plan.schema import PLAN_SCHEMA
from slideplan.plan.robot import base_pose_matrix
from slideplan.plan.result import PlanResult
from slideplan.world.scenes import load_scene
from slideplan.transforms import (matrix_from_quaternion, pose_to_row, quaternion_from_matrix, rotation_from_rpy, rotation_vector,
                                  row_to_pose)

DOF = 7


def _unit_quaternions(rows):
    """Pose rows (x, y, z, qx, qy, qz, qw) with their quaternions scaled to unit norm."""
    rows[:, 3:] /= np.linalg.norm(rows[:, 3:], axis=1, keepdims=True)
    return rows


def make_plan(status="solved", waypoints=5, approach=3):
    """A hand-made plan with arbitrary (not physically valid) numbers in every field."""
    rng = np.random.default_rng(7)
    empty = status != "solved"
    waypoints, approach = (0, 0) if empty else (waypoints, approach)
    trajectory = rng.uniform(-1, 1, (waypoints, DOF))
    return PlanResult(
        status=status,
        planner="slideplan",
        seed=3,
        planning_time_s=0.123456789,
        params={key: value for key, value in PlannerConfig().resolved().to_dict().items() if key not in ("planner", "seed")},
        table={"polygon": np.array([[0.35, -0.25], [0.85, -0.25], [0.85, 0.25], [0.35, 0.25]]), "height": 0.0},
        object={"name": "x", "thickness": 0.004, "points": rng.uniform(0, 1, (10, 3)), "com_xy": np.array([0.5, 0.1])},
        robot={
            "urdf": "/some/robot.urdf",
            "attach": ["/some/finger.urdf"],
            "base_pose": base_pose_matrix([0, 0, 0.3, 0.1, 0.2, 0.3]),
            "base_link": "",
            "fixed_joints": {"finger": 0.01},
            "package_dirs": ["/some/share"],
            "tip_link": "fingertip_contact",
            "tip_offset": base_pose_matrix([0, 0, 0.01, 0, 0, 0]),
            "grasp_link": "t42_grasp",
            "grasp_offset": np.eye(4),
            "contact_links": ["a", "b"],
            "gripper_joints": {"jaw": [0.02, 0.0]},
        },
        obstacles=[{"shape": "box", "center": np.array([0.5, 0.3, 0.1]), "size": np.array([0.1, 0.1, 0.2]), "yaw": 0.4}],
        object_motion={"x": 0.1 / 3, "y": -0.2, "yaw": math.pi / 7},
        overhang_m=0.0 if empty else 0.0234,
        joint_names=[f"wam_j{index}" for index in range(1, DOF + 1)],
        start_config=np.zeros(0) if empty else trajectory[0].copy(),
        goal_config=np.zeros(0) if empty else trajectory[-1].copy(),
        trajectory=trajectory,
        fingertip_poses=_unit_quaternions(rng.uniform(-1, 1, (waypoints, 7))),
        grasp={
            "pose": np.zeros(0) if empty else _unit_quaternions(rng.uniform(-1, 1, (1, 7)))[0],
            "config": np.zeros(0) if empty else rng.uniform(-1, 1, DOF),
            "approach": rng.uniform(-1, 1, (approach, DOF)),
        },
        stats={"iterations": 10, "start_roots": 2, "goal_roots": 3, "pairs_checked": 1, "pairs_rejected": 0,
               "nodes": 40, "root_samples": 9, "precompute_time": 0.0},
    )


def assert_same_plan(first: PlanResult, second: PlanResult):
    """Field-by-field equality, arrays compared exactly and by shape."""
    assert first.to_dict() == second.to_dict()
    for name in ("start_config", "goal_config", "trajectory", "fingertip_poses"):
        a, b = getattr(first, name), getattr(second, name)
        assert isinstance(b, np.ndarray) and a.shape == b.shape and np.array_equal(a, b), name
    for group, keys in (("grasp", ("pose", "config", "approach")), ("table", ("polygon",)),
                        ("object", ("points", "com_xy")), ("robot", ("base_pose",))):
        for key in keys:
            a, b = getattr(first, group)[key], getattr(second, group)[key]
            assert isinstance(b, np.ndarray) and a.shape == b.shape and np.array_equal(a, b), f"{group}.{key}"


@pytest.mark.parametrize("status", ["solved", "timeout", "invalid"])
def test_json_round_trip_is_exact(status):
    plan = make_plan(status)
    again = PlanResult.from_json(plan.to_json(indent=2))
    assert_same_plan(plan, again)
    assert again.solved == (status == "solved")


def test_timeout_plan_keeps_array_shapes():
    again = PlanResult.from_json(make_plan("timeout").to_json())
    assert again.trajectory.shape == (0, DOF)
    assert again.fingertip_poses.shape == (0, 7)
    assert again.grasp["approach"].shape == (0, DOF)


def test_json_has_the_design_fields():
    data = json.loads(make_plan().to_json())
    assert data["schema"] == PLAN_SCHEMA == "slideplan.plan/2"
    for key in ("status", "planner", "seed", "planning_time_s", "params", "table", "object", "object_motion",
                "overhang_m", "joint_names", "start_config", "goal_config", "trajectory", "fingertip_poses",
                "grasp", "stats", "timing"):
        assert key in data, key
    assert {"beta0", "delta_beta", "dz_min", "dz_max", "n_star", "u_star", "d_goal", "time_limit_s"} <= data["params"].keys()
    assert {"polygon", "height"} <= data["table"].keys()
    assert {"thickness", "points"} <= data["object"].keys()
    assert set(data["object_motion"]) == {"x", "y", "yaw"}
    assert {"pose", "config", "approach"} <= data["grasp"].keys()
    assert {"iterations", "start_roots", "goal_roots", "pairs_checked", "pairs_rejected"} <= data["stats"].keys()
    assert all(len(row) == 7 for row in data["fingertip_poses"])


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda data: data.update(schema="slideplan.plan/0"), "schema"),
        (lambda data: data.update(status="done"), "unknown status"),
        (lambda data: data.pop("trajectory"), "missing fields"),
        (lambda data: data.update(extra=1), "unknown fields"),
        (lambda data: data.update(trajectory=[[1.0, 2.0]]), "^trajectory: expected rows of 7 numbers"),
        # Each of these once reached view or execute as a traceback or a numpy message naming nothing.
        (lambda data: data["trajectory"][0].__setitem__(1, "x"), "^trajectory: expected numbers"),
        (lambda data: data["obstacles"][0].pop("size"), r"^obstacles\[0\]: a box needs \['size'\]"),
        (lambda data: data["obstacles"][0].update(size=[0.1, -0.1, 0.2]), r"^obstacles\[0\].size: must be > 0"),
        (lambda data: data["obstacles"][0].update(shape="cone"), r"^obstacles\[0\].shape: unknown shape 'cone'"),
        (lambda data: data["object"].update(points=[]), "^object.points: expected at least 3 points"),
        (lambda data: data["object"].update(thickness=0.0), "^object.thickness: must be > 0"),
        (lambda data: data["table"].update(polygon=[]), "^table.polygon: "),
        (lambda data: data["robot"].update(tip_link=""), "^robot.tip_link: expected a name"),
    ],
)
def test_bad_plan_json_is_rejected(mutate, message):
    data = make_plan().to_dict()
    mutate(data)
    with pytest.raises(InputError, match=message):
        PlanResult.from_dict(data)


def test_quaternion_of_known_rotations():
    np.testing.assert_allclose(quaternion_from_matrix(np.eye(3)), [0, 0, 0, 1])
    half = math.sqrt(0.5)
    np.testing.assert_allclose(quaternion_from_matrix(rotation_from_rpy(0, 0, math.pi / 2)), [0, 0, half, half], atol=1e-15)
    np.testing.assert_allclose(quaternion_from_matrix(rotation_from_rpy(math.pi, 0, 0)), [1, 0, 0, 0], atol=1e-15)


def test_quaternion_round_trip_on_random_and_half_turn_rotations():
    rng = np.random.default_rng(0)
    angles = list(rng.uniform(-math.pi, math.pi, (200, 3))) + [(math.pi, 0, 0), (0, math.pi, 0), (0, 0, math.pi),
                                                                (math.pi, 0, math.pi / 2)]
    for roll, pitch, yaw in angles:
        rotation = rotation_from_rpy(roll, pitch, yaw)
        quaternion = quaternion_from_matrix(rotation)
        assert quaternion[3] >= 0 and math.isclose(np.linalg.norm(quaternion), 1.0)
        np.testing.assert_allclose(matrix_from_quaternion(quaternion), rotation, atol=1e-12)


def test_rotation_vector_matches_scipys():
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(1)
    for _ in range(500):
        axis = rng.normal(size=3)
        expected = axis / np.linalg.norm(axis) * rng.uniform(0.0, math.pi - 1e-6)
        np.testing.assert_allclose(rotation_vector(Rotation.from_rotvec(expected).as_matrix()), expected, atol=1e-9)
    np.testing.assert_allclose(rotation_vector(np.eye(3)), np.zeros(3))


def test_pose_row_round_trip():
    pose = base_pose_matrix([0.1, -0.2, 0.3, 0.4, -0.5, 2.9])
    row = pose_to_row(pose)
    assert row.shape == (7,)
    np.testing.assert_allclose(row_to_pose(row), pose, atol=1e-12)


def test_rpy_follows_urdf_convention():
    # URDF: R = Rz(yaw) Ry(pitch) Rx(roll); a pure pitch of +90 deg takes x to -z.
    np.testing.assert_allclose(rotation_from_rpy(0, math.pi / 2, 0) @ [1, 0, 0], [0, 0, -1], atol=1e-15)
    np.testing.assert_allclose(
        rotation_from_rpy(0.3, 0.2, 0.1),
        rotation_from_rpy(0, 0, 0.1) @ rotation_from_rpy(0, 0.2, 0) @ rotation_from_rpy(0.3, 0, 0),
        atol=1e-15,
    )


def test_planner_config_defaults_follow_the_paper():
    config = PlannerConfig().resolved()
    assert (config.delta_beta, config.dz_min, config.n_star, config.time_limit_s) == (0.1, 0.005, 100.0, 60.0)
    assert config.reconfiguration_range == pytest.approx(0.02)
    assert config.planner == "slideplan"


def test_reconfiguration_range_sets_dz_max():
    config = PlannerConfig().resolved().with_reconfiguration_range(0.005)
    assert config.dz_max == pytest.approx(0.01)
    assert PlannerConfig().resolved().with_reconfiguration_range(0).dz_max == config.dz_min
    with pytest.raises(InputError, match="unset"):  # an unset dz_min has no value to add the range to
        PlannerConfig().with_reconfiguration_range(0.005)


@pytest.mark.parametrize(
    "changes, field, message",
    [
        ({"time_limit_s": 0}, "time_limit_s", "must be > 0"),
        ({"time_limit_s": math.inf}, "time_limit_s", "finite"),
        ({"time_limit_s": math.nan}, "time_limit_s", "finite"),
        ({"planner": "rrt"}, "planner", "unknown planner"),
        ({"dz_min": 0.03, "dz_max": 0.02}, "dz_max", "must be >= dz_min.*dz_max = 0.02, dz_min = 0.03"),
        ({"dz_min": -0.01}, "dz_min", r"must lie in \[0, inf\) m"),
        ({"u_star": 0.0}, "u_star", r"must lie in \(0, inf\) m"),
        ({"projection_iterations": 2.5}, "projection_iterations", "integer"),
        ({"root_ik_attempts": True}, "root_ik_attempts", "integer"),
        ({"seed": -1}, "seed", "must be in"),
        ({"beta0": "1"}, "beta0", "finite number"),
    ],
)
def test_planner_config_rejects_bad_values(changes, field, message):
    with pytest.raises(InputError, match=message) as caught:
        PlannerConfig(**changes)
    assert caught.value.field == field


def test_negative_reconfiguration_range_is_rejected():
    with pytest.raises(InputError, match="reconfiguration_range"):
        PlannerConfig().resolved().with_reconfiguration_range(-0.01)


@pytest.mark.parametrize("where, field", [
    (lambda data: data["trajectory"][1].__setitem__(2, math.nan), "trajectory[1][2]"),
    (lambda data: data["grasp"]["approach"][0].__setitem__(0, math.inf), "grasp.approach[0][0]"),
    (lambda data: data.update(overhang_m=-math.inf), "overhang_m"),
    (lambda data: data["object_motion"].update(yaw=math.nan), "object_motion.yaw"),
])
def test_a_plan_file_with_a_nan_or_inf_is_refused_naming_the_file_and_field(tmp_path, where, field):
    # Once: exported with a bare NaN in the ROS JSON, and executed ("Nan, Inf or huge value in CTRL").
    data = make_plan().to_dict()
    where(data)
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(data))  # Python writes NaN and Infinity; other writers do too
    with pytest.raises(InputError, match="not a finite number") as error:
        PlanResult.load(path)
    assert error.value.field == field
    assert error.value.source == str(path)


def test_load_round_trips_and_names_an_unreadable_file(tmp_path):
    plan = make_plan()
    path = tmp_path / "plan.json"
    path.write_text(plan.to_json())
    assert_same_plan(plan, PlanResult.load(path))
    with pytest.raises(InputError, match="cannot read the plan") as error:
        PlanResult.load(tmp_path / "missing.json")
    assert error.value.source == str(tmp_path / "missing.json")


def test_a_deeply_nested_plan_is_an_input_error_not_a_recursion_error(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text('{"schema": "slideplan.plan/2", "status": "solved", "stats": ' + "[" * 100000 + "]" * 100000 + "}")
    with pytest.raises(InputError):
        PlanResult.load(path)


def test_a_plan_is_opened_from_any_directory(tmp_path, monkeypatch, planned):
    """A scene opened by a relative path records its robot file absolute (a plan once recorded it as
    typed, so view, execute and verify failed from any other directory); a plan naming its robot file
    relative to itself is read relative to itself, not to where it is opened from."""
    urdf = Path(planned.robot["urdf"])
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    (scenes / urdf.name).write_text(urdf.read_text())
    (scenes / "mine.toml").write_text(Path(load_scene("square").source).read_text())
    monkeypatch.chdir(tmp_path)
    assert load_scene("scenes/mine.toml").urdf_path == scenes / urdf.name

    data = planned.to_dict()
    data["robot"]["urdf"] = f"robot/{urdf.name}"
    (tmp_path / "plans" / "robot").mkdir(parents=True)
    (tmp_path / "plans" / "robot" / urdf.name).write_text(urdf.read_text())
    (tmp_path / "plans" / "plan.json").write_text(json.dumps(data))
    monkeypatch.chdir(scenes)
    loaded = PlanResult.load("../plans/plan.json")
    assert loaded.robot["urdf"] == str(tmp_path / "plans" / "robot" / urdf.name)
    assert list(loaded.robot_model().joint_names) == planned.joint_names


def test_a_report_refuses_nan_in_its_json_and_a_plan_writes_it():
    # One to_json for plans and reports (slideplan.jsontext.Document): only a report promises no NaN.
    from slideplan.sim.closed_loop_run import ClosedLoopRun
    from slideplan.sim.report import Execution
    from slideplan.jsontext import Document

    class Plain(Document):
        def to_dict(self):
            return {"x": float("nan"), "rows": [[1.0, 2.0]]}

    assert Plain().to_json() == '{"x": NaN, "rows": [[1.0, 2.0]]}'
    assert PlanResult.JSON_ALLOWS_NAN and not Execution.JSON_ALLOWS_NAN and not ClosedLoopRun.JSON_ALLOWS_NAN

    class Strict(Plain):
        JSON_ALLOWS_NAN = False

    with pytest.raises(ValueError):
        Strict().to_json()
    assert Strict().to_json.__func__ is Execution.to_json is ClosedLoopRun.to_json is PlanResult.to_json
