"""``slideplan eval``: a policy scored on a tier of SlideToEdge's frozen benchmark (docs/benchmark.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from .common import EXIT_NOT_SOLVED, _fail, app
from .experiments import _experiment_executor, _tally_bar


@app.command("eval")
def eval_command(
    policy: str = typer.Option(..., "--policy", help="expert (the planner), a LeRobot pretrained policy folder, "
                               "or module:callable (observation -> action)."),
    tier: str = typer.Option(..., "--tier", help="nominal, random or hard (the closed loop's settings)."),
    out: Path = typer.Option(..., "--out", help="Where the rows go (OUT/results/POLICY/); a run again with the same "
                             "--out skips the tasks that have one."),
    episodes: Optional[int] = typer.Option(None, "--episodes", help="The tier's first N tasks (default: all 100)."),
    workers: Optional[int] = typer.Option(None, "--workers", help="Local worker processes (default: all cores)."),
    scheduler: Optional[str] = typer.Option(
        None, "--scheduler", help="Run on a Dask cluster at this scheduler address instead (e.g. tcp://host:8786)."
    ),
) -> None:
    """Score a policy on a tier of the frozen protocol: one episode per task, judged by the world's verdict.

    Prints success with its 95% Wilson interval, the mean episode length and, where OUT holds the expert's
    rows for the same tasks, the paired comparison with it. Exit codes: 0 every task has a row, 1 some
    episodes lost (a worker died; run the same command again), 2 bad input.
    """
    try:
        from ..benchmark.evaluate import evaluate, expert_rows, summary
        from ..benchmark.protocol import load_protocol

        protocol = load_protocol()
        tasks = protocol.tier(tier, episodes)
        executor = _experiment_executor(workers, scheduler)
        typer.echo(f"eval: {policy} on {protocol.env_id} tier {tier}, {len(tasks)} episodes on {executor.description}")
        with _tally_bar("eval", "") as (_, show):
            rows = evaluate(protocol, tier, policy, out, executor, episodes,
                            progress=lambda done, total: show({"total": total, "done": done}))
    except InputError as error:
        raise _fail(error) from None
    except (ImportError, OSError) as error:
        raise _fail(error) from None
    if len(rows):
        for line in summary(rows, expert_rows(out, rows["task_id"])):
            typer.echo(line)
    if rows.attrs.get("lost"):
        typer.echo(f"slideplan: {rows.attrs['lost']} episodes lost; rerun the same command to run them", err=True)
        raise typer.Exit(EXIT_NOT_SOLVED)
