"""Fixtures shared by the test modules: the grasp-map store, a planned plan and the hand-made one."""

import os

import pytest

from slideplan.world.objects import load_object
from slideplan.plan.config import PlannerConfig
from slideplan.plan.planner import plan
from slideplan.world.scenes import load_scene


@pytest.fixture(scope="session", autouse=True)
def grasp_map_store(tmp_path_factory):
    """Stored grasp maps go to a folder of this run (subprocesses inherit it), never the user's cache."""
    folder = tmp_path_factory.mktemp("cache")
    os.environ["SLIDEPLAN_CACHE_DIR"] = str(folder)
    return folder


@pytest.fixture(scope="session")
def handmade_plan():
    """The hand-made slide of handmade_plan.build_plan, built once for every module (read it, or copy it
    before changing it: copy.deepcopy or dataclasses.replace)."""
    from handmade_plan import build_plan

    return build_plan()


@pytest.fixture(scope="session")
def planned():
    """A real, timed planner result (the L on the square table): jagged, dense, with a long approach."""
    scene = load_scene("square")
    obj = load_object("L", table_height=scene.table.height, pose=(0.6, 0.0, 0.5))
    result = plan(scene, obj, PlannerConfig(seed=1, time_limit_s=20))
    assert result.solved and result.timing is not None
    return result
