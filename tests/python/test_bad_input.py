"""Bad plan and scene files met with one clear line naming the file and field: never a traceback, a hang
or unbounded memory."""

import json
import os
import re
import resource
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from slideplan._fields import as_numbers
from slideplan._limits import MAX_MAGNITUDE, MAX_PLAN_BYTES, MAX_ROBOT_FILE_BYTES, MAX_SCENE_MAGNITUDE, MAX_WAYPOINTS
from slideplan.cli import app
from slideplan.errors import InputError
from slideplan.sim.settings import ExecutionSettings
from slideplan.plan.config import PlannerConfig
from slideplan.plan.result import PlanResult
from slideplan.world.scenes import load_scene

TABLE = "[table]\npolygon = [[0.4, -0.3], [0.8, -0.3], [0.8, 0.3], [0.4, 0.3]]\n"
HAND = '[hand]\ntip_link = "tip"\ngrasp_link = "tip"\ncontact_links = ["tip"]\n'


def assert_one_line(exit_code, stderr, *fragments):
    lines = stderr.strip().splitlines()
    assert exit_code == 2 and len(lines) == 1 and lines[0].startswith("slideplan: error: "), (exit_code, stderr)
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


def cli(*args):
    result = CliRunner().invoke(app, [str(arg) for arg in args])
    assert "Traceback" not in result.output + result.stderr, result.output + result.stderr
    return result


def plan_file(planned, tmp_path, **changes):
    data = planned.to_dict()
    data["robot"].update(changes.pop("robot", {}))
    data.update(changes)
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(data))
    return path


def export_in_a_process(plan, tmp_path):
    """``slideplan export`` in a process of its own, bounded in time and memory: a reader that regresses
    fails this test instead of hanging it or filling the machine's memory."""
    def limit_memory():
        resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))

    command = [sys.executable, "-c", "from slideplan.cli import app; app(prog_name='slideplan')",
               "export", str(plan), "--format", "csv", "--out", str(tmp_path / "out.csv")]
    try:
        return subprocess.run(command, capture_output=True, text=True, timeout=60, preexec_fn=limit_memory)
    except subprocess.TimeoutExpired:
        pytest.fail("the plan reader hung")


@pytest.mark.parametrize("key", ["urdf", "attach", "device"])
def test_a_robot_file_that_is_a_fifo_or_a_device_is_refused_not_read(planned, tmp_path, key):
    # Once: a FIFO hung every reader forever, /dev/zero read until memory ran out.
    if key == "device":
        named, robot = "/dev/zero", {"urdf": "/dev/zero"}
    else:
        named = str(tmp_path / "robot.urdf")
        os.mkfifo(named)
        robot = {"urdf": named} if key == "urdf" else {"attach": [named]}
    done = export_in_a_process(plan_file(planned, tmp_path, robot=robot), tmp_path)
    assert_one_line(done.returncode, done.stderr, named, "not a regular file")


def test_an_unparsable_attached_file_names_the_field_and_the_file(planned, tmp_path):
    # Once: a ParseError traceback.
    fragment = tmp_path / "finger.urdf"
    fragment.write_text('<robot name="finger"><link name=')
    plan = plan_file(planned, tmp_path, robot={"attach": [str(fragment)]})
    with pytest.raises(InputError, match=re.escape(f"{fragment}: robot.attach[0]: not a URDF")):
        PlanResult.load(plan).robot_model()
    done = cli("export", plan, "--format", "csv", "--out", tmp_path / "out.csv")
    assert_one_line(done.exit_code, done.stderr, str(fragment), "robot.attach[0]", "not a URDF")


def test_an_integer_too_long_to_convert_names_its_field(planned, tmp_path):
    # Once: Python's ValueError "Exceeds the limit (4300 digits) for integer string conversion".
    plan = plan_file(planned, tmp_path, seed=123454321)
    plan.write_text(plan.read_text().replace('"seed": 123454321', '"seed": ' + "9" * 5000))
    with pytest.raises(InputError, match="not a finite number") as error:
        PlanResult.load(plan)
    assert (error.value.source, error.value.field) == (str(plan), "seed")
    done = cli("export", plan, "--format", "csv", "--out", tmp_path / "out.csv")
    assert_one_line(done.exit_code, done.stderr, str(plan), "seed")


@pytest.mark.parametrize("path", [("trajectory", "fingertip_poses"), ("grasp.approach",)])
def test_a_path_beyond_the_waypoint_limit_is_refused_naming_the_limit(planned, path):
    # Once: 10^6 waypoints took 55 s and 1.5 GB, 10^7 exhausted memory.
    data = planned.to_dict()
    data["schema"] = "slideplan.plan/1"  # untimed: only the paths need the rows
    del data["timing"]
    for name in path:
        block, key = (data["grasp"], "approach") if name == "grasp.approach" else (data, name)
        block[key] = block[key][:1] * (MAX_WAYPOINTS + 1)
    with pytest.raises(InputError, match=f"more than the limit of {MAX_WAYPOINTS:,}") as error:
        PlanResult.from_dict(data)
    assert error.value.field == path[0]
    for name in path:  # at the limit, it is a plan
        block, key = (data["grasp"], "approach") if name == "grasp.approach" else (data, name)
        del block[key][MAX_WAYPOINTS:]
    assert len(PlanResult.from_dict(data).trajectory) in (MAX_WAYPOINTS, len(planned.trajectory))


def test_a_plan_file_beyond_the_size_limit_is_refused_before_it_is_parsed(tmp_path):
    path = tmp_path / "huge.json"
    with open(path, "wb") as stream:
        stream.truncate(MAX_PLAN_BYTES + 1)  # sparse: takes no disk and no time
    with pytest.raises(InputError, match=f"more than the limit of {MAX_PLAN_BYTES >> 20} MB") as error:
        PlanResult.load(path)
    assert error.value.source == str(path)


def test_a_missing_file_in_a_found_package_is_not_called_a_missing_package(tmp_path):
    # Once: "cannot resolve package 'example-robot-data' (add its parent directory ...)" for a mistyped file.
    package = tmp_path / "share" / "my_robot"
    (package / "urdf").mkdir(parents=True)
    scene = tmp_path / "scene.toml"
    scene.write_text(TABLE + '[robot]\nurdf = "package://my_robot/urdf/ur11.urdf"\npackage_dirs = ["share"]\n' + HAND)
    with pytest.raises(InputError) as error:
        load_scene(scene)
    assert (error.value.source, error.value.field) == (str(scene), "robot.urdf")
    assert f"package 'my_robot' is at {package}, but it has no file urdf/ur11.urdf" in error.value.problem
    assert "package_dirs" not in error.value.problem
    scene.write_text(TABLE + '[robot]\nurdf = "package://no_such_robot/urdf/ur11.urdf"\npackage_dirs = ["share"]\n' + HAND)
    with pytest.raises(InputError, match="cannot resolve package 'no_such_robot' .*package_dirs"):
        load_scene(scene)


HUGE = "1e308"


@pytest.mark.parametrize("text, field", [
    (TABLE.replace("[0.4, -0.3]", f"[{HUGE}, -0.3]"), "table.polygon[0]"),
    ("[table]\ncircle = { center = [0.6, 0.0], radius = 2e3 }\n", "table.circle.radius"),
    (TABLE + f"[[obstacles]]\ncenter = [0.6, 0.0, 0.05]\nsize = [0.1, 0.1, {HUGE}]\n", "obstacles[0].size"),
    (TABLE + "[[obstacles]]\ncenter = [0.6, -1e4, 0.05]\nsize = [0.1, 0.1, 0.1]\n", "obstacles[0].center"),
    (TABLE + "[robot]\nbase_pose = [0.0, 0.0, 1e4, 0.0, 0.0, 0.0]\n", "robot.base_pose"),
])
def test_a_scene_number_beyond_the_bound_names_the_file_and_field(tmp_path, text, field):
    # Once: MuJoCo's "XML Error: number is too large in attribute 'vertex'" from run, a time-out from plan.
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    with pytest.raises(InputError, match=f"beyond {MAX_SCENE_MAGNITUDE:g} in magnitude") as error:
        load_scene(scene)
    assert (error.value.source, error.value.field) == (str(scene), field)
    done = cli("plan", "--scene", scene, "--object", "crescent", "--time-limit", "2")
    assert_one_line(done.exit_code, done.stderr, str(scene), field)


def test_the_planning_guide_states_the_limits_the_readers_apply():
    readme = " ".join((Path(__file__).resolve().parents[2] / "docs" / "planning.md").read_text().split())
    power = lambda value: f"{value:.0e}".replace("e+0", "e")  # 1e9
    for stated in (f"plan file over {MAX_PLAN_BYTES >> 20} MB", f"of over {MAX_WAYPOINTS:,} waypoints",
                   f"beyond {power(MAX_MAGNITUDE)} in magnitude", f"is over {MAX_ROBOT_FILE_BYTES >> 20} MB",
                   f"no length or angle beyond {power(MAX_SCENE_MAGNITUDE)}"):
        assert stated in readme, stated



@pytest.mark.parametrize("make, field", [
    (lambda path: ExecutionSettings(press_force=0.0), "press_force"),
    (lambda path: PlannerConfig(time_limit_s=-1.0), "time_limit_s"),
    (lambda path: load_scene(path), "obstacles[0].size"),
])
def test_every_positive_number_is_checked_by_the_one_check_in_fields(make, field, tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text(TABLE + "[[obstacles]]\ncenter = [0.6, 0.0, 0.05]\nsize = [0.1, 0.0, 0.1]\n")
    with pytest.raises(InputError) as error:
        make(scene)
    assert error.value.field == field and error.value.problem.startswith("must be > 0, got "), error.value


def test_a_list_of_positive_numbers_names_the_first_that_is_not():
    assert as_numbers([0.5, 2], 2, source="s", field="f", positive=True).tolist() == [0.5, 2.0]
    with pytest.raises(InputError) as error:
        as_numbers([0.5, -1], 2, source="s", field="f", positive=True)
    assert (error.value.field, error.value.problem) == ("f", "must be > 0, got -1")
    assert as_numbers([0.5, -1], 2, source="s", field="f").tolist() == [0.5, -1.0]


def test_a_directory_given_for_a_plan_is_named_as_one():
    # Once: "[Errno 21] Is a directory: 3", the number being a file descriptor.
    result = cli("execute", Path(__file__).parent)
    assert_one_line(result.exit_code, result.stderr, str(Path(__file__).parent), "not a regular file but a directory")
    assert "Errno" not in result.stderr


def test_coincident_vertices_are_counted_as_given():
    with pytest.raises(InputError, match=r"at least 3 vertices, got 3 \(the last repeats the first, closing the ring: 2 distinct\)"):
        load_scene_text("[table]\npolygon = [[0.5, 0.0], [0.5, 0.0], [0.5, 0.0]]\n")


def test_a_scene_s_own_depth_band_is_blamed_on_the_scene_not_on_an_option_never_given(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text(TABLE + "[hand]\nparams = { dz_min = 0.02, dz_max = 0.01 }\n")
    for command in (("plan", "--pose", "0.6", "0.0", "0.0"), ("run",)):  # run has no such option at all
        result = cli(*command, "--scene", scene, "--object", "square")
        assert_one_line(result.exit_code, result.stderr, str(scene), "[hand] params.dz")
        assert "--reconfiguration-range" not in result.stderr


def load_scene_text(text: str):
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scene.toml"
        path.write_text(text)
        return load_scene(path)


def test_a_scene_nested_thousands_deep_is_one_line_not_a_recursion_error(tmp_path):
    scene = tmp_path / "deep.toml"
    scene.write_text("[table]\npolygon = " + "[" * 5000 + "]" * 5000 + "\n")
    result = cli("plan", "--scene", scene, "--object", "square", "--pose", "0.6", "0.0", "0.0")
    assert_one_line(result.exit_code, result.stderr, str(scene), "nested too deeply")


@pytest.mark.parametrize("seed", ["-1", str(2**64)])
def test_a_run_s_bad_seed_is_named_by_its_option(seed):
    result = cli("run", "--scene", "square", "--object", "crescent", "--pose", "0.55", "-0.08", "0.4", "--seed", seed)
    assert_one_line(result.exit_code, result.stderr, "--seed", "[0, 2**64)")
