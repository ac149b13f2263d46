"""The measured MuJoCo facts the execution model is calibrated to (docs/physics-facts.md), asserted on
today's model (slideplan.sim.contacts.CURRENT: the object on feet, sleeping islands): each setting
the page says matters still matters, and the model still has what the page says it needs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely

from handmade_plan import DEPTH_M, build_plan
from slideplan import PlannerConfig, load_scene, plan
from slideplan.sim import ExecutionSettings, contacts, execute
from slideplan.sim import replay
from slideplan.sim.model import build_model, cloud_footprint
from slideplan.sim.runner import Runner
from slideplan.world.objects import load_object, load_outline, sample_pose_on_table


@pytest.fixture(scope="module")
def demo_plan():
    """The plan ``slideplan demo`` makes (crescent on the square table, seed 0)."""
    scene = load_scene("square")
    outline, _, _ = load_outline("crescent")
    pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(0))
    result = plan(scene, load_object("crescent", table_height=scene.table.height, pose=pose), PlannerConfig.for_scene(scene, seed=0))
    assert result.solved
    return result


def _within(execution) -> bool:
    return execution.position_error_m is not None and execution.position_error_m <= 0.005 and abs(execution.yaw_error_deg) <= 3.0


def test_the_model_has_the_calibrated_contact_settings():
    import mujoco

    built = build_model(build_plan(), ExecutionSettings())

    option = built.model.opt
    assert option.timestep == 0.001
    assert option.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and option.impratio == 10 and option.noslip_iterations == 10
    pad = built.pad_geom
    assert built.model.geom_condim[pad] == 6 and built.model.geom_priority[pad] == 1
    assert list(built.model.geom_solref[pad]) == [0.004, 1.0]
    assert np.allclose(built.model.geom_solimp[pad][:3], [0.3, 0.95, 0.001])
    assert np.isclose(built.model.geom_friction[pad][1], 0.01)  # torsional, m
    spring = built.spring_joint
    assert built.model.dof_armature[built.model.jnt_dofadr[spring]] == 0.002


def test_the_object_rests_on_contacts_spread_over_its_footprint():
    """Distributed contact: a flat object touches the table all over its footprint, not at one point."""
    import mujoco

    handmade = build_plan()
    # Awake: a resting object falls asleep (contacts.CURRENT.sleep) and then has no contacts to look at.
    built = build_model(handmade, ExecutionSettings(), contacts=dataclasses.replace(contacts.CURRENT, sleep=False))
    model, data = built.model, built.data
    runner = Runner(built, ExecutionSettings(), None)
    runner.press(np.asarray(handmade.trajectory[0]), DEPTH_M)  # pressed as the execution starts
    for _ in range(300):
        data.ctrl[built.arm_actuators] = handmade.trajectory[0]
        mujoco.mj_step(model, data)
    points = []
    for index in range(data.ncon):
        pair = {int(data.contact[index].geom1), int(data.contact[index].geom2)}
        if pair & built.table_geoms and pair & built.object_geoms:
            points.append(data.contact[index].pos[:2].copy())
    feet = [index for index in built.object_geoms if model.geom(index).name.startswith("slideplan_object_foot_")]
    assert len(points) >= 0.9 * len(feet) >= 9
    footprint = cloud_footprint(np.asarray(handmade.object["points"]))
    # The feet stand under the centres of the 1.25 cm cells: half a cell around them covers the footprint.
    spread = shapely.MultiPoint(points).convex_hull.buffer(ExecutionSettings().cell_size / 2, join_style="mitre")
    assert spread.intersection(footprint).area >= 0.95 * footprint.area
    # Every contact with the table is a foot's, one each: the boxes themselves do not touch it.
    touching = [geom for index in range(data.ncon) for geom in (int(data.contact[index].geom1), int(data.contact[index].geom2))
                if geom in built.object_geoms and ({int(data.contact[index].geom1), int(data.contact[index].geom2)} & built.table_geoms)]
    assert set(touching) <= set(feet) and len(touching) == len(set(touching))


@pytest.mark.physics
def test_the_demo_slide_needs_noslip_and_the_pads_torsional_friction(demo_plan, monkeypatch):
    """With noslip and condim 6 at the pad the demo's slide ends within 5 mm / 3 deg of Eq. 2; without
    noslip the object creeps under the finger, and with condim 3 at the pad it does not turn enough."""
    nominal = execute(demo_plan)
    assert _within(nominal), nominal.summary()

    monkeypatch.setattr(contacts, "ACTIVE", [dataclasses.replace(contacts.CURRENT, noslip_iterations=0)])
    no_noslip = execute(demo_plan)
    assert not _within(no_noslip), no_noslip.summary()
    print("nominal:", nominal.summary(), "| no noslip:", no_noslip.summary())
    monkeypatch.setattr(contacts, "ACTIVE", [contacts.CURRENT])

    real = replay.build_model

    def condim_3(*args, **kwargs):
        built = real(*args, **kwargs)
        built.model.geom_condim[built.pad_geom] = 3
        return built

    monkeypatch.setattr(replay, "build_model", condim_3)
    no_torsion = execute(demo_plan)
    assert not _within(no_torsion), no_torsion.summary()
    print("condim 3 at the pad:", no_torsion.summary())
