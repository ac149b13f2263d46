"""slideplan check-scene: a scene that plans passes; a broken one (the base out of reach, the pre-grasp
backoff too long, the grasp frame inside the hand) is named in the first lines, with the parameter to
change."""

from pathlib import Path

from typer.testing import CliRunner

from slideplan.cli import app
from slideplan.world.scenes import load_scene

runner = CliRunner()


def check(*args):
    result = runner.invoke(app, ["check-scene", *map(str, args)])
    return result.exit_code, result.output.strip().splitlines()


def edited_square(tmp_path: Path, old: str, new: str) -> Path:
    """The square scene with one line changed, beside a copy of its URDF."""
    scene = load_scene("square")
    text = Path(scene.source).read_text()
    assert old in text
    path = tmp_path / "scene.toml"
    path.write_text(text.replace(old, new).replace('"wam_t42.urdf"', f'"{scene.urdf_path}"'))
    return path


def test_a_scene_that_plans_passes_and_says_what_it_checked():
    code, lines = check("square")
    assert code == 0, lines
    assert lines[0].startswith("robot wam_t42.urdf: 7 planned joints")
    assert lines[1] == "gripper: t42_finger2_base from 0 to 1.01 (held open while planning; its mimic joints follow)"
    assert lines[2].startswith("fingertip: reaches the table top over 100% of the table")
    edge = next(line for line in lines if line.startswith("edge 0 "))
    clear = int(edge.split("clear at ")[1].split()[0])
    assert clear > 0, edge


def test_a_base_out_of_reach_is_the_first_line(tmp_path):
    code, lines = check(edited_square(tmp_path, "base_pose = [0.0, 0.0, 0.20, 0.0, 0.0, 0.0]",
                                      "base_pose = [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]"))
    assert code == 1
    assert lines[0].startswith("fingertip: reaches the table top over 0% of the table") and "base_pose" in lines[0]


def test_a_backoff_too_long_is_named_with_a_shorter_one_that_works():
    code, lines = check("square", "--param", "grasp_backoff=0.3")
    assert code == 1
    assert lines[0] == "no edge admits a side grasp with a clear pre-grasp: no plan can end in a grasp"
    assert "grasp_backoff 0.3 leaves the pre-grasp unreachable" in lines[1]
    assert "try grasp_backoff <= 0.05" in lines[1]


def test_a_grasp_frame_inside_the_hand_names_the_part_that_meets_the_table(tmp_path):
    code, lines = check(edited_square(tmp_path, 'grasp_link = "t42_grasp"',
                                      'grasp_link = "t42_grasp"\ngrasp_offset = [0.0, 0.0, -0.12, 0.0, 0.0, 0.0]'))
    assert code == 1
    assert lines[0].startswith("no edge admits")
    assert "grasp in collision (t42_palm-table)" in lines[1] and "grasp_standoff" in lines[1]


def test_bad_input_is_one_error_line():
    result = runner.invoke(app, ["check-scene", "nosuch"])
    assert result.exit_code == 2 and result.stderr.startswith("slideplan: error: nosuch: no such file")


def test_a_hand_with_nothing_to_close_is_said():
    code, lines = check("ur5_square")  # a rigid finger on the flange
    assert lines[1] == "gripper: none ([hand] gripper_joints): execution slides, then has nothing to close"


def test_links_left_unchecked_for_always_touching_are_named(tmp_path):
    """A part that touches another wherever the arm is (here a box fixed to the wrist, over the forearm)
    is left out of the self-collision check by the planner: check-scene says which pairs."""
    (tmp_path / "sleeve.urdf").write_text(
        '<robot name="sleeve"><link name="sleeve"><collision><origin xyz="0 0 -0.1"/><geometry><box size="0.3 0.3 0.3"/>'
        '</geometry></collision></link><joint name="sleeve_joint" type="fixed"><parent link="wam_link7"/>'
        '<child link="sleeve"/></joint></robot>')
    scene = edited_square(tmp_path, 'urdf = "wam_t42.urdf"', 'urdf = "wam_t42.urdf"\nattach = ["sleeve.urdf"]')
    _, lines = check(scene)
    note = next(line for line in lines if line.startswith("self-collision: not checked between"))
    assert "sleeve and wam_link5" in note or "wam_link5 and sleeve" in note, note
    _, plain = check("square")
    assert not any("sleeve" in line for line in plain)


def test_the_map_matches_the_report_and_is_drawn(tmp_path):
    from slideplan.checks.scene import check_scene
    from slideplan.world.objects import load_object

    scene = load_scene("square")
    result = check_scene(scene, load_object("square", table_height=scene.table.height, pose=(0.55, 0.0, 0.0)))
    reach = next(line for line in result.lines if line.startswith("fingertip:"))
    assert f"over {100 * result.reached.mean():.0f}% of the table" in reach
    clear = sum(int(line.split("clear at ")[1].split()[0]) for line in result.lines if "clear at " in line)
    assert clear == sum(kind == "clear" for *_, kind in result.stretches) > 0
    stretches = sum(int(line.split(" of ")[1].split()[0]) if "side grasps on" in line else int(line.split("any of its ")[1].split()[0])
                    for line in result.lines if line.startswith("edge "))
    assert len(result.stretches) == stretches
    png = tmp_path / "map.png"
    code, _ = check("square", "--png", png)
    assert code == 0 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code, lines = check("square", "--png", tmp_path / "map.bmp")
    assert code == 2 and "--png" in lines[0]


def test_a_round_table_is_summarised_by_ranges_of_edges_covering_each_edge_once():
    import re

    _, lines = check("round")
    edges = [line for line in lines if line.startswith("edge")]
    assert 0 < len(edges) < 30, len(edges)  # the round table has 100 edges: once 100 lines
    covered = []
    for line in edges:
        first, last = re.match(r"edges? (\d+)(?:-(\d+))?", line).groups()
        covered += list(range(int(first), int(last or first) + 1))
    assert covered == list(range(100))


def test_a_grasp_blocked_by_the_arm_itself_is_not_told_to_change_the_standoff():
    from slideplan.checks.scene import _grasp_advice
    from slideplan.plan.robot import robot_model
    robot = robot_model(load_scene("square"))
    assert "grasp_standoff" not in _grasp_advice(robot, "grasp in collision (wam_link1-wam_link3)")
    assert "base_pose" in _grasp_advice(robot, "grasp in collision (wam_link1-wam_link3)")
    assert "grasp_standoff" in _grasp_advice(robot, "grasp in collision (t42_finger2_distal-table)")
