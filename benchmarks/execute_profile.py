"""Profile of one MuJoCo episode with MuJoCo's own timers: where an execution's time goes.

Runs, in this process (one core), the demo plan's ``execute`` and one closed-loop ``run`` of the same
task (crescent on the square table, seed 0 pose), and reports per phase (slide, approach, close,
lift + hold; the closed loop's slide with its looks and moves): wall time, ``mj_step``'s share and
MuJoCo's own timers inside it (``data.timer``: collision broad/narrow phase, constraint (the solver
and the noslip pass), the rest), contacts per step (``data.ncon``), constraint rows (``data.nefc``),
solver iterations (``data.solver_niter[0]``), and outside ``mj_step``: the depth frames' rendering,
the tracking and re-planning (closed loop), and the Python between steps.

    python benchmarks/execute_profile.py [--closed-loop/--no-closed-loop] [--repeat 1]

Prints a Markdown block (the profile section of docs/benchmarks/execution.md).
"""

from __future__ import annotations

import argparse
import collections
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

import slideplan.sim.closed_loop as closed_loop  # noqa: E402
import slideplan.sim.replay as replay  # noqa: E402
import slideplan.loop.decisions as loop  # noqa: E402
import slideplan.loop.watch as watch  # noqa: E402
from slideplan import PlannerConfig, load_scene, plan  # noqa: E402
from slideplan.sim import contacts
from slideplan.sim import runner as runner_module
from slideplan.world.objects import load_object, load_outline, sample_pose_on_table  # noqa: E402
from slideplan.perception.tracking import Tracker  # noqa: E402

def demo_pose():
    """The pose ``slideplan demo`` puts the crescent at on the square table (seed 0)."""
    scene = load_scene("square")
    outline, _, _ = load_outline("crescent")
    return scene, sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(0))


def demo_plan():
    """The plan ``slideplan demo`` makes (crescent, square table, seed 0)."""
    scene, pose = demo_pose()
    obj = load_object("crescent", table_height=scene.table.height, pose=pose)
    return plan(scene, obj, PlannerConfig.for_scene(scene, seed=0))


TIMERS = [  # (label, timer): MuJoCo's own, accumulated over every mj_step
    ("step (all of mj_step)", mujoco.mjtTimer.mjTIMER_STEP),
    ("  position: kinematics", mujoco.mjtTimer.mjTIMER_POS_KINEMATICS),
    ("  position: inertia", mujoco.mjtTimer.mjTIMER_POS_INERTIA),
    ("  collision (all)", mujoco.mjtTimer.mjTIMER_POS_COLLISION),
    ("    broad phase", mujoco.mjtTimer.mjTIMER_COL_BROAD),
    ("    narrow phase", mujoco.mjtTimer.mjTIMER_COL_NARROW),
    ("  constraint rows (make)", mujoco.mjtTimer.mjTIMER_POS_MAKE),
    ("  constraint projection", mujoco.mjtTimer.mjTIMER_POS_PROJECT),
    ("  velocity", mujoco.mjtTimer.mjTIMER_VELOCITY),
    ("  actuation", mujoco.mjtTimer.mjTIMER_ACTUATION),
    ("  constraint solver + noslip", mujoco.mjtTimer.mjTIMER_CONSTRAINT),
    ("  advance (integrator)", mujoco.mjtTimer.mjTIMER_ADVANCE),
]


class Profile:
    """Per-step records and per-phase MuJoCo timers, filled by the patched functions below."""

    def __init__(self) -> None:
        self.phase = "setup"
        self.steps = collections.defaultdict(list)  # phase -> [(step wall s, ncon, nefc, niter)]
        self.wall = collections.defaultdict(float)  # phase -> wall s of its follow calls
        self.timers = collections.defaultdict(lambda: np.zeros(len(TIMERS)))
        self.outside = collections.defaultdict(float)  # rendering, tracking + planning: wall s
        self.data = None
        self.grasp_index = 0

    def timer_now(self) -> np.ndarray:
        return np.array([self.data.timer[timer].duration for _, timer in TIMERS]) if self.data is not None else np.zeros(len(TIMERS))


ACTIVE: list[Profile] = [Profile()]  # the profile the patched functions fill


def install() -> None:
    """Once: patch mj_step, Runner.follow/slide/grasp, build_model and the closed loop's rendering and planning."""
    real_step = mujoco.mj_step

    def step(model, data, *args):
        started = time.perf_counter()
        real_step(model, data, *args)
        ACTIVE[0].steps[ACTIVE[0].phase].append((time.perf_counter() - started, data.ncon, data.nefc, int(data.solver_niter[0])))

    mujoco.mj_step = step

    def capture(build):
        def built(*args, **kwargs):
            model = build(*args, **kwargs)
            ACTIVE[0].data = model.data
            return model
        return built

    replay.build_model = capture(replay.build_model)
    closed_loop.build_model = capture(closed_loop.build_model)

    follow, slide, grasp = runner_module.Runner.follow, runner_module.Runner.slide, runner_module.Runner.grasp
    grasp_calls = ["approach", "close", "lift + hold"]

    def timed_follow(self, *args, **kwargs):
        phase = ACTIVE[0].phase
        if phase == "grasp":
            phase = grasp_calls[min(ACTIVE[0].grasp_index, 2)]
            ACTIVE[0].grasp_index += 1
        elif phase == "setup":
            phase = "move (closed loop)"
        saved, ACTIVE[0].phase = ACTIVE[0].phase, phase
        before, started = ACTIVE[0].timer_now(), time.perf_counter()
        try:
            return follow(self, *args, **kwargs)
        finally:
            ACTIVE[0].wall[phase] += time.perf_counter() - started
            ACTIVE[0].timers[phase] += ACTIVE[0].timer_now() - before
            ACTIVE[0].phase = saved

    def timed_slide(self, *args, **kwargs):
        saved, ACTIVE[0].phase = ACTIVE[0].phase, "slide"
        try:
            return slide(self, *args, **kwargs)
        finally:
            ACTIVE[0].phase = saved

    def timed_grasp(self, approach, *args, **kwargs):
        saved, ACTIVE[0].phase = ACTIVE[0].phase, "grasp"
        ACTIVE[0].grasp_index = 0 if len(approach) else 1
        try:
            return grasp(self, approach, *args, **kwargs)
        finally:
            ACTIVE[0].phase = saved

    runner_module.Runner.follow, runner_module.Runner.slide, runner_module.Runner.grasp = timed_follow, timed_slide, timed_grasp

    def outside(name, function):
        def timed(*args, **kwargs):
            started = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                ACTIVE[0].outside[(ACTIVE[0].phase, name)] += time.perf_counter() - started
        return timed

    closed_loop.camera_depth = outside("depth frame rendering", closed_loop.camera_depth)
    closed_loop.noisy_depth = outside("depth frame noise", closed_loop.noisy_depth)
    closed_loop.plan = outside("planning", closed_loop.plan)  # the first plan
    for module in (watch, loop):  # the re-plans and a new contact's plan, each verified
        module.plan_checked = outside("planning", module.plan_checked)
    Tracker.track = outside("tracking", Tracker.track)
    Tracker.locate = outside("tracking", Tracker.locate)


def report(title: str, profile: Profile, total_wall: float, sim_time: float) -> list[str]:
    lines = [f"### {title}", "", f"{sim_time:.2f} s simulated in {total_wall:.2f} s wall (instrumented): "
             f"{sim_time / total_wall:.2f}x real time.", ""]
    phases = [phase for phase in ("slide", "move (closed loop)", "approach", "close", "lift + hold") if phase in profile.wall]
    lines += ["| phase | steps | wall s | mj_step s | us/step | ncon median (max) | nefc median | solver iterations median (p90) |",
              "|---|---|---|---|---|---|---|---|"]
    for phase in phases:
        rows = np.array(profile.steps[phase], dtype=float).reshape(-1, 4)
        if not len(rows):
            continue
        lines.append(f"| {phase} | {len(rows)} | {profile.wall[phase]:.2f} | {rows[:, 0].sum():.2f} | {1e6 * rows[:, 0].mean():.0f} | "
                     f"{np.median(rows[:, 1]):.0f} ({rows[:, 1].max():.0f}) | {np.median(rows[:, 2]):.0f} | "
                     f"{np.median(rows[:, 3]):.0f} ({np.percentile(rows[:, 3], 90):.0f}) |")
    lines += ["", "MuJoCo's timers (`data.timer`, s, per phase; indented ones are parts of the step):", "",
              "| timer | " + " | ".join(phases) + " | all | share of step |", "|---|" + "---|" * (len(phases) + 2)]
    total = sum((profile.timers[phase] for phase in phases), np.zeros(len(TIMERS)))
    for index, (label, _) in enumerate(TIMERS):
        lines.append(f"| {label} | " + " | ".join(f"{profile.timers[phase][index]:.2f}" for phase in phases)
                     + f" | {total[index]:.2f} | {100 * total[index] / max(total[0], 1e-12):.0f}% |")
    stepped = sum(profile.wall.values())
    in_step = sum(np.array(profile.steps[phase], dtype=float).reshape(-1, 4)[:, 0].sum() for phase in profile.steps)
    outside = sum(profile.outside.values())
    lines += ["", "Where the wall time went:", "",
              f"- `mj_step`: {in_step:.2f} s ({100 * in_step / total_wall:.0f}%)"]
    for (phase, name), seconds in sorted(profile.outside.items()):
        lines.append(f"- {name} (during {phase}): {seconds:.2f} s ({100 * seconds / total_wall:.0f}%)")
    lines += [f"- Python between steps (the controller, the checks, the profiler's own bookkeeping): "
              f"{stepped - in_step - outside:.2f} s ({100 * (stepped - in_step - outside) / total_wall:.0f}%)",
              f"- outside the stepping (building the model, timing the paths, planning before the first step, IK of the lift): "
              f"{total_wall - stepped:.2f} s ({100 * (total_wall - stepped) / total_wall:.0f}%)", ""]
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--closed-loop", action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument("--task", type=int, default=None, help="profile this task of the execution set instead of the demo")
    parser.add_argument("--model", choices=("current", "legacy"), default="current", help="the contact model (slideplan.sim.contacts)")
    args = parser.parse_args()
    contacts.ACTIVE[0] = contacts.LEGACY if args.model == "legacy" else contacts.CURRENT
    if args.task is None:
        result = demo_plan()
    else:
        from slideplan.experiments import build_spec
        from slideplan.experiments.tasks import cached_scene
        task = build_spec("execution").tasks[args.task]
        result = plan(cached_scene(task.scene), task.placed_object(), task.planner_config())
    assert result.solved, "the plan did not solve"
    # Uninstrumented first: the profiler's own per-step bookkeeping costs a few microseconds a step.
    plain = replay.execute(result)
    print(f"execute, uninstrumented: {plain.summary()}", flush=True)
    install()
    profile = ACTIVE[0] = Profile()
    started = time.perf_counter()
    execution = replay.execute(result)
    lines = report(f"`execute` of {'the demo plan' if args.task is None else f'task {args.task}'}, model {args.model}", profile, time.perf_counter() - started, execution.sim_time_s)
    lines.insert(2, f"Uninstrumented, the same plan: {plain.sim_time_s:.2f} s simulated in {plain.wall_time_s:.2f} s wall "
                    f"({plain.sim_time_s / plain.wall_time_s:.2f}x). Outcome: {execution.summary()}")
    if args.closed_loop:
        scene, pose = demo_pose()
        profile2 = ACTIVE[0] = Profile()
        started = time.perf_counter()
        run = closed_loop.run("square", "crescent", pose, seed=0)
        lines += [""] + report(f"closed-loop `run` (square, crescent, the demo's pose, seed 0): {run.summary()}", profile2,
                               time.perf_counter() - started, run.sim_time_s)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
