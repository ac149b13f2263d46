"""Bring your own arm: mesh collision geometry, package:// URIs, the [hand] keys and their bad
values, and the third-party robots of example-robot-data (Panda, UR5) planning out of the box."""

from __future__ import annotations

import math
import struct
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
from typer.testing import CliRunner

from slideplan import PlannerConfig, _core, load_object, load_scene, plan, verify
from slideplan.cli import app
from slideplan.world.objects import load_outline, sample_pose_on_table
from slideplan.plan.robot import robot_model
from slideplan.plan.planner import grasp_map
from slideplan.transforms import row_to_pose
from slideplan.world.scenes import package_search_dirs

TABLE = "[table]\npolygon = [[0.3, -0.2], [0.7, -0.2], [0.7, 0.2], [0.3, 0.2]]\n"


def cube_triangles(half: float) -> tuple[np.ndarray, np.ndarray]:
    """A cube of half-extent `half` centred at the origin: 8 vertices, 12 outward triangles."""
    vertices = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return vertices, faces


def write_stl(path: Path, half: float) -> None:
    vertices, faces = cube_triangles(half)
    with open(path, "wb") as stream:
        stream.write(b"\0" * 80 + struct.pack("<I", len(faces)))
        for face in faces:
            stream.write(struct.pack("<3f", 0, 0, 0))
            for index in face:
                stream.write(struct.pack("<3f", *vertices[index]))
            stream.write(b"\0\0")


def write_obj(path: Path, half: float) -> None:
    vertices, faces = cube_triangles(half)
    lines = [f"v {x} {y} {z}" for x, y, z in vertices] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


def slider_urdf(mesh_uri: str, scale: str = "1 1 1") -> str:
    """A prismatic joint moving a link, whose collision is the mesh, straight down along z."""
    return f"""<robot name="slider">
  <link name="base"/>
  <link name="block"><collision><geometry><mesh filename="{mesh_uri}" scale="{scale}"/></geometry></collision></link>
  <joint name="drop" type="prismatic"><parent link="base"/><child link="block"/><origin xyz="0.5 0 0.5"/>
    <axis xyz="0 0 -1"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>
</robot>"""


def table_world(robot) -> _core.CollisionWorld:
    table = _core.SupportSurface(np.array([[0.3, -0.2], [0.7, -0.2], [0.7, 0.2], [0.3, 0.2]]), 0.0)
    return _core.CollisionWorld(robot, table)


@pytest.mark.parametrize("writer, name", [(write_stl, "cube.stl"), (write_obj, "cube.obj")])
def test_mesh_collision_geometry_is_loaded_scaled_and_checked(tmp_path, writer, name):
    writer(tmp_path / name, 0.05)
    urdf = tmp_path / "slider.urdf"
    urdf.write_text(slider_urdf(name, scale="2 2 2"))  # a 20 cm cube, its centre 0.5 m above the table
    robot = _core.RobotModel(str(urdf), tip_link="block")
    world = table_world(robot)
    # The cube's bottom is at 0.5 - q - 0.1: clear above 0.39 m of travel, touching the table below.
    assert world.is_valid(np.array([0.38]))
    assert not world.is_valid(np.array([0.42]))
    assert world.collisions(np.array([0.42])) == [("block", "table")]


def test_unscaled_mesh_keeps_its_size(tmp_path):
    write_stl(tmp_path / "cube.stl", 0.05)
    (tmp_path / "slider.urdf").write_text(slider_urdf("cube.stl"))
    world = table_world(_core.RobotModel(str(tmp_path / "slider.urdf"), tip_link="block"))
    assert world.is_valid(np.array([0.44])) and not world.is_valid(np.array([0.46]))


def write_jaws_obj(path: Path) -> None:
    """Two 4 cm cubes in one mesh, centred at x = -6 and +6 cm: jaws with an 8 cm gap between them. The
    hull is a 16 x 4 x 4 cm box, twice the mesh's volume (two 4 cm cubes)."""
    vertices, faces = cube_triangles(0.02)
    lines = [f"v {x + dx} {y} {z}" for dx in (-0.06, 0.06) for x, y, z in vertices]
    lines += [f"f {a + 1 + k} {b + 1 + k} {c + 1 + k}" for k in (0, 8) for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


def box_at(x: float, size: float) -> _core.BoxObstacle:
    pose = np.eye(4)
    pose[:3, 3] = [x, 0.0, 0.5]  # at the height of the slider's link at q = 0
    return _core.BoxObstacle(pose, np.full(3, size))


@pytest.mark.parametrize("in_hand", [True, False])
def test_a_concave_hand_mesh_is_checked_as_its_triangles_and_an_arm_mesh_as_its_hull(tmp_path, in_hand):
    write_jaws_obj(tmp_path / "jaws.obj")
    urdf = slider_urdf("jaws.obj")
    if not in_hand:  # a further joint beyond the jaws' link: the jaws are then an arm link
        urdf = urdf.replace("</robot>", '<link name="finger"/><joint name="reach" type="prismatic"><parent link="block"/>'
                            '<child link="finger"/><axis xyz="1 0 0"/><limit lower="0" upper="1" effort="1" velocity="1"/>'
                            "</joint></robot>")
    (tmp_path / "jaws.urdf").write_text(urdf)
    robot = _core.RobotModel(str(tmp_path / "jaws.urdf"), tip_link="block" if in_hand else "finger")
    [(link, mesh, hull_ratio, exact)] = robot.collision_meshes
    assert (link, Path(mesh).name, exact) == ("block", "jaws.obj", in_hand)
    assert hull_ratio == pytest.approx(0.16 * 0.04 * 0.04 / (2 * 0.04 ** 3)) and hull_ratio > _core.concave_hull_ratio
    q = np.zeros(robot.dof)
    table = _core.SupportSurface(np.array([[0.3, -0.2], [0.7, -0.2], [0.7, 0.2], [0.3, 0.2]]), 0.0)
    in_gap = _core.CollisionWorld(robot, table, [box_at(0.5, 0.02)])  # 2 cm, in the middle of the gap
    assert in_gap.is_valid(q) == in_hand  # the hull fills the gap
    on_jaw = _core.CollisionWorld(robot, table, [box_at(0.5 + 0.04, 0.02)])  # across the +x jaw's inner face
    assert not on_jaw.is_valid(q)
    assert on_jaw.collisions(q)[0][0] == "block"


def test_a_hand_mesh_checked_as_its_triangles_is_named_in_a_warning(tmp_path):
    write_jaws_obj(tmp_path / "jaws.obj")
    (tmp_path / "jaws.urdf").write_text(slider_urdf("jaws.obj"))
    scene = tmp_path / "scene.toml"
    scene.write_text(TABLE + '[robot]\nurdf = "jaws.urdf"\n[hand]\ntip_link = "block"\ngrasp_link = "block"\n'
                     'contact_links = ["block"]\n')
    result = CliRunner().invoke(app, ["plan", "--scene", str(scene), "--object", "square", "--pose", "0.5", "0", "0",
                                      "--time-limit", "0.2"])
    warning = [line for line in result.stderr.splitlines() if line.startswith("slideplan: warning:")]
    assert len(warning) == 1, result.stderr
    assert "'block' (jaws.obj: hull 2.00 x its volume)" in warning[0]
    assert "1 hand mesh(es) checked as their triangles" in warning[0]


def test_package_uris_resolve_in_a_parent_or_the_package_directory(tmp_path):
    mesh = tmp_path / "share" / "my_robot" / "meshes" / "cube.stl"
    mesh.parent.mkdir(parents=True)
    write_stl(mesh, 0.05)
    uri = "package://my_robot/meshes/cube.stl"
    assert Path(_core.resolve_uri(uri, "", [str(tmp_path / "share")])) == mesh
    assert Path(_core.resolve_uri(uri, "", [str(tmp_path / "share" / "my_robot")])) == mesh
    with pytest.raises(ValueError, match="cannot resolve package 'my_robot'"):
        _core.resolve_uri(uri, "", [str(tmp_path)])
    (tmp_path / "slider.urdf").write_text(slider_urdf(uri))
    robot = _core.RobotModel(str(tmp_path / "slider.urdf"), tip_link="block", package_dirs=[str(tmp_path / "share")])
    assert not table_world(robot).is_valid(np.array([0.46]))


def test_installed_python_packages_are_searched_for_package_uris():
    resolved = _core.resolve_uri(
        "package://example-robot-data/robots/panda_description/urdf/panda.urdf", "", [str(p) for p in package_search_dirs()]
    )
    assert Path(resolved).is_file()


def test_scene_urdf_as_package_uri_with_relative_package_dirs(tmp_path):
    share = tmp_path / "share" / "my_robot"
    share.mkdir(parents=True)
    write_stl(share / "cube.stl", 0.05)
    (share / "slider.urdf").write_text(slider_urdf("package://my_robot/cube.stl"))
    (tmp_path / "scene.toml").write_text(
        TABLE + '[robot]\nurdf = "package://my_robot/slider.urdf"\npackage_dirs = ["share"]\n'
        '[hand]\ntip_link = "block"\ngrasp_link = "block"\ncontact_links = ["block"]\n'
    )
    scene = load_scene(tmp_path / "scene.toml")
    assert scene.urdf_path == share / "slider.urdf"
    assert robot_model(scene).dof == 1


# -- bad input: exit 2, one line naming the file and the key -------------------------------------------

PANDA = "package://example-robot-data/robots/panda_description/urdf/panda.urdf"
PANDA_HAND = ('[hand]\ntip_link = "panda_leftfinger"\ngrasp_link = "panda_hand_tcp"\n'
              'contact_links = ["panda_leftfinger"]\n')


def assert_exit_2(scene_text: str, tmp_path: Path, *fragments: str) -> None:
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text)
    result = CliRunner().invoke(app, ["plan", "--scene", str(scene), "--object", "square", "--pose", "0.5", "0", "0",
                                      "--time-limit", "1"])
    assert result.exit_code == 2, (result.exit_code, result.output)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("slideplan: error: "), result.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


def test_missing_mesh_file(tmp_path):
    (tmp_path / "slider.urdf").write_text(slider_urdf("gone.stl"))
    assert_exit_2(TABLE + '[robot]\nurdf = "slider.urdf"\n[hand]\ntip_link = "block"\ngrasp_link = "block"\n'
                  'contact_links = ["block"]\n', tmp_path, "slider.urdf", "link 'block'", "gone.stl", "does not exist")


def test_unsupported_mesh_format(tmp_path):
    (tmp_path / "cube.xyz").write_text("not a mesh\n")
    (tmp_path / "slider.urdf").write_text(slider_urdf("cube.xyz"))
    assert_exit_2(TABLE + '[robot]\nurdf = "slider.urdf"\n[hand]\ntip_link = "block"\ngrasp_link = "block"\n'
                  'contact_links = ["block"]\n', tmp_path, "slider.urdf", "cube.xyz", "cannot read mesh")


def test_unresolvable_package(tmp_path):
    (tmp_path / "slider.urdf").write_text(slider_urdf("package://no_such_package/cube.stl"))
    assert_exit_2(TABLE + '[robot]\nurdf = "slider.urdf"\n[hand]\ntip_link = "block"\ngrasp_link = "block"\n'
                  'contact_links = ["block"]\n', tmp_path, "slider.urdf", "cannot resolve package 'no_such_package'")


@pytest.mark.parametrize(
    ("robot_keys", "hand", "fragments"),
    [
        ("", PANDA_HAND.replace('tip_link = "panda_leftfinger"', 'tip_link = "pinky"'), ("[hand] tip_link 'pinky'",)),
        ("", PANDA_HAND.replace('grasp_link = "panda_hand_tcp"', 'grasp_link = "palm"'), ("[hand] grasp_link 'palm'",)),
        ('base_link = "nowhere"\n', PANDA_HAND, ("[robot] base_link 'nowhere'",)),
        ('base_link = "panda_rightfinger"\n', PANDA_HAND, ("not downstream of base_link 'panda_rightfinger'",)),
        ("fixed_joints = { elbow = 0.1 }\n", PANDA_HAND, ("fixed_joints.elbow", "no such joint")),
        ("fixed_joints = { panda_finger_joint1 = 0.5 }\n", PANDA_HAND, ("fixed_joints.panda_finger_joint1", "outside")),
        ("fixed_joints = { panda_finger_joint2 = 0.01 }\n", PANDA_HAND, ("fixed_joints.panda_finger_joint2", "mimic")),
        ("", PANDA_HAND + "tip_offset = [0.0, 0.1]\n", ("hand.tip_offset", "6")),
        ("", PANDA_HAND + "grasp_offset = [0, 0, 0, 0, 0, 0, 0]\n", ("hand.grasp_offset", "6")),
    ],
)
def test_bad_robot_and_hand_keys_name_the_file_and_key(tmp_path, robot_keys, hand, fragments):
    scene = TABLE + f'[robot]\nurdf = "{PANDA}"\n{robot_keys}' + hand
    assert_exit_2(scene, tmp_path, "scene.toml", *fragments)


def test_a_scene_with_its_own_urdf_must_describe_its_hand(tmp_path):
    assert_exit_2(TABLE + f'[robot]\nurdf = "{PANDA}"\n', tmp_path, "scene.toml", "hand.tip_link", "missing")


def test_param_overrides_the_hand_and_bad_params_exit_2(tmp_path):
    runner = CliRunner()
    base = ["plan", "--scene", "square", "--object", "square", "--pose", "0.5", "0", "0", "--time-limit", "5"]
    solved = runner.invoke(app, [*base, "--param", "u_star=0.03", "--json", str(tmp_path / "p.json")])
    assert solved.exit_code == 0, solved.output
    assert '"u_star": 0.03' in (tmp_path / "p.json").read_text()
    for bad, fragment in [("u_star", "NAME=VALUE"), ("pinky=1", "--param pinky"), ("u_star=abc", "--param u_star"),
                          ("u_star=-1", "--param u_star")]:
        result = runner.invoke(app, [*base, "--param", bad])
        assert result.exit_code == 2 and fragment in result.stderr, (bad, result.stderr)


# -- the Panda's kinematics, computed independently from its URDF's joint origins -----------------------


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    skew = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * skew + (1 - math.cos(angle)) * skew @ skew


def urdf_chain_pose(urdf: Path, link: str, values: dict[str, float]) -> np.ndarray:
    """World pose of `link` by walking the URDF's joints from the root: origin, then the joint motion."""
    joints = {joint.find("child").get("link"): joint for joint in ElementTree.parse(urdf).getroot().iter("joint")}
    chain = []
    while link in joints:
        chain.append(joints[link])
        link = joints[link].find("parent").get("link")
    pose = np.eye(4)
    for joint in reversed(chain):
        origin = joint.find("origin")
        step = np.eye(4)
        if origin is not None:
            step[:3, :3] = rpy_matrix(*(float(v) for v in origin.get("rpy", "0 0 0").split()))
            step[:3, 3] = [float(v) for v in origin.get("xyz", "0 0 0").split()]
        motion = np.eye(4)
        if joint.get("type") in ("revolute", "continuous"):
            motion[:3, :3] = axis_angle(np.array([float(v) for v in joint.find("axis").get("xyz").split()]),
                                        values[joint.get("name")])
        pose = pose @ step @ motion
    return pose


def test_panda_hand_tcp_matches_an_independent_computation_from_the_urdf():
    scene = load_scene("panda_square")
    robot = robot_model(scene)
    assert robot.dof == 7
    rng = np.random.default_rng(4)
    for _ in range(20):
        q = rng.uniform(robot.lower_limits, robot.upper_limits)
        expected = urdf_chain_pose(scene.urdf_path, "panda_hand_tcp", dict(zip(robot.joint_names, q)))
        np.testing.assert_allclose(robot.link_pose(q, "panda_hand_tcp"), expected, atol=1e-12)


@pytest.mark.parametrize("scene_name", ["panda_square", "panda_round", "ur5_square", "ur5_round", "ur5_gripper_square", "xarm7_square",
                                        "kinova_square", "z1_square"])
def test_third_party_arms_plan_out_of_the_box_and_verify(scene_name):
    scene = load_scene(scene_name)
    outline, _, _ = load_outline("crescent")
    pose = sample_pose_on_table(outline, scene.table, np.random.default_rng(3))
    obj = load_object("crescent", table_height=scene.table.height, pose=pose)
    result = plan(scene, obj, PlannerConfig.for_scene(scene, seed=1, time_limit_s=20.0))
    assert result.solved, result.stats
    verification = verify(result)
    assert verification.ok, verification.violations[:5]
    assert result.params["dz_max"] == scene.hand.params["dz_max"]  # the hand's defaults were used


def test_the_stock_z1_solves_five_objects_at_two_poses_each_and_checks_its_jaws_exactly():
    """docs/own-robot.md's walkthrough: the Unitree Z1's URDF as example-robot-data ships it. Its
    gripperStator mesh holds the housing and the fixed jaw; as a hull it fills the jaws' gap, and a
    grasp then always meets the object (1 of 10 solved with hulls)."""
    scene = load_scene("z1_square")
    exact = {link for link, _, _, exact in robot_model(scene).collision_meshes if exact}
    assert exact == {"gripperStator", "gripperMover"}
    assert len(_solved_and_verified(scene)) >= 8


def _solved_and_verified(scene) -> list:
    """The solved plans of 5 objects x 2 seeded poses on the scene's table (10 s each), each checked
    by the verifier."""
    solved = []
    for name in ("square", "circle", "triangle", "crescent", "irregular"):
        outline, _, _ = load_outline(name)
        for seed in (1, 2):
            pose = sample_pose_on_table(outline, scene.table, np.random.default_rng([seed, len(name)]))
            obj = load_object(name, table_height=scene.table.height, pose=pose)
            result = plan(scene, obj, PlannerConfig.for_scene(scene, seed=seed, time_limit_s=10.0))
            if result.solved:
                verification = verify(result)
                assert verification.ok, (name, seed, verification.violations[:3])
                solved.append(result)
    return solved


def test_a_five_joint_arm_slides_and_grasps_with_the_approach_turned_within_its_tolerance():
    """The SO-101 (five joints) from example-robot-data's stock URDF: the sliding constraint leaves the
    contact's yaw free, and a side grasp's heading may turn within the hand's grasp_yaw_tolerance."""
    scene = load_scene("so101_square")
    assert robot_model(scene).dof == 5
    tolerance = scene.hand.params["grasp_yaw_tolerance"]
    solved = _solved_and_verified(scene)
    assert len(solved) >= 8
    turned = 0
    for result in solved:
        # The grasp's approach is off the edge's inward normal by its heading alone, within the band.
        approach = row_to_pose(result.grasp["pose"])[:3, 2]
        assert abs(approach[2]) < 1e-3
        heading = math.atan2(abs(approach[1]), approach[0])
        assert heading <= tolerance + 1e-3
        if heading > 1e-3:
            turned += 1
            # The verifier holds the grasp to the plan's own band: without it the turn is refused.
            result.params["grasp_yaw_tolerance"] = 0.0
            assert any(v.startswith("grasp.pose: turned") for v in verify(result).violations)
    assert turned >= 1  # the band is used: some grasps beside the arm's plane turn the approach


def test_without_its_tolerance_the_five_joint_arm_reaches_no_side_grasp():
    """The tolerance is what makes the SO-101's grasps reachable: with H_g exactly (0 rad), the grasp map
    finds none on the edge facing the arm, where with the hand's 0.5 rad it finds every stretch."""
    scene = load_scene("so101_square")
    obj = load_object("square", table_height=scene.table.height, pose=(0.37, 0.0, 0.0))
    near_edge = 3  # (0.30, 0.10)-(0.30, -0.10), facing the base
    counts = {}
    for tolerance in (0.0, scene.hand.params["grasp_yaw_tolerance"]):
        config = PlannerConfig.for_scene(scene, grasp_yaw_tolerance=tolerance).resolved(scene)
        mapped = grasp_map(scene, obj, config)
        cells = mapped.stretch_count(near_edge)
        counts[tolerance] = sum(mapped.grasp_on(near_edge, cell) is not None for cell in range(cells))
    assert counts[0.0] <= 2 < counts[scene.hand.params["grasp_yaw_tolerance"]] == cells


def test_a_hand_with_several_concave_meshes_gives_one_warning_naming_them_all():
    import warnings

    from slideplan.errors import MeshWarning
    from slideplan.plan.robot import build_robot, robot_description

    exact = {link for link, _, _, is_exact in robot_model(load_scene("so101_square")).collision_meshes if is_exact}
    assert len(exact) >= 2
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        build_robot(robot_description(load_scene("so101_square")))
    meshes = [warning for warning in caught if issubclass(warning.category, MeshWarning)]
    assert len(meshes) == 1, [str(warning.message) for warning in meshes]
    assert all(f"'{link}'" in str(meshes[0].message) for link in exact)


def _stepped_by_ik(robot, config, offset):
    """The straight line as motions.straight_line computed it in Python before the core's straightLine: IK a
    centimetre at a time (a generator seeded 0 each step), each seeded by the last, no joint turning more
    than 0.3 rad."""
    start, offset = np.asarray(robot.fk(config)), np.asarray(offset, dtype=float)
    steps = max(1, math.ceil(float(np.linalg.norm(offset)) / 0.01 - 1e-9))
    path = [np.asarray(config, dtype=float)]
    for step in range(1, steps + 1):
        target = start.copy()
        target[:3, 3] += offset * step / steps
        found = robot.ik(target, seed=path[-1], rng_seed=0, options=_core.contact_ik_options(robot))
        if found is None or np.max(np.abs(np.asarray(found) - path[-1])) > 0.3:
            return None
        path.append(np.asarray(found, dtype=float))
    return np.array(path)


@pytest.mark.parametrize("scene_name", ["square", "so101_square"])
def test_the_straight_line_is_the_cores_and_moves_as_ik_stepped_a_centimetre_at_a_time(scene_name):
    from slideplan.plan.motions import straight_line, straight_up

    robot = robot_model(load_scene(scene_name))
    rng = np.random.default_rng(3)
    lines = 0
    for index in range(12):
        config = np.asarray(robot.random_configuration(index))
        offset = rng.uniform(-0.04, 0.04, 3)
        path, reference = straight_line(robot, config, offset), _stepped_by_ik(robot, config, offset)
        assert (path is None) == (reference is None)
        if path is not None:
            lines += 1
            assert np.array_equal(path, reference)  # bit for bit: executions unchanged
            tips = np.array([np.asarray(robot.fk(q))[:3, 3] for q in path])
            assert np.abs(tips[-1] - tips[0] - offset).max() < 1e-6
    assert lines >= 6
    assert (_core.LIFT_STEP_M, _core.LIFT_JOINT_STEP_RAD) == (0.01, 0.3)
    up = straight_up(robot, config, 0.025)
    assert up is None or len(up) == 4  # 3 steps of at most a centimetre
    with pytest.raises(ValueError, match="finite"):
        _core.straight_line(robot, np.full(robot.dof, np.nan), np.zeros(3))
