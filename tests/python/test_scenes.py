"""Scene files: the built-in scenes and error messages for bad files."""

import math
from pathlib import Path

import numpy as np
import pytest

from slideplan.errors import InputError
from slideplan.paths import builtin_scenes, data_dir
from slideplan.world.scenes import Scene, load_scene

TABLE_AREAS = {
    "square": 0.4 * 0.4,
    "long": 0.25 * 0.8,
    "triangle": 0.5 * 0.5 * 0.45,
    "round": 0.5 * 100 * 0.22**2 * math.sin(2 * math.pi / 100),
}


ROBOT_SCENES = ["panda_square", "panda_round", "ur5_square", "ur5_round", "ur5_gripper_square", "xarm7_square", "kinova_square",
               "z1_square", "so101_square",  # third-party arms (test_robots.py)
                "clutter_can", "clutter_books", "clutter_boxed"]  # and clutter (test_clutter.py)


def test_builtin_scene_list_is_complete():
    assert sorted(builtin_scenes()) == sorted([*TABLE_AREAS, *ROBOT_SCENES])


@pytest.mark.parametrize("name", sorted(TABLE_AREAS))
def test_builtin_scene_loads_with_defaults(name):
    scene = load_scene(name)
    assert scene.name == name
    assert scene.table.area == pytest.approx(TABLE_AREAS[name])
    assert scene.table.height == 0.0
    np.testing.assert_array_equal(scene.base_pose, [0.0, 0.0, 0.20, 0.0, 0.0, 0.0])
    assert scene.urdf_path == data_dir() / "robots" / "wam_t42.urdf"
    assert scene.tip_link == "fingertip_contact"
    assert scene.contact_links == ("t42_finger1_proximal", "t42_finger1_distal")
    assert scene.obstacles == ()
    assert scene.source.endswith(f"{name}.toml")


def test_round_scene_has_100_edge_points():
    assert load_scene("round").table.vertices.shape == (100, 2)


def test_default_scene_is_square():
    assert Scene.default().name == "square"


def test_full_scene_file(tmp_path):
    (tmp_path / "arm.urdf").write_text("<robot name='arm'/>")
    path = tmp_path / "lab.toml"
    path.write_text(
        """
[table]
polygon = [[0.4, 0.3], [0.4, -0.3], [0.9, -0.3], [0.9, 0.3]]
height = 0.72
[robot]
urdf = "arm.urdf"
base_pose = [0.1, 0.0, 1.0, 0.0, 0.0, 1.57]
tip_link = "tip"
contact_links = ["finger"]
[hand]
grasp_link = "palm"
grasp_offset = [0.0, 0.0, 0.1, 0.0, 0.0, 0.0]
[[obstacles]]
center = [0.6, 0.2, 0.8]
size = [0.1, 0.1, 0.16]
[[obstacles]]
center = [0.6, -0.2, 0.8]
size = [0.1, 0.2, 0.16]
yaw = 0.5
"""
    )
    scene = load_scene(path)
    assert scene.name == "lab"
    assert scene.table.height == 0.72
    assert scene.table.contains(np.array([[0.65, 0.0]])).all()
    assert scene.urdf_path == tmp_path / "arm.urdf"
    np.testing.assert_array_equal(scene.base_pose, [0.1, 0.0, 1.0, 0.0, 0.0, 1.57])
    assert scene.tip_link == "tip"
    assert scene.contact_links == ("finger",)
    assert scene.hand.grasp_link == "palm"
    np.testing.assert_array_equal(scene.hand.grasp_offset, [0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    assert len(scene.obstacles) == 2
    np.testing.assert_array_equal(scene.obstacles[1].size, [0.1, 0.2, 0.16])
    assert scene.obstacles[0].yaw == 0.0
    assert scene.obstacles[1].yaw == 0.5


def test_circle_table_defaults_to_100_points(tmp_path):
    path = tmp_path / "disc.toml"
    path.write_text("[table]\ncircle = { center = [0.6, 0.0], radius = 0.3 }\n")
    assert load_scene(path).table.vertices.shape == (100, 2)


@pytest.mark.parametrize(
    ("text", "field", "problem"),
    [
        ("[robot]\nbase_pose = [0, 0, 0, 0, 0, 0]\n", "table", "missing required field"),
        ('[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\nheight = "zero"\n', "table.height", "expected a number"),
        ("[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\nheight = true\n", "table.height", "expected a number"),
        ("[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\nheigth = 0.1\n", "table.heigth", "unknown field"),
        ("[table]\nheight = 0.0\n", "table", "exactly one of"),
        (
            "[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\ncircle = { center = [0, 0], radius = 1 }\n",
            "table",
            "exactly one of",
        ),
        ("[table]\npolygon = [[0, 0], [1, 1], [1, 0], [0, 1]]\n", "table.polygon", "polygon is self-intersecting"),
        ("[table]\npolygon = [[0, 0], [1, 0]]\n", "table.polygon", "at least 3 vertices"),
        ("[table]\npolygon = [[0, 0], [1, 0], [0, nan]]\n", "table.polygon[2]", "finite"),
        ("[table]\ncircle = { center = [0, 0], radius = -1 }\n", "table.circle.radius", "> 0"),
        ("[table]\ncircle = { center = [0, 0], radius = 1, points = 2 }\n", "table.circle.points", ">= 3"),
        ("[table]\ncircle = { radius = 1 }\n", "table.circle.center", "missing"),
        # Refused before a billion vertices are allocated (it grew to 24 GB and was killed).
        ("[table]\ncircle = { center = [0, 0], radius = 1, points = 1000000000 }\n", "table.circle.points",
         "polygon has 1000000000 vertices, at most 10000"),
        (
            "[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\n[robot]\nbase_pose = [0, 0, 0, 0, 0]\n",
            "robot.base_pose",
            "6 numbers",
        ),
        (
            '[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\n[robot]\nurdf = "nowhere.urdf"\n',
            "robot.urdf",
            "file not found",
        ),
        (
            "[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\n[robot]\ncontact_links = []\n",
            "robot.contact_links",
            "non-empty list",
        ),
        (
            "[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\n[[obstacles]]\ncenter = [0, 0, 0]\nsize = [1, -1, 1]\n",
            "obstacles[0].size",
            "> 0",
        ),
        (
            "[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\n[[obstacles]]\nsize = [1, 1, 1]\n",
            "obstacles[0].center",
            "missing",
        ),
        (
            "[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\n[hand]\ngripper_joints = { t42_finger2_base = 1.0 }\n",
            "hand.gripper_joints.t42_finger2_base",
            "2 numbers",
        ),
        (
            "[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\n[hand]\ngripper_joints = { t42_finger2_base = [0.5, 0.5] }\n",
            "hand.gripper_joints.t42_finger2_base",
            "would not move",
        ),
        (
            "[table]\npolygon = [[0, 0], [1, 0], [0, 1]]\n[robot]\nfixed_joints = { t42_finger2_base = 0.0 }\n"
            "[hand]\ngripper_joints = { t42_finger2_base = [0.0, 1.0] }\n",
            "hand.gripper_joints.t42_finger2_base",
            "also held in robot.fixed_joints",
        ),
        ("table = 3\n", "table", "expected a table"),
        ("[table\n", "", "invalid TOML"),
    ],
)
def test_bad_scene_raises_input_error_naming_file_and_field(tmp_path, text, field, problem):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError) as raised:
        load_scene(path)
    assert str(raised.value).startswith(f"{path}: {field}")
    assert problem in str(raised.value)


def test_unknown_scene_name_raises():
    with pytest.raises(InputError, match="no_such_scene: no such file"):
        load_scene("no_such_scene")


def test_default_robot_urdf_has_the_default_tip_and_contact_links():
    scene = Scene.default()
    urdf = scene.urdf_path.read_text()
    for link in (scene.tip_link, *scene.contact_links):
        assert f'<link name="{link}"' in urdf


@pytest.mark.parametrize("name", ["square", "panda_square", "ur5_round", "z1_square"])
def test_robot_toml_writes_a_robot_and_hand_that_load_back_the_same(name, tmp_path):
    from slideplan.plan.robot import robot_description
    from slideplan.world.scenes import robot_toml

    scene = load_scene(name)
    path = tmp_path / "elsewhere.toml"
    path.write_text("[table]\npolygon = [[0.3, -0.2], [0.7, -0.2], [0.7, 0.2], [0.3, 0.2]]\n" + "\n".join(robot_toml(scene)) + "\n")
    copy = load_scene(path)
    original, reloaded = robot_description(scene), robot_description(copy)
    assert Path(reloaded["urdf"]).resolve() == Path(original["urdf"]).resolve()
    assert [Path(p).resolve() for p in reloaded["attach"]] == [Path(p).resolve() for p in original["attach"]]
    for key in ("base_pose", "tip_offset", "grasp_offset"):
        np.testing.assert_array_equal(reloaded[key], original[key])
    for key in ("base_link", "fixed_joints", "tip_link", "grasp_link", "contact_links", "gripper_joints"):
        assert reloaded[key] == original[key], key
    assert copy.hand.params == scene.hand.params


def test_files_behind_a_scene_are_named_in_its_errors(tmp_path):
    """Each once gave a message naming no file, or the wrong one: a scene, an object or a URDF that is
    not UTF-8 ('utf-8' codec can't decode byte 0xff), an obstacle's object file with a bad field ("must
    be > 0, got -1"), and an attached URDF fragment urdfdom cannot read (blamed on the main URDF)."""
    from slideplan.plan.robot import robot_model

    table = "[table]\npolygon = [[0.3, -0.2], [0.7, -0.2], [0.7, 0.2], [0.3, 0.2]]\n"
    binary = tmp_path / "binary.toml"
    binary.write_bytes(table.encode() + b"# \xff\xfe\n")
    with pytest.raises(InputError, match="not UTF-8") as raised:
        load_scene(binary)
    assert raised.value.source == str(binary)

    (tmp_path / "thin.toml").write_text('name = "thin"\nthickness = -1\noutline = [[0, 0], [0.05, 0], [0, 0.05]]\n')
    cluttered = tmp_path / "cluttered.toml"
    cluttered.write_text(table + '[[obstacles]]\nshape = "object"\nobject = "thin.toml"\npose = [0.4, 0.1, 0]\n')
    with pytest.raises(InputError, match=r"obstacles\[0\]\.object \(.*thin\.toml: thickness\): must be > 0"):
        load_scene(cluttered)

    (tmp_path / "binary.urdf").write_bytes(b'<robot name="x"> \xff </robot>')
    robot = tmp_path / "robot.toml"
    robot.write_text(table + '[robot]\nurdf = "binary.urdf"\n[hand]\ntip_link = "a"\ngrasp_link = "a"\ncontact_links = ["a"]\n')
    with pytest.raises(InputError, match=f"{tmp_path / 'binary.urdf'}: not UTF-8"):
        robot_model(load_scene(robot))

    # A fragment adding a link to the WAM whose collision radius urdfdom cannot parse.
    (tmp_path / "probe.urdf").write_text(
        '<robot name="probe"><link name="probe"><collision><geometry><sphere radius="nan"/></geometry></collision>'
        '</link><joint name="probe_joint" type="fixed"><parent link="wam_link7"/><child link="probe"/></joint></robot>')
    attached = tmp_path / "attached.toml"
    attached.write_text(Path(load_scene("square").source).read_text().replace(
        'urdf = "wam_t42.urdf"', 'urdf = "wam_t42.urdf"\nattach = ["probe.urdf"]'))
    with pytest.raises(InputError) as raised:
        robot_model(load_scene(attached))
    assert f"{tmp_path / 'probe.urdf'} (attached to wam_t42.urdf): malformed URDF" in str(raised.value)
    assert "Link [probe]" in str(raised.value)


def test_a_gripper_joint_is_held_open_while_planning_and_a_wrong_one_is_named_in_hand(tmp_path):
    from slideplan.plan.robot import robot_description, robot_model

    scene = load_scene("panda_square")
    assert robot_description(scene)["fixed_joints"]["panda_finger_joint1"] == scene.hand.gripper_joints["panda_finger_joint1"][0]
    path = tmp_path / "bad_gripper.toml"
    path.write_text(Path(scene.source).read_text().replace("panda_finger_joint1 = [0.02, 0.0]", "panda_finger_joint1 = [0.09, 0.0]"))
    with pytest.raises(ValueError, match=r"\[hand\] gripper_joints.panda_finger_joint1 \(open\): value 0.09.* outside the joint limits"):
        robot_model(load_scene(path))
