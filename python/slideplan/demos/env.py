"""``slideplan/SlideToEdge-v1``: the slide, grasp and lift as a Gymnasium environment, to evaluate the
policies trained on ``slideplan demos`` datasets in the same physics.

An episode starts as a demonstration does (:class:`slideplan.sim.closed_loop.Start`: the same draw for the same
seed, the object perceived, the first plan made, the finger pressed at its first contact). A step holds an
action for ``1 / fps`` simulated seconds. Success is the world's verdict, the rule and sampling of every run
(:class:`slideplan.checks.verdict.HoldWatch`): the object in the hand, its lowest point at least 3 cm above
the table top, through a whole hold, sampled every 10 ms of the simulation.
"""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .._environments import register
from ..checks.verdict import HoldWatch
from ..loop.bounds import MAX_REPLANS, MAX_SLIDE_S
from ..sim.closed_loop import Start
from ..sim.episode import Episode
from ..sim.conditions import execution_settings, hard_push, push_candidates
from ..errors import InputError
from ..sim.model import DEPTH_CAMERA, enable_hand_collisions
from ..sim.runner import CLOSE_S, HOLD_SAMPLE_EVERY, SETTLE_S, instability, timing_options
from ..world.geometry import Ending
from ..plan.motions import Unreachable, plan_times, reach_path, reference, rest_to_rest, straight_up
from ..loop.decisions import plan_anew
from ..plan.robot import robot_model
from ..sim.rendering import camera_depth
from ..world.scenes import Scene, load_scene
from ..plan.timing import resolve_limits
from ..transforms import compose_planar, planar_motion, rotation_2d, rotation_vector, row_to_pose
from ..loop.watch import pose_error
from .draw import draw
from .frames import CameraSpec, Frames, state_names
from .generate import Request, front_points

OBS_TYPES = ("state", "pixels", "depth")
ACTION_TYPES = ("joint", "ee_delta")
REWARD_TYPES = ("sparse", "dense")
# The fastest fingertip an ee_delta action may ask for (m/s, rad/s; a step's bound is this over fps): above
# the expert's plans' fastest (1.07 m/s and 3.1 rad/s on the default scene's draws 0-8), so that the
# demonstrations' ee_delta actions lie in the action space.
_EE_SPEED = (1.2, 3.5)
_POSTURE_GAIN = 0.2  # the share of its way back to the reset posture an ee_delta step takes in the null space
# As long as a run may take: its slide bounded by slideplan.loop.bounds (60 s), then the approach, grasp, lift and hold.
EPISODE_S = MAX_SLIDE_S + 20.0
_FELL_M = 0.05  # the object's centre this far below the table top: off the table, the episode over
# The fingertip this far from where the expert's reference has it (m, rad): a policy took the arm elsewhere.
_OFF_REFERENCE = (0.03, 0.3)
# The object this far from where its plan leaves it when the slide ends (m, rad): the plan's grasp is for
# elsewhere. Unpushed slides end within 3 mm and 3.3 deg (the default scene's draws 0-8).
_OFF_PLAN = (0.01, math.radians(10.0))


class SlideToEdgeEnv(gym.Env):
    """Slide a thin object to a table edge with one fingertip, then grasp it from the side and lift it.

    ## Description

    A thin object lies flat on a table, too flat to grasp from above. The arm (by default the WAM with the
    Yale T42 hand of the square table's scene) presses one fingertip on the object and slides it until part
    of it overhangs an edge, then closes its hand on the overhang and lifts. The physics is `slideplan
    execute`'s MuJoCo model: a compliant finger, the object on small feet, the table as its prism, the
    scene's clutter. The environment evaluates policies trained on `slideplan demos` datasets, which record
    the same episodes.

    ## Action Space

    ``action_type="joint"``: ``Box(dof + 1)``, each arm joint's servo target (rad or m, within the URDF's
    limits) and the gripper's closing (0 open .. 1 closed; above 0.5 the hand closes). ``"ee_delta"``:
    ``Box(7)``, the fingertip's step in the world (dx, dy, dz m, a rotation vector rad, at most 1.2 m/s and
    3.5 rad/s over a step) and the gripper. A step holds the action for ``1 / fps`` simulated seconds.

    ## Observation Space

    ``obs_type="state"``: ``agent_pos`` (the joints, the fingertip's pose, the gripper: the datasets'
    ``observation.state``) and ``environment_state`` (the object's true x, y, yaw, z). ``"pixels"``:
    ``pixels`` (``{"front": RGB}``, ``image_size``: the datasets' ``observation.images.front`` once LeRobot
    maps its keys) and ``agent_pos``. ``"depth"``: ``depth`` (the scene
    camera's depth in m, 0 where nothing is seen) and ``agent_pos``.

    ## Rewards

    ``reward_type="sparse"``: 1 on the step that succeeds, else 0. ``"dense"``: the overhang's progress to
    u* (0..1), less ten times the centre of mass's shortfall inside the edge (m), plus the lift's progress
    (0..1), and 1 more on success.

    ## Starting State

    ``reset(seed=s)`` draws an object (of ``objects``), a pose wholly on the table and clear of clutter, and
    the setting's physics from ``s`` alone, perceives the object with the depth camera (where the robot it
    sees puts the camera: :mod:`slideplan.sim.calibration`), plans, and presses the finger at the plan's
    first contact: the episode a dataset calls seed ``s``. A draw that cannot be
    planned is drawn again from the next seed (``info["redrawn"]``).

    ## Episode End

    Terminated on success (the world's verdict of every run, :class:`slideplan.checks.verdict.HoldWatch`:
    the object in the hand, its lowest point 3 cm above the table top, through a whole 1 s hold, sampled
    every 10 ms), when the object falls off the table, or when the simulation goes unstable; truncated after
    ``max_episode_steps``. The last step's ``info["end"]`` says which (``success``, ``fell``,
    ``simulation``, ``time_limit``); a step after the end is refused.

    ## Arguments

    - ``scene``: a built-in scene name or a scene TOML.
    - ``objects``: the objects reset draws from (as ``slideplan demos --objects``).
    - ``setting``: ``nominal``, ``stress``, ``random`` or ``hard`` (its physics and, when drawn, its push
      mid-slide, as a run's: ``info["pushed"]`` on the step it happens).
    - ``obs_type``, ``action_type``, ``reward_type``: as above.
    - ``render_mode``: None or ``rgb_array`` (the front camera).
    - ``fps``: steps per simulated second (a whole number >= 1).
    - ``image_size``: (width, height) of the pixels and depth images.
    - ``max_episode_steps``: steps before the episode is truncated (default: :data:`EPISODE_S` at ``fps``;
      ``gym.make`` registers 800, the default at 10 steps a second).

    ## Version History

    - v1: the benchmark's protocol frozen (:mod:`slideplan.benchmark.protocol`: its tiers' tasks in
      ``data/benchmark/slide_to_edge.toml``, scored by ``slideplan eval``); the front camera frames the
      hand's reach past the table's edges too (v0's framed the table alone, and the hand left the frame as it
      grasped). The suffix changes with anything that changes a score on it.
    - v0: ``pixels`` is ``{"front": RGB}`` at 256 x 256 and ``task_description`` the episode's own, as the
      datasets have them; success is the runs' verdict (3 cm, a whole hold sampled every 10 ms); releases before 0.2 judged
      2.5 cm at each step; the object is perceived through the camera the robot in view puts (releases
      before 0.2 perceived through the camera where it was believed to be). Still made, with gymnasium's
      warning that v1 exists.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, scene: str | Scene = "square", objects: tuple[str, ...] = Request.objects, setting: str = "nominal",
                 obs_type: str = "state", action_type: str = "joint", reward_type: str = "sparse",
                 render_mode: str | None = None, fps: int = 10, image_size: tuple[int, int] = (256, 256),
                 max_episode_steps: int | None = None) -> None:
        for name, value, allowed in (("obs_type", obs_type, OBS_TYPES), ("action_type", action_type, ACTION_TYPES),
                                     ("reward_type", reward_type, REWARD_TYPES),
                                     ("render_mode", render_mode, (None, "rgb_array"))):
            if value not in allowed:
                raise InputError(f"must be one of {', '.join(map(str, allowed))}, got {value!r}", field=name)
        if isinstance(fps, bool) or not isinstance(fps, int) or fps < 1:
            raise InputError(f"must be a whole number of steps per simulated second >= 1, got {fps!r}", field="fps")
        if (len(tuple(image_size)) != 2 or any(isinstance(side, bool) or not isinstance(side, int) or side < 1
                                                for side in image_size)):
            raise InputError(f"must be (width, height) in whole pixels >= 1, got {image_size!r}", field="image_size")
        self.scene = scene if isinstance(scene, Scene) else load_scene(scene)
        self.objects, self.setting, self.fps = tuple(objects), setting, int(fps)
        self.obs_type, self.action_type, self.reward_type, self.render_mode = obs_type, action_type, reward_type, render_mode
        self.image_size = tuple(image_size)
        self._max_episode_steps = int(max_episode_steps or round(EPISODE_S * self.fps))
        self.metadata = {**self.metadata, "render_fps": self.fps}
        robot = robot_model(self.scene)
        self.dof, self.lower, self.upper = robot.dof, np.asarray(robot.lower_limits), np.asarray(robot.upper_limits)
        self.task_description = f"slide the object to the edge of the {self.scene.name} table, then grasp and lift it"
        self.observation_space = self._observation_space()
        if action_type == "joint":
            self.action_space = spaces.Box(np.append(self.lower, 0.0).astype(np.float32),
                                           np.append(self.upper, 1.0).astype(np.float32), dtype=np.float32)
        else:
            step = np.array([_EE_SPEED[0] / self.fps] * 3 + [_EE_SPEED[1] / self.fps] * 3 + [1.0], dtype=np.float32)
            self.action_space = spaces.Box(np.append(-step[:6], 0.0).astype(np.float32), step, dtype=np.float32)
        self._world = None

    def _observation_space(self) -> spaces.Dict:
        agent = spaces.Box(-np.inf, np.inf, (len(state_names(["q"] * self.dof)),), dtype=np.float64)
        width, height = self.image_size
        if self.obs_type == "state":
            return spaces.Dict({"agent_pos": agent, "environment_state": spaces.Box(-np.inf, np.inf, (4,), dtype=np.float64)})
        if self.obs_type == "pixels":
            front = spaces.Box(0, 255, (height, width, 3), dtype=np.uint8)
            return spaces.Dict({"pixels": spaces.Dict({"front": front}), "agent_pos": agent})
        return spaces.Dict({"depth": spaces.Box(0.0, np.inf, (height, width, 1), dtype=np.float32), "agent_pos": agent})

    # ---- an episode ----

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Draw the episode of ``seed`` (:func:`slideplan.demos.draw.draw`, as ``slideplan demos`` does), perceive
        and plan, and press the finger at the plan's first contact. A draw that cannot be planned is drawn again
        from the next seed (said in ``info["redrawn"]``)."""
        super().reset(seed=seed)
        self.close()
        episode_seed = int(self.np_random.integers(2**31)) if seed is None else int(seed)
        for attempt in range(20):
            drawn = draw(self.scene, self.objects, self.setting, episode_seed + attempt)
            start = Start.of(self.scene, drawn.object, drawn.pose, seed=drawn.seed, setting=self.setting)
            if start.first is not None:
                break
        else:
            raise RuntimeError(f"no plan for 20 draws from seed {episode_seed}")
        self._world = _World(self.scene, start, self.setting, self.fps, self.image_size, self.obs_type)
        self._steps, self._done = 0, False
        self.task_description = drawn.task(self.scene.name)  # the dataset's task text for the same episode
        return self._observation(), {**self._info(), "redrawn": attempt, "object": drawn.object, "pose": drawn.pose,
                                     "seed": drawn.seed}

    def step(self, action):
        if self._world is None:
            raise RuntimeError("call reset() first")
        if self._done:
            raise RuntimeError("the episode has ended (info['end'] says why): call reset() first")
        world = self._world
        action = np.asarray(action, dtype=float)
        if action.shape != self.action_space.shape or not np.isfinite(action).all():
            raise InputError(f"must be {self.action_space.shape[0]} finite numbers, got shape {action.shape}", field="action")
        target, grip = self._targets(action)
        pushed_before = world.pushed
        failure = world.hold(target, grip, 1.0 / self.fps)
        self._steps += 1
        success = world.held
        fell = world.object_height() < self.scene.table.height - _FELL_M
        terminated = success or fell or failure is not None
        truncated = not terminated and self._steps >= self._max_episode_steps
        reward = float(success) if self.reward_type == "sparse" else world.progress() + float(success)
        info = {**self._info(), "is_success": success}
        if terminated or truncated:
            self._done = True
            info["end"] = ("success" if success else "simulation" if failure is not None else "fell" if fell
                           else "time_limit")
        if world.pushed is not pushed_before:
            info["pushed"] = dataclasses.asdict(world.pushed)
        if failure is not None:
            info["failure"] = failure
        return self._observation(), reward, terminated, truncated, info

    def _targets(self, action: np.ndarray) -> tuple[np.ndarray, float]:
        """The joints' servo targets and the gripper's closing an action asks for."""
        grip = float(np.clip(action[-1], 0.0, 1.0))
        if self.action_type == "joint":
            return np.clip(action[:-1], self.lower, self.upper), grip
        world = self._world
        q = world.joints()
        step = np.clip(action[:6], self.action_space.low[:6], self.action_space.high[:6])
        return q + _fingertip_step(np.asarray(world.robot.jacobian(q)), step, q, world.posture, self.lower, self.upper), grip

    def expert_action(self) -> np.ndarray:
        """The planner's action now: its reference one step ahead (the slide, the approach, the closing and the
        lift as ``slideplan execute`` times them), in this environment's action type. It re-plans from the
        object's true pose when a slide has ended short of graspable or the arm is off its reference (DAgger:
        the expert's label for wherever a policy has brought the episode)."""
        world = self._world
        if world is None:
            raise RuntimeError("call reset() first")
        target, grip = world.expert(world.time(), 1.0 / self.fps)
        if self.action_type == "joint":
            return np.append(target, grip).astype(np.float32)
        tip, goal = np.asarray(world.robot.fk(world.joints())), np.asarray(world.robot.fk(target))
        delta = np.concatenate([goal[:3, 3] - tip[:3, 3], rotation_vector(goal[:3, :3] @ tip[:3, :3].T)])
        return np.append(np.clip(delta, self.action_space.low[:6], self.action_space.high[:6]), grip).astype(np.float32)

    def _observation(self) -> dict:
        world = self._world
        snap = world.frames.snapshot()
        if self.obs_type == "state":
            return {"agent_pos": snap["state"], "environment_state": world.object_state()}
        if self.obs_type == "pixels":
            return {"pixels": {"front": snap["front"]}, "agent_pos": snap["state"]}
        return {"depth": world.depth(), "agent_pos": snap["state"]}

    def _info(self) -> dict:
        return {"is_success": False, "task_description": self.task_description}

    def render(self):
        if self.render_mode == "rgb_array" and self._world is not None:
            return self._world.view()
        return None

    def close(self) -> None:
        if self._world is not None:
            self._world.close()
            self._world = None


def _fingertip_step(jacobian: np.ndarray, step: np.ndarray, q: np.ndarray, posture: np.ndarray,
                    lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The joint step that moves the fingertip by ``step`` (damped least squares), its null space pulled
    toward ``posture``, and a joint that would pass its limit held at it while the others make up the step:
    else a redundant arm's joints drift into a limit (a radian in a few seconds of slide) and, clipped there,
    the fingertip no longer follows."""
    dq, free = np.zeros_like(q), np.ones(len(q), dtype=bool)
    for _ in range(len(q)):
        sub = jacobian[:, free]
        inverse = sub.T @ np.linalg.inv(sub @ sub.T + 1e-4 * np.eye(6))  # damped: no wild steps near a singularity
        null = np.eye(int(free.sum())) - inverse @ sub
        wanted = step - jacobian[:, ~free] @ dq[~free]
        dq[free] = inverse @ wanted + null @ (_POSTURE_GAIN * (posture - q)[free])
        over = free & ((q + dq > upper) | (q + dq < lower))
        if not over.any():
            break
        dq[over] = np.clip(q + dq, lower, upper)[over] - q[over]
        free &= ~over
    return np.clip(q + dq, lower, upper) - q


class _World(Episode):
    """An episode (:class:`~slideplan.sim.episode.Episode`: the first plan's model with the object as it is, the
    servos) stepped by a policy's actions, with the expert's timed reference and the observation's cameras."""

    def __init__(self, scene: Scene, start: Start, setting: str, fps: int, image_size: tuple[int, int], obs_type: str) -> None:
        import mujoco

        first = start.first
        self.scene, self.start = scene, start
        super().__init__(first, execution_settings(setting, start.draws, float(first.params["dz_min"])), start.truth,
                         start.mounted)
        self.top = scene.table.height + start.perceived.thickness
        depths = self.top - np.asarray(first.fingertip_poses)[:, 2]
        self.posture = np.asarray(first.trajectory[0], dtype=float)  # pressed at the first contact
        self.runner.press(self.posture, float(depths[0]))
        self.closing, self.replans, self.quiet_until = False, 0, 0.0
        self.watch, self.held, self.steps = HoldWatch(scene.table.height, self.settings.hold_s), False, 0
        width, height = image_size
        cameras = (CameraSpec("front", width, height),) if obs_type == "pixels" else ()
        self.frames = Frames(self.built, self.runner, self.robot, fps, cameras, front_points(scene))
        self.viewer = None  # render()'s camera, made at its first frame
        self.depth_renderer = None
        if obs_type == "depth":
            self.depth_renderer = mujoco.Renderer(self.built.model, height, width)
            self.depth_renderer.enable_depth_rendering()
        com, yaw, _ = self.runner.object_pose()
        self.start_pose = (np.asarray(com, dtype=float), yaw)
        self._expert_reference(first, (0.0, 0.0, 0.0))
        # The hard setting's push, as a run's (closed_loop._Push): at its share of the planned slide's time,
        # the first candidate that leaves the centre of mass inside the table.
        draws, slide_s = start.draws, float(plan_times(first, "trajectory", len(first.trajectory))[-1])
        self.pushes = push_candidates(int(draws["push_seed"]), draws["push_fraction"] * slide_s) if draws.get("push") else None
        self.pushed = None

    def _expert_reference(self, result, planned_from, start_s: float = 0.0, reach: tuple | None = None) -> None:
        """The joint reference and gripper command from ``start_s`` on: ``reach`` (path, times) to the plan's
        first contact if given, then the plan's slide, the approach, the closing and the lift. ``planned_from``:
        the object's motion (:meth:`motion`) when the plan was made, for where its slide leaves it."""
        slide = np.asarray(result.trajectory, dtype=float)
        slide_t = plan_times(result, "trajectory", len(slide))
        approach = np.asarray(result.grasp["approach"], dtype=float)
        approach_t = plan_times(result, "approach", len(approach)) if len(approach) else np.zeros(0)
        grasp = np.asarray(result.grasp["config"], dtype=float)
        limits = resolve_limits(result, timing_options(self.settings, self.robot.velocity_limits))
        lift = straight_up(self.robot, grasp, self.settings.lift_height)
        lift = grasp[None, :] if lift is None else lift
        lift_t = rest_to_rest(self.robot, lift, limits, "lift")["time_from_start"]
        ramp = self.built.gripper.ramp_s(self.settings) if len(self.built.gripper) else 0.0
        paths, times, clock = [], [], start_s
        if reach is not None:
            paths.append(reach[0])
            times.append(clock + reach[1])
            clock += float(reach[1][-1]) + SETTLE_S
        paths.append(slide)
        times.append(clock + slide_t)
        self.slid = clock + float(slide_t[-1])  # the slide's last configuration reached
        clock = self.slid + SETTLE_S
        self.slide_end, self.looked = clock, False
        tips = np.asarray(result.fingertip_poses)
        self.planned_end = compose_planar(planned_from, planar_motion(row_to_pose(tips[0]), row_to_pose(tips[-1])))
        if len(approach):
            paths.append(approach)
            times.append(clock + approach_t)
            clock += float(approach_t[-1]) + SETTLE_S
        self.close_at, self.ramp_s = clock, max(ramp, 1e-6)
        clock += ramp + CLOSE_S
        paths.append(lift)
        times.append(clock + lift_t)
        self.result, self.reference = result, (np.vstack(paths), np.concatenate(times))

    def expert(self, t: float, ahead: float) -> tuple[np.ndarray, float]:
        """The expert's joint targets and gripper closing ``ahead`` s after episode time ``t``. Before the hand
        closes it re-plans (at most MAX_REPLANS times) when the slide has ended short of graspable, or when the
        arm is off the reference (a policy took it elsewhere): a new plan for the object where it truly is,
        reached from where the arm is."""
        if not self.closing and self.replans < MAX_REPLANS and t >= self.quiet_until:
            off = self._off_reference(t)
            ended = t >= self.slide_end and not self.looked
            if ended:
                self.looked = True
            if off or (ended and not self._ended_as_planned()):
                self._replan(t)
        path, times = self.reference
        return reference(path, times, t + ahead), float(np.clip((t + ahead - self.close_at) / self.ramp_s, 0.0, 1.0))

    def _ended_as_planned(self) -> bool:
        """The slide left the object graspable and where the plan's grasp is for (a push may leave it
        graspable elsewhere)."""
        params = self.result.params
        error_m, error_yaw = pose_error(self.start.truth, self.planned_end, self.motion())
        return (self.ending().graspable(float(params["u_star"]), float(params["com_margin"]))
                and error_m <= _OFF_PLAN[0] and abs(error_yaw) <= _OFF_PLAN[1])

    def _off_reference(self, t: float) -> bool:
        """The fingertip off the reference's. Measured in the fingertip's space, not the joints': an ee_delta
        policy (the expert's own included) moves the fingertip and leaves a redundant arm free in its null space,
        so its joints drift from the reference's while the finger follows the plan."""
        want, tip = (np.asarray(self.robot.fk(q)) for q in (reference(*self.reference, t), self.joints()))
        turned = np.linalg.norm(rotation_vector(want[:3, :3] @ tip[:3, :3].T))
        return bool(np.linalg.norm(want[:3, 3] - tip[:3, 3]) > _OFF_REFERENCE[0] or turned > _OFF_REFERENCE[1])

    def _replan(self, t: float) -> None:
        """Plan for the object where it is (:func:`slideplan.loop.decisions.plan_anew`: over an edge too) and reach its first
        contact from here; keep the reference if there is none."""
        self.replans += 1
        motion = self.motion()
        moved = self.start.truth.moved(motion)
        config = dataclasses.replace(self.start.config, seed=self.start.config.seed + self.replans, time_limit_s=1.0)
        try:
            # On the contact constraint, as the plan's configurations are: the slide's, not the approach's.
            commanded = reference(*self.reference, min(t, self.slid))
            checked = plan_anew(self.scene, moved, config, self.robot, commanded)
            reach = reach_path(checked.result, moved, self.joints(), pressed=True) if checked.ok else None
        except (InputError, Unreachable):
            reach = None
        if reach is None:  # look again in a second, while the hand is open
            self.slide_end, self.looked, self.quiet_until = t + 1.0, False, t + 1.0
            return
        reach_t = rest_to_rest(self.robot, reach, checked.result.timing["limits"], "reach", capped=False)["time_from_start"]
        self._expert_reference(checked.result, motion, t, (reach, reach_t))

    def hold(self, target: np.ndarray, grip: float, duration: float) -> str | None:
        """Hold the servo targets for ``duration`` s; returns why the simulation stopped, or None."""
        import mujoco

        model, data, built, runner = self.built.model, self.built.data, self.built, self.runner
        gripper = built.gripper
        if grip > 0.5 and not self.closing and len(gripper):
            # The hand closes: from now on the whole hand touches things, as after `slideplan execute`'s slide.
            # Before, only the pad does (the slide's contact, and a new contact's after a re-plan).
            runner.let_go()
            runner.start_closing()
            enable_hand_collisions(built, True)
            self.closing = True
            runner.phase = "grasp"
        end = data.time + duration - 1e-9
        while data.time < end:
            self.steps += 1
            if self.steps % HOLD_SAMPLE_EVERY == 0 and not self.held:
                self.held = self.watch.add(*runner.hold_sample(data.time))
            data.ctrl[built.arm_actuators] = target
            if len(gripper):
                data.ctrl[gripper.actuators] = gripper.target(grip) if self.closing else gripper.opened
            mujoco.mj_step(model, data)
            if self.pushes is not None and data.time >= self.pushes[0].after_s:
                self.pushed = hard_push(self.pushes, self.scene.table, runner.object_pose()[0])
                if self.pushed is not None:
                    self.pushed.apply(built)
                self.pushes = None
        bad = instability(data)  # MuJoCo's warnings count up: one look per action sees any step's
        return f"simulation unstable ({bad}) at t = {data.time:.3f} s" if bad else None

    def time(self) -> float:
        return float(self.built.data.time)

    def joints(self) -> np.ndarray:
        return np.array(self.built.data.qpos[self.built.arm_qpos])

    def object_height(self) -> float:
        return self.runner.object_pose()[2]

    def object_state(self) -> np.ndarray:
        com, yaw, z = self.runner.object_pose()
        return np.array([com[0], com[1], yaw, z], dtype=float)

    def motion(self) -> tuple[float, float, float]:
        """Eq. 2's planar motion that took the object from its pose at reset to where it truly is now."""
        com, yaw, _ = self.runner.object_pose()
        com0, yaw0 = self.start_pose
        turn = yaw - yaw0
        shift = np.asarray(com) - rotation_2d(turn) @ com0
        return float(shift[0]), float(shift[1]), float(turn)

    def moved(self):
        """The object where it truly is now (a :class:`~slideplan.world.objects.ThinObject`)."""
        return self.start.truth.moved(self.motion())

    def ending(self) -> Ending:
        """How the object lies for the grasp now (the overhang, the centre of mass's margin)."""
        return Ending.at(self.scene.table, np.asarray(self.moved().points)[:, :2], self.runner.object_pose()[0])

    def progress(self) -> float:
        """The dense reward's shaping: the overhang's progress to u* (0..1), less the centre of mass's shortfall
        inside the edge (m x 10), plus the lift's progress (0..1)."""
        ending = self.ending()
        u_star, margin = float(self.start.first.params["u_star"]), float(self.start.first.params["com_margin"])
        _, lowest, _ = self.runner.hold_sample(0.0)
        lift = np.clip((lowest - self.scene.table.height) / self.settings.lift_height, 0.0, 1.0)
        return float(np.clip(ending.overhang / u_star, 0.0, 1.0) - 10.0 * max(0.0, margin - ending.com_margin) + lift)

    def depth(self) -> np.ndarray:
        depth = camera_depth(self.depth_renderer, self.built.model, self.built.data, DEPTH_CAMERA)
        return np.nan_to_num(depth, nan=0.0)[:, :, None].astype(np.float32)

    def view(self) -> np.ndarray:
        if self.viewer is None:
            self.viewer = Frames(self.built, self.runner, self.robot, 1, (CameraSpec("front", 320, 240),),
                                 front_points(self.scene))
        return self.viewer.snapshot()["front"]

    def close(self) -> None:
        self.frames.close()
        if self.viewer is not None:
            self.viewer.close()
        super().close()  # the depth observation's renderer too


register(gym)  # gym.make("slideplan/SlideToEdge-v1") works after import slideplan as well
