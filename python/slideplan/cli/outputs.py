"""``slideplan export`` and ``view``."""

from __future__ import annotations

import ipaddress
import socket
import time
from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from ..plan.result import PlanResult
from .common import _fail, _output_file, _warnings_as_lines, app


@app.command("export")
def export_command(
    plan_file: Path = typer.Argument(..., help="A solved plan JSON (slideplan.plan/2, or /1: it is timed on export)."),
    fmt: str = typer.Option(..., "--format", help="ros-json (trajectory_msgs/JointTrajectory per segment) or csv."),
    out: Path = typer.Option(..., "--out", help="Output file."),
) -> None:
    """Write a plan's timed slide and approach for a controller.

    Exit codes: 0 written, 2 bad input (unreadable or unknown plan, plan not solved, unknown format).
    """
    from ..outputs.export import export_plan

    try:
        result = PlanResult.load(plan_file)
        with _warnings_as_lines():
            export_plan(result, fmt, out)
    except InputError as error:
        if not error.source and error.field != "--format":  # e.g. "status": a field of the plan file
            error = InputError(error.problem, source=str(plan_file), field=error.field)
        raise _fail(error) from None
    except OSError as error:
        raise _fail(error) from None
    typer.echo(str(out))


@app.command("view")
def view_command(
    plan_file: Path = typer.Argument(..., help="A plan JSON (slideplan.plan/1 or /2, solved or not)."),
    host: str = typer.Option("127.0.0.1", "--host", help="Interface to listen on (default: this machine only)."),
    port: int = typer.Option(8080, "--port", help="Port to try first; the next free one is used if it is taken."),
    record_out: Optional[Path] = typer.Option(
        None, "--record", help="Instead of serving, write the animated view to OUT.html (opens in any browser) or OUT.viser."
    ),
) -> None:
    """Show a plan in 3D in the browser: robot, table, object, fingertip path, grasp; a time slider plays the plan.

    Exit codes: 0 (after Ctrl-C, or once the recording is written), 2 bad input.
    """
    try:
        from ..outputs import view3d as view

        record_out = _output_file(record_out, "--record")
        result = PlanResult.load(plan_file)
        if not 0 <= port < 65536:
            raise InputError(f"must be in [0, 65536), got {port}", field="--port")
        with _warnings_as_lines():
            if record_out is not None:
                typer.echo(str(view.record(result, record_out)))
                return
            shown = view.open_view(result, host, port)
    except InputError as error:
        if not error.source and not error.field.startswith("--"):  # a field of the plan file
            error = InputError(error.problem, source=str(plan_file), field=error.field)
        raise _fail(error) from None
    except ImportError as error:
        raise _fail(error) from None
    except OSError as error:  # an unwritable --record
        raise _fail(InputError(str(error), field="--record")) from None
    if shown.server.get_port() != port:
        typer.echo(f"slideplan: port {port} is in use; using {shown.server.get_port()}", err=True)
    if not _is_loopback(host):
        where = "every network interface" if host in ("0.0.0.0", "::", "") else host
        typer.echo(f"slideplan: warning: serving on {where}: anyone who can reach this machine on port "
                   f"{shown.server.get_port()} can open the view (there is no password)", err=True)
    status = "" if result.solved else f" (not solved: {result.status}; showing the scene only)"
    typer.echo(f"view at {shown.url}{status}; Ctrl-C to stop")
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        shown.server.stop()


def _is_loopback(host: str) -> bool:
    """Whether ``host`` is this machine only (an address or a name resolved here)."""
    try:
        return ipaddress.ip_address(socket.gethostbyname(host) if ":" not in host else host).is_loopback
    except (OSError, ValueError, UnicodeError):
        return False
