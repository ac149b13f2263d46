"""The public Python API refuses wrong argument types with an InputError naming the argument (once 23
of 66 wrong-type calls raised AttributeError, TypeError or IndexError from deep inside)."""

import numpy as np
import pytest

from slideplan.sim.closed_loop import run
from slideplan.errors import InputError
from slideplan.sim import execute
from slideplan.world.objects import ThinObject, load_object
from slideplan.plan.config import PlannerConfig
from slideplan.plan.result import PlanResult
from slideplan.plan.planner import plan
from slideplan.world.scenes import load_scene
from slideplan.checks.verify import verify

SCENE = load_scene("square")
OBJECT = load_object("crescent", table_height=SCENE.table.height, pose=(0.55, -0.08, 0.4))


@pytest.mark.parametrize("call, field", [
    (lambda: plan(None, OBJECT), "scene"),
    (lambda: plan("square", OBJECT), "scene"),
    (lambda: plan(SCENE, None), "obj"),
    (lambda: plan(SCENE, "crescent"), "obj"),
    (lambda: plan(SCENE, OBJECT, 3), "config"),
    (lambda: PlannerConfig.for_scene(None), "scene"),
    (lambda: verify(None), "result"),
    (lambda: verify("plan.json"), "result"),
    (lambda: execute(None), "result"),
    (lambda: load_scene(None), "name_or_path"),
    (lambda: load_scene(3), "name_or_path"),
    (lambda: load_object(None, table_height=0.0), "spec"),
    (lambda: load_object(3, table_height=0.0), "spec"),
    (lambda: PlanResult.from_json(None), "text"),
    (lambda: PlanResult.from_json(3), "text"),
    (lambda: PlanResult.load(None), "path"),
    (lambda: run(None, "crescent", (0.55, -0.08, 0.4)), "name_or_path"),
    (lambda: run("square", None, (0.55, -0.08, 0.4)), "spec"),
    (lambda: ThinObject(np.zeros((10, 2)), 0.01), "points"),
    (lambda: ThinObject(None, 0.01), "points"),
    (lambda: ThinObject(np.full((10, 3), np.nan), 0.01), "points"),
    (lambda: ThinObject(np.ones((10, 3)), "thin"), "thickness"),
    (lambda: ThinObject(np.ones((10, 3)), -0.01), "thickness"),
])
def test_a_wrong_argument_is_an_input_error_naming_it(call, field):
    with pytest.raises(InputError) as error:
        call()
    assert error.value.field == field, error.value
    assert "expected" in error.value.problem or "must be" in error.value.problem, error.value
