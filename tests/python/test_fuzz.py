"""Property-based fuzzing of the Python entry points (hypothesis).

Whatever the input, only ``InputError`` or a clean result (a plan, or a timeout within the time limit
plus 0.5 s) may come out: no other exception, no crash, no hang. The normal suite runs the seeded
``ci`` profile (a few thousand examples in all); ``make fuzz`` runs the ``fuzz`` profile (many more,
random seeds).
"""

from __future__ import annotations

import functools
import json
import math
import os
import time
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from slideplan import InputError, PlannerConfig, PlanResult, SupportSurface, ThinObject, load_object, load_scene, perceive, plan, verify
from slideplan.outputs.export import export_plan
from slideplan.plan.robot import robot_model
from slideplan.checks.verify import require_motion

# Fixtures (tmp_path_factory, capfd) serve every example: each example writes its own files or reads
# what it alone printed.
HEALTH = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.function_scoped_fixture]
settings.register_profile("ci", derandomize=True, deadline=None, suppress_health_check=HEALTH)
settings.register_profile("fuzz", deadline=None, suppress_health_check=HEALTH)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
FUZZ = os.environ.get("HYPOTHESIS_PROFILE") == "fuzz"


def examples(count: int) -> int:
    """Examples of one test: `count` in the normal suite, ten times more under `make fuzz`."""
    return count * 10 if FUZZ else count


SCENE = load_scene("square")
SLACK_S = 0.5  # a plan may overrun its time limit by at most this much

finite = st.floats(min_value=-5.0, max_value=5.0, allow_nan=False)
anything = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-1e300, max_value=1e300),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.booleans(),
    st.text(max_size=5),
    st.none(),
    st.lists(st.floats(), max_size=3),
)


def clean(call):
    """Run `call`; an InputError is a clean outcome, any other exception fails the test."""
    try:
        return call()
    except InputError as error:
        assert str(error), "an InputError must say what is wrong"
        return None


def planned_clean(scene, obj, config, allowed_s: float):
    """:func:`clean` planning within ``allowed_s`` of wall time; a plan that solves passes the verifier."""
    started = time.perf_counter()
    result = clean(lambda: plan(scene, obj, config))
    assert time.perf_counter() - started <= allowed_s
    if result is not None and result.solved:
        verification = verify(result)
        assert verification.ok, verification
    return result


def on_table_cloud(draw, count: int) -> np.ndarray:
    """`count` points around a seeded centre on the square table, 4 mm above it."""
    centre = np.array([draw(st.floats(0.45, 0.6)), draw(st.floats(-0.1, 0.1))])
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    xy = centre + rng.uniform(-0.04, 0.04, size=(count, 2))
    return np.column_stack([xy, np.full(count, SCENE.table.height + 0.004)])


@st.composite
def clouds(draw):
    """Object clouds, from sane to absurd."""
    kind = draw(st.sampled_from(["empty", "few", "collinear", "duplicated", "nonfinite", "huge", "off_table", "random", "dense"]))
    if kind == "empty":
        return np.zeros((0, 3))
    if kind == "few":
        return on_table_cloud(draw, draw(st.integers(1, 2)))
    if kind == "collinear":
        t = np.linspace(0.0, 0.08, draw(st.integers(3, 60)))
        return np.column_stack([0.5 + t, -0.05 + draw(st.floats(-1, 1)) * t, np.full(len(t), 0.004)])
    if kind == "duplicated":
        return np.repeat(on_table_cloud(draw, 1), draw(st.integers(3, 50)), axis=0)
    if kind == "nonfinite":
        cloud = on_table_cloud(draw, 20)
        cloud[draw(st.integers(0, 19)), draw(st.integers(0, 2))] = draw(st.sampled_from([np.nan, np.inf, -np.inf]))
        return cloud
    if kind == "huge":
        return on_table_cloud(draw, 20) * draw(st.sampled_from([1e6, 1e150, -1e300]))
    if kind == "off_table":
        cloud = on_table_cloud(draw, 40)
        cloud[: draw(st.integers(1, 40)), 0] += draw(st.floats(0.2, 2.0))
        return cloud
    if kind == "dense":
        return on_table_cloud(draw, 200_000 if FUZZ else 20_000)
    return draw(arrays(np.float64, st.tuples(st.integers(0, 30), st.sampled_from([2, 3, 4])), elements=finite))


@settings(max_examples=examples(400))
@given(cloud=clouds())
def test_object_clouds_give_an_object_or_an_input_error(cloud):
    obj = clean(lambda: ThinObject.from_points(cloud, table_height=SCENE.table.height))
    if obj is not None:
        assert obj.points.shape[1] == 3 and np.all(np.isfinite(obj.points)) and obj.thickness > 0


@settings(max_examples=examples(60))
@given(cloud=clouds(), time_limit=st.sampled_from([0.05, 0.2]))
def test_planning_any_cloud_is_a_plan_an_input_error_or_a_clean_timeout(cloud, time_limit):
    obj = clean(lambda: ThinObject.from_points(cloud, table_height=SCENE.table.height))
    if obj is None:
        return
    # The object's centre of mass (the area centroid of its cloud: a triangulation, and scipy.spatial's import the
    # first time) is the object's, computed once and kept; the time limit bounds planning.
    clean(lambda: obj.centroid_xy)
    result = planned_clean(SCENE, obj, PlannerConfig(seed=1, time_limit_s=time_limit),
                           time_limit + SLACK_S + (0.0 if len(cloud) < 50_000 else 1.0))
    if result is not None:
        assert result.status in ("solved", "timeout")


@st.composite
def polygons(draw):
    """Table polygons: regular, clockwise, with collinear or duplicate vertices, self-intersecting, random."""
    kind = draw(st.sampled_from(["regular", "clockwise", "collinear", "duplicate", "bowtie", "random", "large"]))
    n = draw(st.integers(3, 40))
    angles = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    regular = np.column_stack([0.7 + 0.4 * np.cos(angles), 0.4 * np.sin(angles)])
    if kind == "regular":
        return regular
    if kind == "clockwise":
        return regular[::-1]
    if kind == "collinear":
        midpoints = (regular + np.roll(regular, -1, axis=0)) / 2
        return np.stack([regular, midpoints], axis=1).reshape(-1, 2)
    if kind == "duplicate":
        return np.repeat(regular, 2, axis=0)
    if kind == "bowtie":
        return np.array([[0.3, -0.3], [1.0, 0.3], [1.0, -0.3], [0.3, 0.3]])
    if kind == "large":
        count = 10_000 if FUZZ else draw(st.sampled_from([1000, 3000]))
        angles = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
        return np.column_stack([0.7 + 0.4 * np.cos(angles), 0.4 * np.sin(angles)])
    return draw(arrays(np.float64, st.tuples(st.integers(0, 12), st.just(2)), elements=finite))


@settings(max_examples=examples(500))
@given(vertices=polygons(), height=st.one_of(finite, st.sampled_from([math.nan, math.inf])))
def test_table_polygons_give_a_table_or_an_input_error(vertices, height):
    table = clean(lambda: SupportSurface.from_vertices(vertices, height))
    if table is not None:
        assert table.polygon.is_valid and table.polygon.area > 0


@settings(max_examples=examples(40))
@given(vertices=polygons())
def test_planning_on_any_valid_table_is_clean(vertices, tmp_path_factory):
    directory = tmp_path_factory.mktemp("table")
    rows = ", ".join(f"[{x!r}, {y!r}]" for x, y in np.asarray(vertices, dtype=float).reshape(-1, 2))
    (directory / "scene.toml").write_text(f"[table]\npolygon = [{rows}]\n")
    scene = clean(lambda: load_scene(directory / "scene.toml"))
    if scene is None:
        return
    obj = clean(lambda: load_object("square", table_height=scene.table.height, pose=(0.7, 0.0, 0.3)))
    if obj is None:
        return
    planned_clean(scene, obj, PlannerConfig(seed=2, time_limit_s=0.2), 0.2 + SLACK_S)


@st.composite
def holed_outlines(draw):
    """Outline TOML text with holes: inside, touching, outside, overlapping, degenerate."""
    size = draw(st.floats(0.01, 0.2))
    hole = draw(st.floats(0.001, 0.3))
    shift = draw(st.floats(-0.2, 0.2))
    holes = [[[shift - hole / 2, -hole / 2], [shift + hole / 2, -hole / 2], [shift + hole / 2, hole / 2], [shift - hole / 2, hole / 2]]]
    if draw(st.booleans()):
        holes.append(holes[0])  # a duplicate hole overlaps the first
    outline = [[-size, -size], [size, -size], [size, size], [-size, size]]
    return f"outline = {outline!r}\nholes = {holes!r}\nthickness = {draw(st.sampled_from([0.004, 0.0, -1.0]))!r}\n"


@settings(max_examples=examples(300))
@given(text=holed_outlines(), pose=st.tuples(finite, finite, finite))
def test_outlines_with_holes_give_an_object_or_an_input_error(text, pose, tmp_path_factory):
    path = tmp_path_factory.mktemp("outline") / "object.toml"
    path.write_text(text)
    obj = clean(lambda: load_object(path, table_height=0.0, pose=pose))
    if obj is not None:
        assert len(obj.points) >= 3 and np.all(np.isfinite(obj.points))


SCENE_KEYS = {
    "table": ["polygon", "height", "circle", "bogus"],
    "robot": ["urdf", "base_pose", "tip_link", "contact_links", "base_link", "fixed_joints", "package_dirs", "bogus"],
    "hand": ["tip_link", "tip_offset", "grasp_link", "grasp_offset", "contact_links", "params", "bogus"],
}


def toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value == math.inf else "-inf" if value == -math.inf else repr(value))
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(item) for item in value) + "]"
    if value is None:
        return '""'
    return repr(value)


@settings(max_examples=examples(600))
@given(
    section=st.sampled_from(sorted(SCENE_KEYS)),
    data=st.data(),
)
def test_scene_fields_give_a_scene_or_an_input_error(section, data, tmp_path_factory):
    key = data.draw(st.sampled_from(SCENE_KEYS[section]))
    value = data.draw(anything)
    base = "[table]\npolygon = [[0.35, -0.4], [1.05, -0.4], [1.05, 0.4], [0.35, 0.4]]\n"
    if section == "table":
        text = f"[table]\n{key} = {toml_value(value)}\n"
    else:
        text = base + f"[{section}]\n{key} = {toml_value(value)}\n"
    path = tmp_path_factory.mktemp("scene") / "scene.toml"
    path.write_text(text)
    clean(lambda: load_scene(path))


PARAMETERS = [name for name in PlannerConfig.__dataclass_fields__ if name not in ("planner",)]


@settings(max_examples=examples(800))
@given(name=st.sampled_from(PARAMETERS), value=anything)
def test_planner_parameters_give_a_config_or_an_input_error(name, value):
    config = clean(lambda: PlannerConfig(**{name: value}))
    if config is not None:
        assert getattr(config, name) == value or (isinstance(value, float) and math.isnan(value))


@settings(max_examples=examples(40))
@given(
    name=st.sampled_from(["beta0", "delta_beta", "dz_min", "dz_max", "u_star", "d_goal", "n_star", "max_joint_step",
                          "max_tip_step", "projection_iterations", "root_ik_attempts", "shortcut_attempts"]),
    scale=st.sampled_from([1e-9, 1e-3, 0.5, 2.0, 1e3, 1e9]),
)
def test_planning_with_parameters_at_and_beyond_their_limits_is_clean(name, scale):
    default = getattr(PlannerConfig().resolved(), name)
    value = type(default)(max(1, round(default * scale)) if isinstance(default, int) else default * scale)
    config = clean(lambda: PlannerConfig(seed=3, time_limit_s=0.2, **{name: value}))
    if config is None:
        return
    obj = load_object("square", table_height=SCENE.table.height, pose=(0.6, 0.0, 0.2))
    planned_clean(SCENE, obj, config, 0.2 + SLACK_S)


def test_a_collinear_cloud_is_an_input_error_not_a_timeout():
    t = np.linspace(0.0, 0.1, 50)
    cloud = np.column_stack([0.5 + t, 0.5 * t, np.full(len(t), 0.004)])
    obj = ThinObject.from_points(cloud, table_height=0.0)
    started = time.perf_counter()
    with pytest.raises(InputError, match="degenerate"):
        plan(SCENE, obj, PlannerConfig(seed=1, time_limit_s=5.0))
    assert time.perf_counter() - started < 1.0


@st.composite
def parameter_values(draw):
    """A planner parameter and a value anywhere from far below to far above its default, on a log scale
    (the validator's bounds fall somewhere in between), or at 0 and negative."""
    name = draw(st.sampled_from(["beta0", "delta_beta", "dz_min", "dz_max", "u_star", "d_goal", "n_star",
                                 "max_joint_step", "max_tip_step", "projection_tolerance", "projection_iterations",
                                 "root_ik_attempts", "shortcut_attempts", "grasp_standoff", "grasp_lift",
                                 "grasp_backoff", "contact_radius", "max_yaw_rate", "com_margin"]))
    default = getattr(PlannerConfig.for_scene(SCENE).resolved(SCENE), name)
    factor = draw(st.one_of(st.floats(-12, 12).map(lambda exponent: 10.0**exponent), st.sampled_from([0.0, -1.0])))
    value = default * factor
    return name, (max(0, min(round(value), 2**31)) if isinstance(default, int) else value)


@settings(max_examples=examples(60))
@given(parameter=parameter_values())
def test_planning_with_any_parameter_value_is_clean_and_verified(parameter):
    name, value = parameter
    config = clean(lambda: PlannerConfig.for_scene(SCENE, seed=4, time_limit_s=0.2, **{name: value}))
    if config is None:
        return
    obj = load_object("crescent", table_height=SCENE.table.height, pose=(0.55, -0.08, 0.4))
    planned_clean(SCENE, obj, config, 0.2 + SLACK_S)


@functools.lru_cache(maxsize=1)
def solved_plan_text() -> str:
    """A real solved plan's JSON (the crescent on the square table)."""
    obj = load_object("crescent", table_height=SCENE.table.height, pose=(0.55, -0.08, 0.4))
    result = plan(SCENE, obj, PlannerConfig.for_scene(SCENE, seed=1, time_limit_s=10.0))
    assert result.solved
    return result.to_json()


@st.composite
def plan_edits(draw):
    """1-3 edits of a plan's JSON as a hand or a faulty tool would make them: (path, how, value), a value
    anywhere in it replaced by anything, scaled, turned into another type, or deleted."""
    edits = []
    for _ in range(draw(st.integers(1, 3))):
        node, path = json.loads(solved_plan_text()), []
        while isinstance(node, (dict, list)) and node and (not path or draw(st.integers(0, 3)) > 0):
            key = draw(st.sampled_from(sorted(node) if isinstance(node, dict) else list(range(len(node)))))
            node = node[key]
            path.append(key)
        edit = draw(st.sampled_from(["replace", "scale", "retype", "delete"]))
        edits.append((tuple(path), edit, draw(anything) if edit == "replace" else
                      draw(st.sampled_from([-1.0, 1e6, 1.0 + 1e-9, 0.0, 1e300])) if edit == "scale" else None))
    return edits


def edited(edits) -> str:
    """The solved plan's JSON with ``edits`` (:func:`plan_edits`) made where they still apply."""
    data = json.loads(solved_plan_text())
    for path, edit, value in edits:
        parent = data
        try:
            for key in path[:-1]:
                parent = parent[key]
            node = parent[path[-1]]
        except (KeyError, IndexError, TypeError):
            continue  # an earlier edit took this place away
        if not isinstance(parent, (dict, list)):
            continue  # ... or made it a string (which indexes, but cannot be assigned to)
        if edit == "delete" and isinstance(parent, dict):
            del parent[path[-1]]
        elif edit == "scale" and isinstance(node, (int, float)) and not isinstance(node, bool):
            parent[path[-1]] = node * value
        elif edit == "retype":
            parent[path[-1]] = {"value": node} if not isinstance(node, dict) else [node]
        elif edit == "replace":
            parent[path[-1]] = value
    return json.dumps(data)


@settings(max_examples=examples(300))
@given(edits=plan_edits())
def test_an_edited_plan_file_is_read_checked_and_verified_cleanly(edits, tmp_path_factory):
    """What verify, export, execute and view do first with a plan file: read it, check its motion, verify it,
    export it; each gives a result or an InputError."""
    directory = tmp_path_factory.mktemp("plan")
    (directory / "plan.json").write_text(edited(edits))
    result = clean(lambda: PlanResult.load(directory / "plan.json"))
    if result is None:
        return
    clean(lambda: require_motion(result))
    verification = clean(lambda: verify(result))
    assert verification is None or isinstance(verification.ok, bool)
    if verification is not None and verification.ok:
        clean(lambda: export_plan(result, "csv", directory / "plan.csv"))


@st.composite
def scene_clouds(draw):
    """World-frame scene clouds: a table (tilted, small, in millimetres or not), objects on it, noise,
    flying pixels, holes, NaNs."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    half = draw(st.sampled_from([0.05, 0.2, 0.4]))
    spacing = 0.004
    axis = np.arange(-half, half, spacing)
    x, y = (grid.ravel() for grid in np.meshgrid(axis, axis))
    tilt = draw(st.sampled_from([0.0, 0.02, 0.2]))
    z = 0.7 + tilt * x
    for _ in range(draw(st.integers(0, 3))):  # thin rectangles
        cx, cy, size = rng.uniform(-half, half), rng.uniform(-half, half), rng.uniform(0.005, 0.1)
        inside = (np.abs(x - cx) < size) & (np.abs(y - cy) < size / 2)
        z = np.where(inside, z + draw(st.sampled_from([0.0005, 0.004, 0.02, 0.1])), z)
    cloud = np.column_stack([x, y, z + rng.normal(0.0, draw(st.sampled_from([0.0, 0.001, 0.005])), len(x))])
    outliers = int(draw(st.sampled_from([0.0, 0.01, 0.3])) * len(cloud))
    cloud[rng.choice(len(cloud), outliers, replace=False)] += rng.uniform(-0.3, 0.3, (outliers, 3))
    if draw(st.booleans()):
        cloud = cloud[rng.random(len(cloud)) > draw(st.sampled_from([0.5, 0.99]))]
    if draw(st.integers(0, 9)) == 0:
        cloud[rng.integers(0, len(cloud))] = np.nan
    return cloud * draw(st.sampled_from([1.0, 1.0, 1000.0]))


@settings(max_examples=examples(150))
@given(cloud=scene_clouds())
def test_perceiving_any_scene_cloud_is_clean(cloud):
    perception = clean(lambda: perceive(cloud, seed=0))
    if perception is not None:
        assert perception.objects, "a perception holds at least one object"
        for obj in perception.objects:
            assert np.isfinite(obj.points).all() and obj.thickness > 0


URDF = Path(SCENE.urdf_path)
# Bad text, or another link's name (a joint's parent or child renamed to one: loops, two parents).
BAD_TEXT = st.one_of(st.sampled_from(["nan", "inf", "-1", "0", "", "1 2", "1 2 3 4", "abc", "1e400", "0 0 nan",
                                      "package://nowhere/x.stl", "1" * 400]), st.text(max_size=8),
                     st.sampled_from(sorted(link.get("name") for link in ElementTree.parse(URDF).getroot().iter("link"))))


@st.composite
def edited_urdfs(draw):
    """The WAM + T42 URDF with 1-3 attributes set to bad text or elements removed."""
    root = ElementTree.parse(URDF).getroot()
    elements = [element for element in root.iter() if element is not root]
    for _ in range(draw(st.integers(1, 3))):
        element = draw(st.sampled_from(elements))
        if element.attrib and draw(st.integers(0, 3)) > 0:
            element.set(draw(st.sampled_from(sorted(element.attrib))), draw(BAD_TEXT))
        else:
            for parent in root.iter():
                if element in list(parent):
                    parent.remove(element)
                    break
            elements = [item for item in root.iter() if item is not root]
    return ElementTree.tostring(root, encoding="unicode")


@settings(max_examples=examples(150))
@given(text=edited_urdfs())
def test_an_edited_urdf_gives_a_robot_or_an_error_and_nothing_on_stderr(text, tmp_path_factory, capfd):
    directory = tmp_path_factory.mktemp("urdf")
    (directory / "robot.urdf").write_text(text)
    (directory / "scene.toml").write_text(Path(SCENE.source).read_text().replace('urdf = "wam_t42.urdf"', 'urdf = "robot.urdf"'))
    capfd.readouterr()
    scene = clean(lambda: load_scene(directory / "scene.toml"))
    robot = None if scene is None else clean(lambda: robot_model(scene))
    if robot is not None:
        assert robot.dof == len(robot.joint_names) and robot.dof > 0
    assert capfd.readouterr().err == "", "a library wrote to stderr"
