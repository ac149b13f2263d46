"""The parameter registry is the one list of planner parameters, and the paper preset is exactly the paper."""

import ast
import json
import re
from pathlib import Path

from typer.testing import CliRunner

from slideplan import _core, parameters
from slideplan.cli import app
from slideplan.plan.config import PARAMETERS, PlannerConfig
from slideplan.world.scenes import load_scene

ROOT = Path(__file__).resolve().parents[2]
NAMES = set(parameters.NAMES)


def test_every_parameter_has_a_paper_value_or_says_why_the_paper_leaves_it_open():
    for parameter in parameters.REGISTRY:
        assert parameter.paper is not None or parameter.paper_source.startswith("open"), parameter.name
        assert parameter.doc, parameter.name
    assert len(NAMES) == len(parameters.REGISTRY)


def test_planner_config_the_core_and_the_hand_keys_are_the_registry():
    assert PARAMETERS == parameters.NAMES
    core = _core.PlannerParams()
    for parameter in parameters.REGISTRY:
        assert getattr(core, parameter.name) == parameter.default, parameter.name
        assert isinstance(getattr(core, parameter.name), parameter.python_type), parameter.name
    published = _core.PlannerParams.as_published()
    assert {name: getattr(published, name) for name in parameters.PAPER_VALUES} == parameters.PAPER_VALUES
    assert set(parameters.HAND_NAMES) <= NAMES


def _literal_lists(tree):
    """Every tuple, list or set literal of strings in a module, with its line (a dict of values is a use)."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            yield node.lineno, {item.value for item in node.elts if isinstance(item, ast.Constant) and isinstance(item.value, str)}


def test_no_list_of_parameters_outside_the_registry():
    # A literal naming three or more parameters is a second list that can drift from the registry.
    offenders = []
    for path in sorted((ROOT / "python" / "slideplan").rglob("*.py")):
        for line, strings in _literal_lists(ast.parse(path.read_text(), str(path))):
            if len(strings & NAMES) >= 3:
                offenders.append(f"{path.relative_to(ROOT)}:{line}: {sorted(strings & NAMES)}")
    pattern = re.compile(r'"(' + "|".join(sorted(NAMES)) + r')"')
    for path in sorted((ROOT / "cpp").rglob("*.[ch]pp")):
        if path.name != "params.cpp":
            found = set(pattern.findall(path.read_text()))
            if len(found) >= 3:
                offenders.append(f"{path.relative_to(ROOT)}: {sorted(found)}")
    assert not offenders, offenders


def test_the_paper_preset_on_a_five_joint_arm_records_every_grasp_tolerance_as_zero(tmp_path):
    scene = load_scene("so101_square")
    assert scene.hand.params["grasp_yaw_tolerance"] > 0  # the hand's own value, which the preset must override
    out = tmp_path / "plan.json"
    result = CliRunner().invoke(app, ["plan", "--scene", "so101_square", "--object", "square", "--preset", "paper",
                                      "--time-limit", "1", "--json", str(out)])
    assert result.exit_code in (0, 1), result.output
    params = json.loads(out.read_text())["params"]
    for name in ("grasp_tilt_tolerance", "grasp_yaw_tolerance", "grasp_roll_tolerance"):
        assert params[name] == 0.0 and params["sources"][name] == "paper", name
    for name, value in parameters.PAPER_VALUES.items():
        assert params[name] == value, name


def test_a_pair_error_names_both_parameters_and_the_way_out():
    import pytest

    from slideplan.errors import InputError

    with pytest.raises(InputError) as caught:
        PlannerConfig.for_scene(load_scene("square"), beta0=0.05)
    assert caught.value.field == "delta_beta"
    assert "beta0 = 0.05" in str(caught.value) and "lower delta_beta or raise beta0" in str(caught.value)


def test_docs_parameter_table_is_the_registry():
    text = (ROOT / "docs" / "parameters.md").read_text()
    block = re.search(r"<!-- generated: parameters -->\n(.*?)\n<!-- /generated -->", text, re.S)
    assert block, "docs/parameters.md has no generated parameter table"
    assert block.group(1) == parameters.markdown_table(), "docs/parameters.md's table is stale: run docs/make_parameters.py"


def test_docs_simulation_table_is_the_registry_and_lists_every_setting():
    import dataclasses

    from slideplan.sim import conditions, registry
    from slideplan.sim.settings import ExecutionSettings

    text = (ROOT / "docs" / "simulation.md").read_text()
    block = re.search(r"<!-- generated: simulation -->\n(.*?)\n<!-- /generated -->", text, re.S)
    assert block and block.group(1) == registry.markdown_table(), "docs/simulation.md is stale: run docs/make_parameters.py"
    names = [row.name for row in registry.rows()]
    assert [field.name for field in dataclasses.fields(ExecutionSettings)] == names[:len(dataclasses.fields(ExecutionSettings))]
    drawn = set(conditions.RANDOM_RANGES) | set(conditions.HARD_RANGES)
    listed = " ".join(f"{row.name} {row.what} {' '.join(row.values.values())}" for row in registry.rows())
    assert all(name in listed for name in drawn), sorted(name for name in drawn if name not in listed)
    hard = {row.name: row.values["hard"] for row in registry.rows()}
    assert hard["table_friction"] == "U(0.15, 0.8)" and hard["reference_lag_s"] == "0.03"
