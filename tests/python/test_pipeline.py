"""The one pipeline (slideplan.checks.pipeline): plan, verify, mark; margins raised for a perceived object."""

import dataclasses

import pytest

from slideplan.checks import pipeline
from slideplan.world.objects import load_object
from slideplan.plan.config import PlannerConfig
from slideplan.world.scenes import load_scene
from slideplan.checks.verify import Verification


@pytest.fixture(scope="module")
def task():
    scene = load_scene("square")
    return scene, load_object("crescent", table_height=scene.table.height, pose=(0.55, -0.08, 0.4))


def test_a_solved_plan_comes_verified(task):
    checked = pipeline.plan_checked(*task, PlannerConfig(seed=1, time_limit_s=20))
    assert checked.ok and checked.result.status == "solved"
    assert checked.verification is not None and checked.verification.ok


def test_a_plan_the_verifier_rejects_is_marked_invalid_with_its_violations(task, monkeypatch):
    monkeypatch.setattr(pipeline, "verify", lambda result, **_: Verification(["trajectory[3]: a planted violation"]))
    checked = pipeline.plan_checked(*task, PlannerConfig(seed=1, time_limit_s=20))
    assert not checked.ok and checked.result.status == "invalid"
    assert checked.verification.violations == ["trajectory[3]: a planted violation"]
    assert len(checked.result.trajectory) > 0  # the plan is kept, to be looked at


def test_a_plan_not_solved_is_not_verified(task, monkeypatch):
    def never(result, **_):
        raise AssertionError("an unsolved plan was verified")

    monkeypatch.setattr(pipeline, "verify", never)
    checked = pipeline.plan_checked(*task, PlannerConfig(seed=1, time_limit_s=1e-6))  # cut off before it starts
    assert checked.result.status == "timeout" and checked.verification is None and not checked.ok


def test_a_perceived_object_plans_with_margins_raised_by_the_edge_uncertainty(task):
    config = PlannerConfig.for_scene(task[0])
    raised = pipeline.for_perceived(config, 0.004)
    assert raised.u_star == pytest.approx(config.u_star + 0.004)
    assert raised.grasp_standoff == pytest.approx(config.grasp_standoff + 0.004)
    assert dataclasses.replace(raised, u_star=config.u_star, grasp_standoff=config.grasp_standoff) == config
