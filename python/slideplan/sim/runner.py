"""Stepping the model: the arm servoed along timed joint paths (:mod:`slideplan.plan.motions` makes and reads
them), checked for instability."""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from ..plan.motions import reference, references, rest_to_rest, straight_up
from ..plan.timing import TimingOptions
from .model import Model, enable_hand_collisions
from .settings import ExecutionSettings

SETTLE_S = 0.3  # held after the slide, and after the approach, for the object and the arm to come to rest
CLOSE_S = 0.8  # the hand held closed this long before the lift
_LIFTED_FRACTION = 0.5  # lifted: the object rose at least half the lift height and stays there
_FELL_DROP_M = 0.01  # fell: the object's centre is this far below its resting height
_SAMPLE_EVERY = 5  # steps between normal-force samples
HOLD_SAMPLE_EVERY = 10  # steps between samples of the object over the hold (the verdict: slideplan.checks.verdict.SAMPLE_GAP_S)
UNSTABLE_WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")  # MuJoCo resets the state on each


def instability(data) -> str:
    """Why a simulation can no longer be trusted, or "" while it can: one of MuJoCo's
    :data:`UNSTABLE_WARNINGS` fired (it then resets the state and goes on, silently), or the
    accelerations are not finite. Every stepping loop ends its run on a cause.

    Args:
        data: the ``mujoco.MjData`` after a step.
    """
    import mujoco

    fired = [name[len("mjWARN_"):] for name in UNSTABLE_WARNINGS if data.warning[int(getattr(mujoco.mjtWarning, name))].number]
    if fired:
        return f"MuJoCo's {', '.join(fired)} warning"
    return "" if np.isfinite(data.qacc).all() else "non-finite accelerations"


_CHECK_EVERY = 10  # steps between checks of MuJoCo's warnings and of the state's finiteness


class Unstable(Exception):
    """The simulation produced NaN or MuJoCo reset it (bad positions, velocities or accelerations)."""


def timing_options(settings: ExecutionSettings, urdf_velocity) -> TimingOptions:
    """The limits under which :mod:`slideplan.plan.timing` times what an execution times itself.

    Args:
        settings: its ``tip_speed``, ``joint_velocity`` and ``joint_acceleration`` are the limits.
        urdf_velocity: (dof,) the URDF's ``<limit velocity>``; 0 or less (missing) sets no limit.

    Returns:
        The options, joint velocity ``min(URDF, settings.joint_velocity)`` per joint.
    """
    urdf_velocity = np.asarray(urdf_velocity, dtype=float)
    velocity = np.minimum(np.where(urdf_velocity > 0, urdf_velocity, np.inf), settings.joint_velocity)
    return TimingOptions(joint_acceleration=settings.joint_acceleration, fingertip_speed=settings.tip_speed,
                         joint_velocity=velocity)


class Runner:
    """Steps the simulation with the arm servoed along joint paths, checking for instability."""

    def __init__(self, built: Model, settings: ExecutionSettings, on_frame: Callable[[], None] | None):
        self.built = built
        self.settings = settings
        self.on_frame = on_frame
        self.forces: list[float] = []  # the pad's normal force while sliding (N), every few steps
        self.lifted = False
        # Reading the reference kv/kp ahead is velocity feed-forward to first order; an arm that follows
        # its references late (settings.reference_lag_s) reads them that much behind.
        self.lead = 1.0 / (math.pi * settings.servo_bandwidth_hz) - settings.reference_lag_s
        self.hold: list[tuple[float, float, bool]] = []  # (s into the hold, object's lowest z, in the hand): the verdict's record
        self.phase = "slide"  # what the arm is doing: slide, a move's phase (reach, ...), approach, grasp, lift, hold
        self._is_object = None  # per geom: part of the object (built on the first force sample)
        self._object_ids = None  # the object's geoms, sorted (built on the first hold sample)
        # The first touch of the scene's clutter by the arm or the object: (stage, what touched what), or None.
        self.clutter_contact: tuple[str, str] | None = None
        self._clutter = None  # {geom id: obstacle name}, built at the first check

    def follow(self, path: np.ndarray, times: np.ndarray, extra_s: float = 0.0, on_step=None) -> float:
        """Servo the arm along ``path`` at ``times`` (s from now), then hold its end for ``extra_s``.

        Args:
            path: (M, dof) joint path.
            times: (M,) its times from now (s).
            extra_s: hold the end this long (s).
            on_step: called as ``on_step(elapsed, step)`` before each step; returning True stops
                following there (the closed loop switches to a new trajectory).

        Returns:
            The time followed (s).

        Raises:
            Unstable: MuJoCo flagged bad accelerations or a state went non-finite.
        """
        import mujoco

        model, data = self.built.model, self.built.data
        start = data.time
        end = float(times[-1]) + extra_s
        # The references of every step at once (the reference of step k is read at k * timestep + lead):
        # no per-step interpolation in Python.
        count = max(int(math.ceil(end / model.opt.timestep)) + 2, 1)
        ahead = references(path, times, np.maximum(np.arange(count) * model.opt.timestep + self.lead, 0.0))
        actuators = self.built.arm_actuators
        first = int(actuators[0]) if len(actuators) else 0
        contiguous = np.array_equal(actuators, np.arange(first, first + len(actuators)))
        # A view when the arm's actuators are contiguous: writing it sets data.ctrl without an index array.
        ctrl = data.ctrl[first:first + len(actuators)] if contiguous else None
        warnings = data.warning.number  # a view: MuJoCo's warning counters, read without building structs
        watched = [int(getattr(mujoco.mjtWarning, name)) for name in UNSTABLE_WARNINGS] + [
            int(mujoco.mjtWarning.mjWARN_CNSTRFULL), int(mujoco.mjtWarning.mjWARN_CONTACTFULL)]
        mj_step, on_frame, last = mujoco.mj_step, self.on_frame, count - 1
        step = 0
        while data.time - start < end - 1e-9:
            elapsed = data.time - start
            if contiguous:
                ctrl[:] = ahead[min(step, last)]
            else:
                data.ctrl[actuators] = ahead[min(step, last)]
            if on_step is not None and on_step(elapsed, step):
                break
            mj_step(model, data)
            step += 1
            # The counters only grow, so checking every few steps still ends the run on the first one
            # (MuJoCo resets the state when it fires); checking every step cost 5% of an episode's wall.
            if step % _CHECK_EVERY == 0:
                self._check(warnings, watched)
            if on_frame is not None:
                on_frame()
        self._check(warnings, watched)
        return float(data.time - start)

    def _check(self, warnings: np.ndarray, watched: list[int]) -> None:
        """Raise :class:`Unstable` if a watched warning counter (the unstable ones, then the full ones) is
        set or the accelerations are not finite."""
        data = self.built.data
        counts = warnings[watched]
        if counts[:len(UNSTABLE_WARNINGS)].any() or not np.isfinite(data.qacc).all():
            raise Unstable(f"simulation unstable ({instability(data)}) at t = {data.time:.3f} s")
        if counts.any():
            raise Unstable(f"simulation out of contact memory at t = {data.time:.3f} s (contacts were dropped)")
        if self.clutter_contact is None:
            self._watch_clutter()

    def _watch_clutter(self) -> None:
        """Record the first contact of the arm or the object with an obstacle (a plan's promise broken)."""
        model, data, built = self.built.model, self.built.data, self.built
        if self._clutter is None:
            self._clutter = {index: model.geom(index).name.split("_")[2] for index in range(model.ngeom)
                             if model.geom(index).name.startswith("slideplan_clutter_")}
            self._clutter_bodies = {int(model.geom_bodyid[index]) for index in self._clutter}
        if not self._clutter or not data.ncon:
            return
        pairs = data.contact.geom[:data.ncon]
        for first, second in pairs:
            for mine, other in ((first, second), (second, first)):
                if mine in self._clutter:
                    body = int(model.geom_bodyid[other])
                    if body == 0 or body in self._clutter_bodies:
                        continue  # the table, or clutter on clutter
                    who = "the object" if body == built.object_body else f"the robot ({model.body(body).name})"
                    stage = "grasp" if self.phase in ("approach", "grasp", "lift", "hold") else "slide"
                    self.clutter_contact = (stage, f"{who} touched obstacle {self._clutter[mine]} during the {self.phase} "
                                                   f"at t = {data.time:.2f} s")
                    return

    def commanded(self, path: np.ndarray, times: np.ndarray, elapsed: float) -> np.ndarray:
        """The joint reference the servos hold ``elapsed`` s into ``path``: where a new path must start
        for the reference not to jump."""
        return reference(path, times, max(elapsed + self.lead, 0.0))

    def press(self, config: np.ndarray, depth: float) -> None:
        """Start pressed: the arm at ``config``, the finger spring compressed by the planned ``depth``; only
        the pad touches anything while sliding."""
        import mujoco

        enable_hand_collisions(self.built, False)
        self.built.data.qpos[self.built.arm_qpos] = config
        self.built.data.qpos[self.built.spring_qpos] = max(depth, 0.0)
        mujoco.mj_forward(self.built.model, self.built.data)

    def slide(self, path: np.ndarray, times: np.ndarray, depths: np.ndarray, extra_s: float = 0.0, on_step=None) -> float:
        """Follow a sliding path, sampling the pad's normal force into :attr:`forces`.

        With ``settings.contact_depth`` set, the spring's rest length follows the planned ``depths``
        (m, per waypoint) so that the pad presses that deep instead. Arguments and return as :meth:`follow`.
        """
        model, spring = self.built.model, self.built.spring_qpos
        depth_override = self.settings.contact_depth

        def during(elapsed: float, step: int) -> bool:
            if depth_override is not None:
                model.qpos_spring[spring] = float(np.interp(elapsed, times, depths)) - depth_override
            if step % _SAMPLE_EVERY == 0 and 0 < elapsed < times[-1]:
                self.forces.append(self.pad_normal_force())
            return on_step is not None and bool(on_step(elapsed, step))

        if depth_override is not None:
            model.qpos_spring[spring] = depths[0] - depth_override
        self.phase = "slide"
        return self.follow(path, times, extra_s, during)

    def grasp(self, approach: np.ndarray, approach_times: np.ndarray, grasp_config: np.ndarray, robot, limits: dict[str, Any],
              top: float, rest_z: float) -> tuple[str, str] | None:
        """Let go, follow the approach, close the hand, lift and hold.

        Args:
            approach: (K, dof) the plan's approach, from the end of the slide to the grasp.
            approach_times: (K,) its times (s).
            grasp_config: (dof,) the grasp.
            robot: the core robot model (fingertip frame and IK for the lift).
            limits: timing limits of the lift (:func:`slideplan.plan.timing.resolve_limits`).
            top: the object's top surface height (m): the hand's own geoms touch things above it.
            rest_z: the object's centre height at rest on the table (m).

        Returns:
            None if the object was lifted and held, else ``(stage, message)`` of the first failure
            (``"slide"``: the object was off the table before the finger let go; ``"release"``: it fell off
            the table when the finger let go; ``"grasp"``: not lifted).
        """
        data, built, settings = self.built.data, self.built, self.settings
        gone = self.object_pose()[2] < rest_z - _FELL_DROP_M  # pushed or slid off before the finger let go
        self.let_go()
        failure = ("slide", "the object left the table before the finger let go (pushed or slid off it)") if gone else None

        def during_approach(elapsed: float, step: int) -> None:
            # The pad (at the contact frame), not the tip link's origin: the Panda's is 5 cm up its finger,
            # and its finger, still pressed into the object, then dragged the object off the table.
            if step % _SAMPLE_EVERY == 0 and data.geom_xpos[built.pad_geom][2] > top + 0.02:
                enable_hand_collisions(built, True)

        self.phase = "approach"
        if len(approach):
            self.follow(approach, approach_times, SETTLE_S, during_approach)
        enable_hand_collisions(built, True)
        if failure is None and self.object_pose()[2] < rest_z - _FELL_DROP_M:
            failure = ("release", "the object fell off the table when the finger let go")
        gripper = built.gripper
        if not len(gripper):
            # A rigid finger only (e.g. the bundled UR5 and xArm7 scenes): the slide ran, there is nothing to close.
            return failure or ("grasp", "the hand has no fingers to close: the plan's hand names no gripper joints "
                                        "([hand] gripper_joints)")
        # Straight up; an arm with fewer than six joints takes the yaw its posture gives (the SO-101's
        # offsets leave the same orientation 5 cm higher just out of reach).
        lift_way = straight_up(robot, grasp_config, settings.lift_height)
        self.start_closing()
        # The fingers close at the hand's speed and meet at the grasp plane together: a step lets the light
        # fingers strike a thin object so hard that it flies out, and a finger arriving first (the
        # straight one under a splayed one) lifts the object off the table before the other holds it.
        ramp_s = gripper.ramp_s(settings)
        self.phase = "grasp"

        def closing(elapsed: float, step: int) -> None:
            data.ctrl[gripper.actuators] = gripper.target(elapsed / ramp_s)

        self.follow(grasp_config[None, :], np.zeros(1), ramp_s + CLOSE_S, closing)
        on_table = self.robot_bodies_on_table()
        if lift_way is None:
            return failure or ("grasp", f"no inverse kinematics for the {100 * settings.lift_height:.0f} cm lift")
        # The lift is not in the plan: timed here, the fingertip capped all the way (it holds the object).
        lift_path, lift_times = lift_way, rest_to_rest(robot, lift_way, limits, "lift")["time_from_start"]
        lift_s = float(lift_times[-1])

        def holding(elapsed: float, step: int) -> None:
            if elapsed >= lift_s - 1e-9:
                self.phase = "hold"
                if step % HOLD_SAMPLE_EVERY == 0:
                    self.hold.append(self.hold_sample(elapsed - lift_s))

        self.phase = "lift"
        self.follow(lift_path, lift_times, settings.hold_s, holding)
        self.hold.append(self.hold_sample(settings.hold_s))
        self.lifted = self.object_pose()[2] >= rest_z + _LIFTED_FRACTION * settings.lift_height
        if not self.lifted:
            blocked = f" ({', '.join(on_table)} stopped by the table when closing)" if on_table else ""
            failure = failure or ("grasp", f"the grasp did not lift the object{blocked}")
        return failure

    def let_go(self) -> None:
        """The slide is over: the finger's spring back at rest, the contact solver as after a slide."""
        model, built = self.built.model, self.built
        model.qpos_spring[built.spring_qpos] = 0.0
        if built.contacts.noslip_after_slide is not None:
            model.opt.noslip_iterations = built.contacts.noslip_after_slide

    def start_closing(self) -> None:
        """Close: the finger's flexure stiffens (the hand squeezes with the closing servos), the grip capped."""
        model, built = self.built.model, self.built
        model.jnt_stiffness[built.spring_joint] *= 50.0
        built.gripper.grip(model, self.settings, closing=True)

    def object_pose(self) -> tuple[np.ndarray, float, float]:
        """The object's centre of mass xy, yaw and height."""
        data = self.built.data
        body = self.built.object_body
        rotation = data.xmat[body].reshape(3, 3)
        return data.xpos[body][:2].copy(), math.atan2(rotation[1, 0], rotation[0, 0]), float(data.xpos[body][2])

    def hold_sample(self, at: float) -> tuple[float, float, bool]:
        """``(at, the object's lowest point's height, whether it touches the robot)`` from the true state now."""
        import mujoco

        model, data, built = self.built.model, self.built.data, self.built
        if self._object_ids is None:
            self._object_ids = np.array(sorted(built.object_geoms), dtype=int)
        geoms = self._object_ids
        boxes = model.geom_type[geoms] == int(mujoco.mjtGeom.mjGEOM_BOX)
        # A box's lowest corner: its centre less the half sizes along its axes' vertical components.
        reach = np.where(boxes, np.einsum("gi,gi->g", np.abs(data.geom_xmat[geoms].reshape(-1, 3, 3)[:, 2, :]),
                                          model.geom_size[geoms]), model.geom_rbound[geoms])
        lowest = float(np.min(data.geom_xpos[geoms, 2] - reach))
        # In the hand: touching a robot body (the table and clutter are the world body's, 0).
        bodies = model.geom_bodyid[data.contact.geom[:data.ncon]].reshape(-1, 2)
        other = np.where(bodies[:, 0] == built.object_body, bodies[:, 1], bodies[:, 0])
        touching = bool(np.any((bodies == built.object_body).any(axis=1) & (other != 0) & (other != built.object_body)))
        return float(at), lowest, touching

    def robot_bodies_on_table(self) -> list[str]:
        """Names of the robot bodies touching the table now (e.g. a closing finger it stopped)."""
        model, data = self.built.model, self.built.data
        names = set()
        for index in range(data.ncon):
            geoms = (int(data.contact[index].geom1), int(data.contact[index].geom2))
            for geom, other in (geoms, geoms[::-1]):
                if other in self.built.table_geoms and model.geom_bodyid[geom] != self.built.object_body:
                    names.add(model.body(model.geom_bodyid[geom]).name)
        return sorted(names)

    def pad_normal_force(self) -> float:
        """Total normal force between the fingertip pad and the object (N)."""
        import mujoco

        model, data = self.built.model, self.built.data
        if data.ncon == 0:
            return 0.0
        if self._is_object is None:
            self._is_object = np.zeros(model.ngeom, dtype=bool)
            self._is_object[list(self.built.object_geoms)] = True
        geoms = data.contact.geom[: data.ncon]
        pad = self.built.pad_geom
        touching = ((geoms[:, 0] == pad) & self._is_object[geoms[:, 1]]) | ((geoms[:, 1] == pad) & self._is_object[geoms[:, 0]])
        total = 0.0
        wrench = np.zeros(6)
        for index in np.flatnonzero(touching):
            mujoco.mj_contactForce(model, data, int(index), wrench)
            total += abs(wrench[0])
        return total
