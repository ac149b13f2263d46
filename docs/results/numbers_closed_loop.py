"""Generated blocks of issue 53's closed-loop evaluation (docs/results/closed_loop.md): the world's verdict
per task set, setting and mode, from ``closed_loop_dev.parquet`` and ``closed_loop_eval.parquet`` (one row
per run, :func:`slideplan.experiments.closed_loop.closed_loop_runs`). A set without its file is reported as
not run yet."""

from __future__ import annotations

from numbers_common import HERE, rows
from slideplan.experiments.closed_loop_report import SETS, report

SET_FILES = {name: f"closed_loop_{name}.parquet" for name in SETS}


def values() -> dict[str, str]:
    """The ``cl53-report`` block, and the README's sentence on the eval set (``readme-cl53-eval``)."""
    sets = {name: rows(file, "runs") if (HERE / file).exists() else None for name, file in SET_FILES.items()}
    return {"cl53-report": report(sets), "readme-cl53-eval": eval_sentence(sets["eval"])}


def eval_sentence(runs) -> str:
    """True success on the eval set per setting, closed loop then open loop, or that it has not been run."""
    if runs is None or not len(runs):
        return "the held-out `eval` set has not been run yet, so there are no numbers for it"
    ok = runs.assign(ok=runs["success"].fillna(False).astype(bool)).groupby(["setting", "mode"], sort=False)["ok"].mean()
    settings = list(dict.fromkeys(runs["setting"]))
    return ("on the held-out `eval` set, judged by the world, the closed loop succeeded in "
            + ", ".join(f"{100 * ok[(setting, 'closed')]:.1f}% ({setting})" for setting in settings)
            + " of runs, the open loop in " + ", ".join(f"{100 * ok[(setting, 'open')]:.1f}%" for setting in settings))
