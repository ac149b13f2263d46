"""What every command shares: the app, its one-line errors and exit codes, the options read into a
planner config, the object loaded or placed, the plan verified and written."""

from __future__ import annotations

import contextlib
import dataclasses
import difflib
import math
import sys
import warnings
from pathlib import Path

import numpy as np
import typer
from typer.core import TyperGroup

try:  # typer 0.28 carries its own copy of click; earlier releases use click itself
    from typer._click import exceptions as click_errors
except ImportError:
    from click import exceptions as click_errors

from .._files import replacing, write_text
from ..errors import InputError, SlideplanWarning
from ..world.objects import CLOUD_SUFFIXES, ThinObject, load_object, load_outline, sample_pose_on_table
from ..plan.config import PlannerConfig
from ..plan.result import PlanResult
from ..world.scenes import Scene


EXIT_SOLVED, EXIT_NOT_SOLVED, EXIT_BAD_INPUT, EXIT_INVALID_PLAN = 0, 1, 2, 3
EXIT_INTERRUPTED = 130  # Ctrl-C: 128 + SIGINT, the shell's convention (the entry point, which cannot import this, keeps a copy)
PICTURE_SUFFIXES = (".png", ".svg")
MIN_TABLE_REACH = 0.5  # perceive warns when the fingertip reaches less of the table than this (plan.robot.table_reach)
VIDEO_SUFFIXES = (".mp4", ".gif", ".png")
_SHOWN_VIOLATIONS = 20  # a broken plan can have thousands; the first ones tell the story

# Command-line option names of the PlannerConfig fields the CLI sets, for error messages.
_OPTION_OF_FIELD = {
    "seed": "--seed",
    "time_limit_s": "--time-limit",
    "reconfiguration_range": "--reconfiguration-range",
    "dz_max": "--reconfiguration-range",
    "planner": "--planner",
    "scene": "--scene",
    "preset": "--preset",
    "workers": "--workers",
    "scheduler": "--scheduler",
    "tip_speed": "--tip-speed",
    "setting": "--setting",
    "set": "--set",
    "poses": "--poses",
}

class _OneLineErrors(TyperGroup):
    """Usage errors (an unknown or missing option, a value of the wrong type) as one line on stderr
    and exit 2, like every other bad input: not a box of rich text."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click_errors.NoArgsIsHelpError as error:
            typer.echo(error.ctx.get_help())
            sys.exit(error.exit_code)
        except click_errors.NoSuchOption as error:
            known = sorted(name for param in error.ctx.command.params for name in param.opts if name.startswith("-")) if error.ctx else []
            close = difflib.get_close_matches(error.option_name, known, n=3, cutoff=0.75)  # click's 0.6 offers --pose for --bogus
            command = f"{error.ctx.command_path}: " if error.ctx else ""
            hint = f" (did you mean {' or '.join(close)}?)" if close else f" (see {error.ctx.command_path} --help)" if error.ctx else ""
            typer.echo(f"slideplan: error: {command}no such option {error.option_name}{hint}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        except click_errors.ClickException as error:
            command = f"{error.ctx.command_path}: " if getattr(error, "ctx", None) else ""
            message = " ".join(error.format_message().split())
            typer.echo(f"slideplan: error: {command}{message}", err=True)
            sys.exit(EXIT_BAD_INPUT if isinstance(error, click_errors.UsageError) else error.exit_code)
        except typer.Abort:  # click's word for Ctrl-C: the shell's convention is 128 + SIGINT
            typer.echo("slideplan: aborted", err=True)
            sys.exit(EXIT_INTERRUPTED)
        sys.exit(code if isinstance(code, int) else 0)


app = typer.Typer(
    cls=_OneLineErrors,
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Pre-grasp sliding planning of thin objects (Hang, Morgan, Dollar, RA-L 2019).",
)


def _fail(error: Exception) -> typer.Exit:
    """Print one error line on stderr and return the bad-input exit."""
    message = " ".join(str(error).split())  # one line, whatever the source's message looked like
    typer.echo(f"slideplan: error: {message}", err=True)
    return typer.Exit(EXIT_BAD_INPUT)


@contextlib.contextmanager
def _warnings_as_lines():
    """Print slideplan's own warnings raised inside (e.g. a URDF limit replaced by a default) as
    ``slideplan: warning: ...`` lines; the libraries' deprecation notices are not the user's concern."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield
        finally:
            for warning in caught:
                if issubclass(warning.category, SlideplanWarning):
                    typer.echo(f"slideplan: warning: {' '.join(str(warning.message).split())}", err=True)


def _parse_params(items: list[str]) -> dict:
    """``NAME=VALUE`` strings as PlannerConfig fields, each value typed like the field's default.

    Raises:
        InputError: naming ``--param NAME``: no ``=``, an unknown name, or a value of the wrong type.
    """
    fields = {item.name: item for item in dataclasses.fields(PlannerConfig)}
    defaults = PlannerConfig().resolved()  # every field with its built-in value, hence its type
    params = {}
    for item in items:
        name, equals, text = item.partition("=")
        name = name.strip()
        if not equals:
            raise InputError(f"expected NAME=VALUE, got {item!r}", field="--param")
        if name not in fields:
            raise InputError(f"unknown parameter (expected one of: {', '.join(sorted(fields))})", field=f"--param {name}")
        default = getattr(defaults, name)
        try:
            if isinstance(default, bool):
                if text.strip().lower() not in ("true", "false", "1", "0"):
                    raise ValueError(text)
                params[name] = text.strip().lower() in ("true", "1")
            elif isinstance(default, int):
                params[name] = int(text)
            elif isinstance(default, float):
                params[name] = float(text)
            else:
                params[name] = text
        except ValueError:
            raise InputError(f"expected a {type(default).__name__}, got {text!r}", field=f"--param {name}") from None
    return params


def _config_from_options(
    scene: Scene, seed: int, time_limit: float, reconfiguration_range: float | None, planner: str, params: list[str],
    preset: str = "default",
) -> PlannerConfig:
    """Build the planner config: built-in defaults, the hand's, the preset's, then the command line's,
    naming command-line options (not config fields) in errors."""
    overrides = _parse_params(params)
    overrides.pop("preset", None)  # --preset, not --param preset=, chooses it
    try:
        config = PlannerConfig.for_scene(scene, preset=preset,
                                         **{"seed": seed, "time_limit_s": time_limit, "planner": planner, **overrides})
        if reconfiguration_range is not None:
            config = config.with_reconfiguration_range(reconfiguration_range)
    except InputError as error:  # the scene's own [hand] params come named as its file's (PlannerConfig.for_scene)
        if error.field in overrides:
            raise InputError(error.problem, field=f"--param {error.field}") from None
        raise InputError(error.problem, source=error.source, field=_OPTION_OF_FIELD.get(error.field) or error.field) from None
    return config


def _load_object(scene: Scene, object_spec: str, pose, seed: int) -> tuple[ThinObject, tuple | None]:
    """Load the object; place an outline object at ``pose`` or a seeded random pose on the scene's table
    (clear of its obstacles).

    Returns:
        (object, the random pose drawn or None).
    """
    sampled_pose = None
    if pose is None and Path(object_spec).suffix.lower() not in CLOUD_SUFFIXES:
        outline, thickness, _ = load_outline(object_spec)
        sampled_pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(seed),
                                            avoid=scene.footprints(scene.table.height + thickness))
        pose = sampled_pose
    obj = load_object(object_spec, table_height=scene.table.height, pose=pose)
    return obj, sampled_pose


def _write_scene_cloud(scene: Scene, object_name: str, pose, path: Path, seed: int) -> Path | None:
    """Render the table and the object at ``pose`` with the default depth camera into a PLY cloud; None
    (nothing written) without the execution and perception extras."""
    try:
        import plyfile

        from ..sim.rendering import place_objects, render_scene

        points = render_scene(scene.table, place_objects([(object_name, pose)]), seed=seed).points
    except ImportError:  # mujoco is imported when rendering
        return None
    vertices = np.array([tuple(point) for point in points], dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as temporary:
        plyfile.PlyData([plyfile.PlyElement.describe(vertices, "vertex")]).write(str(temporary))
    return path


def _summary(result: PlanResult) -> str:
    """One line: status, time, overhang, roots and pairs; for a plan not found, why pairs were rejected
    most (a collision names its pair: what to move or retune)."""
    stats = result.stats
    counts = (
        f"roots {stats.get('start_roots', 0)} start / {stats.get('goal_roots', 0)} goal, "
        f"pairs {stats.get('pairs_checked', 0)} checked / {stats.get('pairs_rejected', 0)} rejected"
    )
    if not result.solved:
        ranked = sorted(stats.get("rejections", {}).items(), key=lambda item: (-item[1], item[0]))[:3]
        why = "; most rejected: " + ", ".join(f"{count} x {reason}" for reason, count in ranked) if ranked else ""
        # The limit bounds the search; setting up (the input's checks, the collision worlds) comes before it.
        setup = stats.get("setup_time", 0.0)
        split = f" ({setup:.2f} s of it setting up before the search)" if setup >= 0.1 * result.planning_time_s else ""
        return f"{result.status} after {result.planning_time_s:.2f} s{split} ({result.planner}; {counts}{why})"
    return (
        f"solved in {result.planning_time_s:.2f} s ({result.planner}): overhang {100 * result.overhang_m:.1f} cm, "
        f"{len(result.trajectory)} waypoints, {counts}"
    )


def _plan_verify_write(scene: Scene, obj: ThinObject, config: PlannerConfig, json_path: Path | None,
                       png_path: Path | None) -> PlanResult:
    """Plan, verify a solved plan (:func:`slideplan.checks.pipeline.plan_checked`: marked ``invalid`` if it fails,
    its violations printed) and write the outputs asked for."""
    from ..checks.pipeline import plan_checked

    with _warnings_as_lines():
        checked = plan_checked(scene, obj, config)
    if checked.verification is not None and not checked.verification.ok:
        violations = checked.verification.violations
        typer.echo(f"slideplan: plan fails verification ({len(violations)} violations):", err=True)
        for violation in violations[:_SHOWN_VIOLATIONS]:
            typer.echo(f"  {violation}", err=True)
        if len(violations) > _SHOWN_VIOLATIONS:
            typer.echo(f"  ... and {len(violations) - _SHOWN_VIOLATIONS} more", err=True)
    scene_name = Path(scene.source).stem if scene.source else "scene"
    _write_outputs(checked.result, json_path, png_path, f"{obj.name or 'object'} on {scene_name}")
    return checked.result


def _exit_for(result: PlanResult) -> typer.Exit:
    """The exit of ``plan``: 0 solved and verified, 1 not solved, 3 fails verification."""
    if result.status == "invalid":
        return typer.Exit(EXIT_INVALID_PLAN)
    return typer.Exit(EXIT_SOLVED if result.solved else EXIT_NOT_SOLVED)


def _output_file(path: Path | None, option: str, suffixes: tuple[str, ...] = ()) -> Path | None:
    """Check that an output file can be written before the work that fills it (its folder is made).

    Raises:
        InputError: naming the option and the path: a wrong suffix, a directory, or unwritable.
    """
    if path is None:
        return None
    if suffixes and path.suffix.lower() not in suffixes:
        raise InputError(f"expected a {' or '.join(suffixes)} file, got {str(path)!r}", field=option)
    if path.is_dir():
        raise InputError(f"{path} is a directory, not a file", field=option)
    existed = path.exists()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a"):
            pass
    except OSError as error:
        raise InputError(f"cannot write {path} ({error.strerror or error})", field=option) from None
    if not existed:
        path.unlink()
    return path


def _write_text(path: Path, text: str, option: str) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, text)
    except OSError as error:
        raise InputError(f"cannot write {path} ({error.strerror or error})", field=option) from None


def _write_outputs(result: PlanResult, json_path: Path | None, png_path: Path | None, label: str = "") -> None:
    if json_path is not None:
        _write_text(json_path, result.to_json(indent=1), "--json")
    if png_path is not None:
        from ..outputs.pictures import draw_plan

        draw_plan(result, png_path, label)


def _numbers(text: str, option: str, unit: str) -> list[float]:
    """The comma-separated numbers of ``option`` (in ``unit``, for the message).

    Raises:
        InputError: one is not a number (field ``option``).
    """
    try:
        return [float(value) for value in text.split(",")]
    except ValueError:
        raise InputError(f"expected comma-separated numbers ({unit}), got {text!r}", field=option) from None


def _disturb_values(disturb: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    """``--disturb DX DY DYAW T`` checked: a push within a metre and a turn, T in [0, 600] s (MuJoCo resets
    an object moved beyond any table, and a NaN poisons the simulation).

    Raises:
        InputError: (``--disturb``) naming the value.
    """
    for name, value, bound, unit in zip(("DX", "DY", "DYAW"), disturb, (1.0, 1.0, 2 * math.pi), ("m", "m", "rad")):
        if not math.isfinite(value):
            raise InputError(f"{name} {value} is not a finite number", field="--disturb")
        if abs(value) > bound:
            raise InputError(f"{name} {value:g} is beyond {bound:g} {unit} in magnitude", field="--disturb")
    if not 0.0 <= disturb[3] <= 600.0:
        raise InputError(f"T must be in [0, 600] s, got {disturb[3]:g}", field="--disturb")
    return disturb
