"""``slideplan ros serve``, ``call`` and ``sim`` (docs/ros2.md; the ``ros`` extra)."""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np
import typer

from .._fields import as_number
from ..errors import InputError
from ..world.objects import load_outline, sample_pose_on_table
from ..world.scenes import load_scene
from .common import EXIT_NOT_SOLVED, _OPTION_OF_FIELD, _OneLineErrors, _disturb_values, _fail, _numbers, app


ros_app = typer.Typer(cls=_OneLineErrors, no_args_is_help=True, help="slideplan on a ROS 2 robot (docs/ros2.md; the ros extra).")
app.add_typer(ros_app, name="ros")
_ROS_ARGS = {"allow_extra_args": True, "ignore_unknown_options": True}


def _ros_args(context: typer.Context) -> list[str]:
    """What follows ``--ros-args`` (remappings ``-r FROM:=TO``, parameters ``-p NAME:=VALUE``); nothing
    else may be left over."""
    extra = list(context.args)
    if extra and extra[0] != "--ros-args":
        raise _fail(InputError(f"unexpected argument {extra[0]!r} (ROS arguments go after --ros-args)"))
    return extra


def _ros_import(module: str):
    try:
        return __import__(f"slideplan.ros.{module}", fromlist=[module])
    except ImportError as error:
        raise _fail(InputError(f"the ros extra is not installed ({error}): pip install 'slideplan[ros]'")) from None


@ros_app.command("serve", context_settings=_ROS_ARGS)
def ros_serve_command(
    context: typer.Context,
    scene_name: str = typer.Option("square", "--scene", help="The robot's scene (URDF, mount, hand): built-in name or TOML."),
    camera_pose: Optional[Tuple[float, float, float, float, float, float]] = typer.Option(
        None, "--camera-pose", help="X Y Z ROLL PITCH YAW of the cloud's frame in the world (parameter camera_pose)."),
    target: Optional[int] = typer.Option(
        None, "--target", help="Which object to slide, largest first (parameter target; default 0)."),
    closed: Optional[bool] = typer.Option(
        None, "--closed-loop/--open-loop", help="Watch and re-plan while sliding (parameter closed_loop; default on)."),
    sim_time: Optional[bool] = typer.Option(
        None, "--sim-time/--wall-time", help="Run on the simulator's /clock (parameter use_sim_time; default off)."),
) -> None:
    """The planning node ``slideplan``: services /slideplan/plan and /slideplan/execute (docs/ros2.md).
    ROS arguments (remappings, parameters) go after --ros-args. Exit codes: 0 on Ctrl-C, 2 bad input."""
    ros_args = _ros_args(context)
    serve = _ros_import("serve")
    try:
        scene = load_scene(scene_name)
    except (InputError, OSError, ValueError) as error:
        raise _fail(error) from None
    # Only the options given: the others leave the node's parameters to --ros-args -p NAME:=VALUE, then the defaults.
    given = {"target": target, "closed_loop": closed, "use_sim_time": sim_time,
             "camera_pose": None if camera_pose is None else [float(value) for value in camera_pose]}
    parameters = {name: value for name, value in given.items() if value is not None}
    try:
        serve.serve(scene, parameters, ros_args=ros_args, log=typer.echo)
    except InputError as error:
        raise _fail(error) from None


@ros_app.command("call", context_settings=_ROS_ARGS)
def ros_call_command(
    context: typer.Context,
    service: str = typer.Argument(..., help="plan, execute, or a Trigger service's full name (/slideplan/plan)."),
    timeout: float = typer.Option(600.0, "--timeout", help="Seconds to wait for the answer once called (execute runs a whole task)."),
    wait: float = typer.Option(30.0, "--wait", help="Seconds to wait for the service to appear."),
) -> None:
    """Call the planning node's /slideplan/plan or /slideplan/execute (std_srvs/Trigger) and print its answer:
    what ROS 2's `ros2 service call` would do, without ROS 2's command line tools. Exit codes: 0 the service
    answered success, 1 it answered failure, 2 bad input or no answer."""
    ros_args = _ros_args(context)
    call = _ros_import("call")
    name = f"/slideplan/{service}" if service in ("plan", "execute") else service
    try:
        for value, option in ((timeout, "--timeout"), (wait, "--wait")):
            as_number(value, source="", field=option, positive=True)
        success, message = call.call_trigger(name, wait_s=wait, answer_s=timeout, ros_args=ros_args[1:])
    except InputError as error:
        raise _fail(InputError(error.problem, field={"timeout": "--timeout", "service": "SERVICE"}.get(error.field, error.field))) from None
    typer.echo(f"{name}: {'success' if success else 'failure'}: {message}")
    if not success:
        raise typer.Exit(EXIT_NOT_SOLVED)


@ros_app.command("sim", context_settings=_ROS_ARGS)
def ros_sim_command(
    context: typer.Context,
    scene_name: str = typer.Option("square", "--scene", help="Built-in scene name or scene TOML."),
    object_name: str = typer.Option("crescent", "--object", help="Object outline: a name in data/objects or a TOML."),
    pose: Optional[Tuple[float, float, float]] = typer.Option(
        None, "--pose", help="X Y YAW where the object lies (m, m, rad); default: drawn on the table from --seed."),
    seed: int = typer.Option(1, "--seed", help="Seeds the pose, the camera noise and the random setting."),
    setting: str = typer.Option("nominal", "--setting", help="nominal, stress or random (physics drawn per --seed)."),
    disturb: Optional[Tuple[float, float, float, float]] = typer.Option(
        None, "--disturb", help="DX DY DYAW T: move the object by (DX, DY) m and turn it by DYAW rad T s after the finger first touches it."),
    home: Optional[str] = typer.Option(None, "--home", help="The arm's first configuration, comma-separated (rad); default all 0."),
    cloud_hz: float = typer.Option(5.0, "--cloud-rate", help="Depth clouds per second on /camera/points."),
) -> None:
    """The MuJoCo robot ``slideplan_sim``: /joint_states, /camera/points, /slideplan_sim/object_pose; follows
    /joint_trajectory_controller/joint_trajectory; serves /gripper/set (docs/ros2.md). Exit codes: 0 on
    Ctrl-C, 2 bad input."""
    ros_args = _ros_args(context)
    sim = _ros_import("sim")
    try:
        from ..sim.conditions import Disturbance

        scene = load_scene(scene_name)
        if pose is None:
            outline, _, _ = load_outline(object_name)
            pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(seed))
        if not (np.isfinite(cloud_hz) and 0 < cloud_hz <= 60):
            raise InputError(f"expected a rate in (0, 60] Hz, got {cloud_hz}", field="--cloud-rate")
        configuration = None if home is None else _numbers(home, "--home", "rad")
        disturbance = None if disturb is None else Disturbance(*_disturb_values(disturb))
        robot = sim.Sim(scene, object_name, pose, setting=setting, seed=seed, home=configuration, disturbance=disturbance)
    except InputError as error:
        raise _fail(InputError(error.problem, source=error.source, field=_OPTION_OF_FIELD.get(error.field, error.field))) from None
    except (OSError, ValueError) as error:
        raise _fail(error) from None
    try:
        sim.serve(robot, cloud_hz=cloud_hz, ros_args=ros_args, log=typer.echo)
    except InputError as error:
        raise _fail(error) from None
