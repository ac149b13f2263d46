"""The closed loop's held-out eval2 set: its definition, and that it stays held out.

These tests read the set's definition (which objects and tables, where they lie, which seed) and
nothing else: no test plans, executes or tunes on its objects. They never name the objects either; the
names come from the set's folders (``slideplan.paths.held_out``).
"""

import re
from pathlib import Path

import pytest
import shapely

from slideplan.errors import InputError
from slideplan.experiments import build_spec
from slideplan.experiments.tasks import EVAL2_SEED, FIXED_SEEDS, TABLES, task_set
from slideplan.world.objects import load_outline
from slideplan.paths import builtin_objects, builtin_scenes, held_out
from slideplan.world.scenes import load_scene

REPO = Path(__file__).resolve().parents[2]
PERCEPTION_MIN_THICKNESS_M = 0.002  # the thinnest object the perception finds (docs/perception.md)


@pytest.fixture(scope="module")
def eval2():
    return build_spec("closed-loop", task_set="eval2").tasks


def test_eval2_is_eight_new_objects_on_the_four_tables_and_a_new_one_five_poses_each(eval2):
    objects, tables = held_out("objects", "eval2"), held_out("scenes", "eval2")
    assert len(objects) >= 8 and len(tables) >= 1
    assert len(eval2) == len(objects) * (len(TABLES) + len(tables)) * 5 >= 200
    assert {task.object for task in eval2} == set(objects)
    assert {task.scene for task in eval2} == set(TABLES) | set(tables)
    assert {task_set(task) for task in eval2} == {"eval2"}
    # Nothing of it is built in: whatever walks the bundled objects and scenes never meets it.
    assert not {name.split("/")[1] for name in objects} & set(builtin_objects())
    assert not {name.split("/")[1] for name in tables} & set(builtin_scenes())
    # A new seed, and new objects and poses: no task of another set shares them.
    others = build_spec("closed-loop").tasks + build_spec("closed-loop", task_set="eval").tasks
    assert EVAL2_SEED not in (0, *(seed for name, seed in FIXED_SEEDS.items() if name != "eval2"))
    assert not {task.object for task in others} & set(objects)
    assert not {(task.x, task.y, task.yaw) for task in others} & {(task.x, task.y, task.yaw) for task in eval2}
    for task in eval2:  # the whole object on its table at its initial pose
        assert load_scene(task.scene).table.polygon.contains(task.placed_object().outline)


def test_eval2_has_the_shapes_the_set_was_defined_to_have():
    outlines = {name: load_outline(name) for name in held_out("objects", "eval2")}
    centre_outside = [name for name, (outline, _, _) in outlines.items() if not outline.contains(outline.centroid)]
    assert len(centre_outside) >= 2  # the centre of mass off the material, as the L's
    thicknesses = [thickness for _, thickness, _ in outlines.values()]
    assert min(thicknesses) == pytest.approx(0.003) and min(thicknesses) > PERCEPTION_MIN_THICKNESS_M
    lengths = [max(b[2] - b[0], b[3] - b[1]) for b in (outline.bounds for outline, _, _ in outlines.values())]
    assert max(lengths) == pytest.approx(0.15, abs=0.01)
    # A narrow part: an opening by a disc of 6 mm radius cuts the outline in two.
    assert any(len(getattr(outline.buffer(-0.006), "geoms", [None])) > 1 for outline, _, _ in outlines.values())
    # The new table: a shape none of the four has (another number of sides).
    paper_sides = {len(load_scene(name).table.vertices) for name in TABLES}
    assert {len(load_scene(name).table.vertices) for name in held_out("scenes", "eval2")}.isdisjoint(paper_sides)


def test_eval2_s_seed_is_fixed_and_its_names_stay_inside_the_data_folder():
    assert build_spec("closed-loop", task_set="eval2").seed == EVAL2_SEED
    with pytest.raises(InputError) as caught:
        build_spec("closed-loop", task_set="eval2", seed=1)
    assert caught.value.field == "seed"
    with pytest.raises(InputError, match="not a built-in"):
        load_outline("eval2/../square")


def test_no_test_benchmark_or_example_names_an_eval2_object_or_table():
    names = [name.split("/")[1] for name in held_out("objects", "eval2") + held_out("scenes", "eval2")]
    quoted = re.compile("[\"'](" + "|".join(map(re.escape, names)) + ")[\"']|eval2/")
    this_file = Path(__file__).resolve()
    files = [path for folder in ("tests", "benchmarks", "examples") for path in (REPO / folder).rglob("*")
             if path.is_file() and path.suffix in {".py", ".toml", ".json", ".md", ".cpp", ".hpp"} and path != this_file]
    files += [path for path in (REPO / "data" / "lerobot").rglob("*") if path.is_file()]  # the demonstrations' draws
    assert files
    named = [f"{path.relative_to(REPO)}: {match.group(0)}" for path in files
             for match in [quoted.search(path.read_text(errors="replace"))] if match]
    assert not named, named
