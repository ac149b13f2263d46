"""The closed loop judged by what happened, on constructed data: the world's verdict
(slideplan.checks.verdict) against what the camera saw, the hard setting's draws, the bounds' no-progress test,
the dev and eval task sets, and the report's statistics."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from slideplan import InputError, load_scene
from slideplan.loop.bounds import NO_PROGRESS_MOVE_M, NO_PROGRESS_TRAVEL_M, Progress
from slideplan.sim.conditions import (HARD_PUSH_COM_INSIDE_M, HARD_RANGES, Disturbance, camera_as_mounted,
                                            execution_settings, hard_push, push_candidates, setting_draws)
from slideplan.sim.settings import ExecutionSettings
from slideplan.perception.camera import Camera
from slideplan.checks.verdict import HOLD_HEIGHT_M, SAMPLE_GAP_S, Hold, HoldWatch, held, judge

TABLE_TOP = 0.75
U_STAR = 0.02


def hold(lowest_above_table: float, in_hand: bool = True, duration_s: float = 1.0, step_s: float = 0.01) -> Hold:
    times = np.arange(0.0, duration_s + 1e-9, step_s)
    return Hold(times, np.full(len(times), TABLE_TOP + lowest_above_table), np.full(len(times), in_hand), duration_s)


# --- the verdict: what happened, not what was seen ---------------------------------------------------------


def test_a_run_seen_overhanging_enough_whose_object_was_not_lifted_is_a_failure():
    seen_overhang_m = 0.035  # the camera says the slide ended well over the edge: the old verdict passed it
    assert seen_overhang_m >= U_STAR
    on_table = hold(0.0, in_hand=False)  # the fingers closed on air; the object lay on the table through the hold
    success, stage, why = judge(on_table, TABLE_TOP, ("grasp", "the grasp did not lift the object"))
    assert not success and stage == "grasp" and "did not lift" in why
    # Even with no failure reported on the way, the hold itself fails it.
    success, stage, why = judge(on_table, TABLE_TOP)
    assert not success and stage == "hold" and "out of the hand" in why


def test_a_run_seen_short_whose_object_was_lifted_and_held_is_a_success():
    seen_overhang_m = 0.0187  # a camera reading under u* (the open loop's old "slide" failures)
    assert seen_overhang_m < U_STAR
    lifted = hold(0.045)
    assert judge(lifted, TABLE_TOP) == (True, None, "")
    # The runner's own lift check cannot overrule the world either way.
    assert judge(lifted, TABLE_TOP, ("release", "the object fell off the table when the finger let go"))[0]


def test_an_object_dropped_or_sagging_during_the_hold_fails_it_there():
    dropped = hold(0.045)
    in_hand = dropped.in_hand.copy()
    in_hand[60:] = False
    ok, why = held(Hold(dropped.times, dropped.lowest_z, in_hand, 1.0), TABLE_TOP)
    assert not ok and "0.60 s" in why
    sagging = hold(0.045)
    lowest = sagging.lowest_z.copy()
    lowest[-1] = TABLE_TOP + HOLD_HEIGHT_M - 0.001
    ok, why = held(Hold(sagging.times, lowest, sagging.in_hand, 1.0), TABLE_TOP)
    assert not ok and "above the table top 1.00 s" in why
    assert held(hold(HOLD_HEIGHT_M), TABLE_TOP)[0]  # exactly 3 cm is enough


def test_a_hold_that_is_not_wholly_recorded_is_no_success():
    assert not held(None, TABLE_TOP)[0]
    assert held(hold(0.045, duration_s=0.5), TABLE_TOP)[0]  # a 0.5 s hold recorded whole
    short = hold(0.045)
    cut = Hold(short.times[:50], short.lowest_z[:50], short.in_hand[:50], 1.0)  # the run ended half way
    ok, why = held(cut, TABLE_TOP)
    assert not ok and "covers" in why
    gap = Hold(np.delete(short.times, range(20, 40)), np.delete(short.lowest_z, range(20, 40)),
               np.delete(short.in_hand, range(20, 40)), 1.0)
    assert not held(gap, TABLE_TOP)[0]


# --- the hard setting --------------------------------------------------------------------------------------


def test_a_held_object_whose_run_touched_an_obstacle_is_no_success_and_says_so():
    table = 0.7
    samples = [(t, table + 0.05, True) for t in np.arange(0.0, 1.001, 0.01)]
    hold = Hold.from_samples(samples, 1.0)
    touched = ("slide", "the robot (link3) touched obstacle 0 during the slide at t = 2.10 s")
    assert judge(hold, table) == (True, None, "")
    assert judge(hold, table, clutter=touched) == (False, "slide", touched[1])
    assert judge(None, table, ("grasp", "not lifted"), touched) == (False, "grasp", "not lifted")  # the run's own failure first


def test_the_environment_s_watch_is_the_run_s_rule_over_any_stretch_of_the_episode():
    table = 0.7
    watch = HoldWatch(table, duration_s=1.0)
    # Lifted 2.7 cm (a rule of half the 5 cm lift would call it held): never a success.
    assert not any(watch.add(t, table + 0.027, True) for t in np.arange(0.0, 3.0, 0.01))
    # 3.5 cm up from t = 3 s: held once a whole second of samples says so, the same verdict held() gives them.
    times = np.round(np.arange(3.0, 4.2, 0.01), 6)
    verdicts = [watch.add(t, table + 0.035, True) for t in times]
    first = times[verdicts.index(True)]
    assert first == pytest.approx(4.0)
    samples = [(t - 3.0, table + 0.035, True) for t in times if t <= first]
    assert held(Hold.from_samples(samples, 1.0), table) == (True, "")
    # Out of the hand for one sample, or a gap in the record: the hold starts again.
    for broken in ((table + 0.035, False), None):
        watch = HoldWatch(table, duration_s=1.0)
        clock = [watch.add(t, table + 0.035, True) for t in np.arange(0.0, 0.5, 0.01)]
        later = 0.5 + (2 * SAMPLE_GAP_S if broken is None else 0.0)
        if broken is not None:
            watch.add(0.5, *broken)
        again = [watch.add(t, table + 0.035, True) for t in np.round(np.arange(later + 0.01, later + 1.2, 0.01), 6)]
        assert not any(clock) and again.index(True) >= 99


def test_a_run_and_the_environment_sample_the_hold_often_enough_for_the_rule():
    from slideplan.sim import runner

    assert runner.HOLD_SAMPLE_EVERY * ExecutionSettings().timestep <= SAMPLE_GAP_S


def test_the_hard_setting_s_draws_are_deterministic_recorded_and_in_their_ranges():
    draws = [setting_draws("hard", seed) for seed in range(200)]
    assert setting_draws("hard", 7) == draws[7]
    assert draws[7] != draws[8]
    for name, (low, high) in HARD_RANGES.items():
        values = np.array([draw[name] for draw in draws])
        assert np.all((values >= low) & (values <= high)), name
        assert values.max() - values.min() > 0.8 * (high - low), name  # drawn over the range, not a corner of it
    assert all(draw["lag_s"] == 0.03 for draw in draws)
    positions = np.array([[draw[f"camera_d{axis}_m"] for axis in "xyz"] for draw in draws])
    turns = np.array([[draw[f"camera_r{axis}_deg"] for axis in "xyz"] for draw in draws])
    assert 0.004 < positions.std() < 0.006 and 0.4 < turns.std() < 0.6
    assert 0.4 < np.mean([draw["push"] for draw in draws]) < 0.6
    # The draws are what the execution runs with.
    settings = execution_settings("hard", draws[7], 0.01)
    assert (settings.table_friction, settings.pad_friction, settings.torsional_friction, settings.spring_scale,
            settings.reference_lag_s) == (draws[7]["table_friction"], draws[7]["pad_friction"],
                                          draws[7]["torsional_friction"], draws[7]["spring_scale"], 0.03)
    assert settings.object_density == pytest.approx(ExecutionSettings().object_density * draws[7]["mass_scale"])
    # The other settings keep their draws (the committed rows' physics).
    assert setting_draws("random", 3) == setting_draws("random", 3) and "lag_s" not in setting_draws("random", 3)


def test_the_camera_is_mounted_off_where_the_planner_believes_it_by_the_draws():
    believed = Camera((0.3, -0.3, 1.35), (0.6, 0.0, 0.75))
    draws = {"camera_dx_m": 0.004, "camera_dy_m": -0.003, "camera_dz_m": 0.002,
             "camera_rx_deg": 0.5, "camera_ry_deg": 0.0, "camera_rz_deg": -0.5}
    mounted = camera_as_mounted(believed, draws)
    assert np.allclose(np.subtract(mounted.position, believed.position), (0.004, -0.003, 0.002))
    turn = mounted.optical_pose()[:3, :3] @ believed.optical_pose()[:3, :3].T
    assert math.degrees(math.acos((np.trace(turn) - 1) / 2)) == pytest.approx(math.sqrt(0.5), rel=0.02)
    assert camera_as_mounted(believed, setting_draws("nominal", 1)) is believed


def test_a_push_that_would_leave_the_centre_of_mass_near_an_edge_is_redrawn():
    table = load_scene("square").table
    candidates = push_candidates(11, 1.5)
    assert candidates == push_candidates(11, 1.5)
    for push in candidates:
        assert 0.01 <= math.hypot(push.dx, push.dy) <= 0.04 and abs(push.dyaw) <= math.radians(15) and push.after_s == 1.5
    centre = np.asarray(table.polygon.centroid.coords[0])
    assert hard_push(candidates, table, centre) == candidates[0]  # far from every edge: the first draw
    # Just inside an edge: the push chosen keeps the centre of mass 1 cm inside.
    xs = np.asarray(table.polygon.exterior.coords)[:, 0]
    near = np.array([xs.max() - 0.02, centre[1]])
    chosen = hard_push(candidates, table, near)
    assert chosen is not None and table.edge_margin(near + (chosen.dx, chosen.dy)) >= HARD_PUSH_COM_INSIDE_M
    assert hard_push(candidates, table, np.array([xs.max() + 0.5, centre[1]])) is None  # none can
    assert isinstance(chosen, Disturbance)


def test_the_arm_s_lag_is_a_setting_that_must_not_be_negative():
    assert ExecutionSettings(reference_lag_s=0.0).reference_lag_s == 0.0
    with pytest.raises(InputError) as caught:
        ExecutionSettings(reference_lag_s=-0.01)
    assert caught.value.field == "reference_lag_s"
    with pytest.raises(InputError) as caught:
        ExecutionSettings(spring_scale=0.0)
    assert caught.value.field == "spring_scale"
    assert ExecutionSettings(spring_scale=0.5).spring_stiffness(0.01, 0.03) == pytest.approx(
        0.5 * ExecutionSettings().spring_stiffness(0.01, 0.03))


def test_an_unknown_setting_names_the_field():
    with pytest.raises(InputError) as caught:
        setting_draws("harder", 1)
    assert caught.value.field == "setting"


# --- bounds: no progress -----------------------------------------------------------------------------------


def test_a_finger_travelling_while_the_object_stays_is_no_progress():
    progress = Progress()
    travel = np.arange(0.0, 0.061, 0.005)
    stopped = [progress.update((0.5 + x, 0.0), (0.0, 0.0, 0.0)) for x in travel]
    assert any(stopped)
    assert NO_PROGRESS_TRAVEL_M - 1e-9 <= travel[stopped.index(True)] <= NO_PROGRESS_TRAVEL_M + 0.005


def test_a_finger_carrying_or_turning_the_object_makes_progress():
    carried = Progress()
    assert not any(carried.update((0.5 + x, 0.0), (x, 0.0, 0.0)) for x in np.arange(0.0, 0.2, 0.005))
    # Turning it about its centre of mass (at the origin here), the finger 5 cm out: the point under the
    # finger goes round with it although the centre of mass stays.
    turned = Progress()
    angles = np.arange(0.0, 2.0, 0.05)
    assert not any(turned.update((0.05 * math.cos(a), 0.05 * math.sin(a)), (0.0, 0.0, a)) for a in angles)
    # Unseen looks decide nothing.
    blind = Progress()
    assert not any(blind.update((0.5 + x, 0.0), None) for x in np.arange(0.0, 0.2, 0.005))
    assert NO_PROGRESS_MOVE_M < NO_PROGRESS_TRAVEL_M


# --- task sets ---------------------------------------------------------------------------------------------


def test_dev_and_eval_are_disjoint_and_eval_is_the_80_held_out_tasks():
    from slideplan.experiments import build_spec
    from slideplan.experiments.tasks import EVAL_SEED, task_set

    dev, held_out = build_spec("closed-loop").tasks, build_spec("closed-loop", task_set="eval").tasks
    assert len(dev) == 200 and len(held_out) == 80
    assert not {task.task_id for task in dev} & {task.task_id for task in held_out}
    assert not {task.object for task in dev} & {task.object for task in held_out}
    assert not {(task.x, task.y, task.yaw) for task in dev} & {(task.x, task.y, task.yaw) for task in held_out}
    assert {task.object for task in held_out} == {"Y", "A", "L", "E"}
    assert {task.scene for task in held_out} == {"square", "round", "triangle", "long"}
    assert {task_set(task) for task in dev} == {"dev"} and {task_set(task) for task in held_out} == {"eval"}
    assert build_spec("closed-loop", task_set="eval").seed == EVAL_SEED
    for bad, field in ((dict(figure="fig10", task_set="eval"), "set"), (dict(figure="closed-loop", task_set="test"), "set"),
                       (dict(figure="closed-loop", task_set="eval", seed=3), "seed")):
        with pytest.raises(InputError) as caught:
            build_spec(**bad)
        assert caught.value.field == field


def test_the_clutter_set_lies_clear_of_the_obstacles_and_runs_nominal_physics_only():
    from slideplan.experiments import build_spec
    from slideplan.experiments.tasks import CLUTTER_SCENES, SET_SETTINGS, task_set

    tasks = build_spec("closed-loop", task_set="clutter").tasks
    assert len(tasks) == 30 and {task.scene for task in tasks} == set(CLUTTER_SCENES)
    assert {task_set(task) for task in tasks} == {"clutter"} and SET_SETTINGS["clutter"] == ("nominal",)
    for task in tasks:
        scene, placed = load_scene(task.scene), task.placed_object()
        footprints = scene.footprints(scene.table.height + placed.thickness)
        assert scene.table.polygon.contains(placed.outline) and not placed.outline.intersects(footprints)


# --- the report --------------------------------------------------------------------------------------------


def _runs(outcomes: dict[str, list[tuple[bool, bool]]]) -> pd.DataFrame:
    """Rows of paired runs: per setting, (open ok, closed ok) per task."""
    rows = []
    for setting, pairs in outcomes.items():
        for index, pair in enumerate(pairs):
            for mode, ok in zip(("open", "closed"), pair):
                rows.append({"task_id": f"t{index}", "setting": setting, "mode": mode, "success": ok,
                             "failed_stage": None if ok else "grasp", "slide_stop": "", "build": "abc1234",
                             "draws": json.dumps({"pad_friction": 1.0, "table_friction": 0.4})})
    return pd.DataFrame(rows)


def test_the_report_gives_wilson_intervals_and_the_exact_mcnemar_test_of_the_paired_runs():
    from scipy.stats import binomtest

    from slideplan.experiments.closed_loop_report import mcnemar, report

    # Hard: the closed loop alone succeeds in 12 tasks, the open loop alone in 1, both in 5.
    runs = _runs({"hard": [(False, True)] * 12 + [(True, False)] + [(True, True)] * 5,
                  "nominal": [(True, True)] * 18})
    better, worse, p = mcnemar(runs[runs["setting"] == "hard"])
    assert (better, worse) == (12, 1) and p == pytest.approx(binomtest(12, 13, 0.5).pvalue) and p < 0.01
    assert mcnemar(runs[runs["setting"] == "nominal"]) == (0, 0, 1.0)
    runs.loc[(runs["setting"] == "hard") & (runs["mode"] == "open") & (runs["task_id"] == "t0"), "slide_stop"] = \
        "no_progress+replan_cap"
    # Task t12 (the open loop alone succeeded) drew a pad less grippy than the table: its closed run slipped.
    slipped = (runs["setting"] == "hard") & (runs["task_id"] == "t12")
    runs.loc[slipped, "draws"] = json.dumps({"pad_friction": 0.5, "table_friction": 0.6})
    runs.loc[slipped & (runs["mode"] == "closed"), "slide_stop"] = "slip"
    text = report({"dev": runs, "eval": None})
    assert "| hard | open | 0 | 0 | 0 | 12 | 0 | 0 | 1 | 1 | 0 | 0 |" in text  # failures by stage, then the bounds met
    assert "| hard | closed | 0 | 0 | 0 | 1 | 0 | 0 | 0 | 0 | 0 | 1 |" in text
    # The hard setting by friction: 17 tasks with the pad grippier than the table, one without.
    assert "| pad > table | closed | 17 | 17 (100.0%) |" in text and "| pad <= table | closed | 1 | 0 (0.0%) | 0.0-79.3% | 1 |" in text
    assert "| pad > table | open | 17 | 5 (29.4%) |" in text and "pad" not in text[:text.index("| hard |")]
    assert "| hard | closed | 18 | 17 (94.4%) |" in text and "| hard | open | 18 | 6 (33.3%) |" in text
    assert "**`eval`: not run yet.**" in text and "abc1234 (72 runs)" in text
    assert text.index("| nominal |") < text.index("| hard |")  # settings in their order


def test_the_experiment_s_set_option_refuses_what_it_does_not_know_naming_the_option(tmp_path):
    from typer.testing import CliRunner

    from slideplan.cli import app

    for arguments, option in ((["--set", "test"], "--set"), (["--set", "eval", "--seed", "2"], "--seed")):
        result = CliRunner().invoke(app, ["experiment", "closed-loop", *arguments, "--out", str(tmp_path / "out")])
        assert result.exit_code == 2 and result.output.startswith(f"slideplan: error: {option}:"), result.output
    assert not (tmp_path / "out").exists()


def test_every_bound_a_closed_loop_meets_is_recorded_and_a_cap_holds_after_a_no_progress_stop():
    from slideplan.loop.decisions import SlideLoop
    from slideplan.loop.bounds import MAX_REPLANS, MAX_SLIDE_S

    class Clock:
        now = 0.0

        def clock(self):
            return self.now

    arm = Clock()
    loop = SlideLoop(None, None, 0.0, 3, arm)
    assert not loop.capped() and loop.stopped == ""
    loop._met("no_progress")
    loop.replans = MAX_REPLANS
    assert loop.capped() and loop.stopped == "no_progress+replan_cap"
    loop.replans, arm.now = 0, MAX_SLIDE_S
    assert loop.capped() and loop.stopped == "no_progress+replan_cap+time_cap"
    assert loop.capped() and loop.stops.count("time_cap") == 1
