"""Regenerate every number that comes from the committed rows: tables.md whole, and each marked block
of README.md, docs/planning.md and docs/results/*.md.

One command rewrites them all from the Parquet files next to this script (through the loaders of
``slideplan.experiments``); ``--check`` rewrites nothing and exits 1 naming each file and block that
would change (tests/python/test_numbers.py runs it)::

    .venv/bin/python docs/results/make_tables.py            # rewrite
    .venv/bin/python docs/results/make_tables.py --check    # exit 1 if any text would change

**Marked blocks.** A number written from the rows sits between two HTML comments, which markdown does
not show::

    the slowest in <!-- generated: fig10-default-full -->0.099 s<!-- /generated --> ...

    <!-- generated: cl-49efcf6-summary -->
    | setting | mode | ... |
    <!-- /generated -->

The name says which value goes there (the functions ``values()`` of ``numbers_planning.py``,
``numbers_execution.py``, ``numbers_closed_loop.py``, ``numbers_benchmarks.py``, ``numbers_hands.py`` and ``numbers_grasp_model.py`` make them). A block whose opening comment ends
its line is a block of lines
(tables); any other is inline and must not start a line (markdown would take the line for raw HTML).
Edit the text around a block freely; edit inside it and the next run (or ``--check``) puts the rows'
value back. An unknown name, an unclosed block or a nested one is an error (exit 2).

To commit the results of a run::

    PYTHONPATH=python python -c "from slideplan.experiments import load_results; \\
        load_results('out/fig11').to_parquet('docs/results/fig11.parquet')"
    .venv/bin/python docs/results/backfill_provenance.py fig11.parquet  # the committed column types; keeps the builds
    .venv/bin/python docs/results/make_tables.py

Other options: ``--root DIR`` (the repository whose README.md, docs/planning.md and docs/results/*.md are rewritten;
the data always come from this folder), ``--figures`` (also redraw figures/execution.png), ``--replan``
(print the execution page's grasp, contact and depth tables, which the rows do not hold, by re-planning
each task: right only with the build that made execution.parquet). Unsolved runs count at their time
limit in mean planning times (as in the figures); rows of tasks that raised are left out.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import pandas as pd

from slideplan.experiments import load_results, planning_runs, planning_time_summary, success_rate_curve
from slideplan.experiments.stats import setting_label, settings_in_order

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
MARKED_PAGES = ("README.md", "docs/planning.md", "docs/results/*.md")  # globs under the root: every page that may hold blocks
TABLES = "docs/results/tables.md"  # generated whole
FIGURE_INPUTS = ("fig10.parquet", "fig10_paper.parquet", "fig11.parquet", "fig11_paper.parquet",
                 "fig12.parquet", "fig12_paper.parquet")
OPEN, CLOSE = "<!-- generated: ", "<!-- /generated -->"
BLOCK = re.compile(r"<!-- generated: (?P<name>[a-z0-9][a-z0-9_.-]*) -->(?P<body>.*?)<!-- /generated -->", re.S)
SUCCESS_TIMES_S = (1.0, 5.0, 10.0, 20.0, 60.0)


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    """A GitHub markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def mean_cell(row) -> str:
    """``mean +- s.e. s (solved/runs)``."""
    spread = "" if pd.isna(row.se_s) else f" ± {row.se_s:.3f}"
    return f"{row.mean_s:.3f}{spread} s ({row.solved}/{row.runs})"


def success_table(runs: pd.DataFrame) -> str:
    """Fig. 11: success rate [95% Wilson interval] at fixed budgets, per setting."""
    rows = []
    for planner, reconfiguration_range in settings_in_order(runs):
        setting = runs[(runs["planner"] == planner) & (runs["reconfiguration_range_m"] == reconfiguration_range)]
        curve = success_rate_curve(setting, SUCCESS_TIMES_S)
        limit = setting["time_limit_s"].max()
        cells = [
            f"{100 * point.rate:.1f}% [{100 * point.low:.1f}, {100 * point.high:.1f}]" if point.time_s <= limit else "—"
            for point in curve.itertuples()
        ]
        rows.append([setting_label(planner, reconfiguration_range), str(len(setting)), *cells])
    header = ["setting", "runs", *(f"≤ {time:g} s" for time in SUCCESS_TIMES_S)]
    return markdown_table(header, rows)


def by_category_table(runs: pd.DataFrame, category: str, title: str) -> str:
    """Fig. 10: mean planning time ± s.e. per ``category`` column (headed ``title``), one column per scale."""
    summary = planning_time_summary(runs, [category, "scale"])
    scales = sorted(summary["scale"].unique(), reverse=True)
    rows = []
    for name, group in summary.groupby(category, sort=False):
        by_scale = {row.scale: mean_cell(row) for row in group.itertuples()}
        rows.append([str(name), *(by_scale.get(scale, "—") for scale in scales)])
    return markdown_table([title, *(f"scale {scale:g}" for scale in scales)], rows)


def n_star_table(runs: pd.DataFrame) -> str:
    """Fig. 12: mean planning time ± s.e. per N*."""
    rows = [[f"{row.n_star:g}", mean_cell(row)] for row in planning_time_summary(runs, ["n_star"]).itertuples()]
    return markdown_table(["N*", "mean planning time (solved/runs)"], rows)


def tables(results: pd.DataFrame) -> str:
    """All tables the results support, as one markdown document."""
    runs = planning_runs(results)
    sections = ["# Results tables\n\nGenerated by `docs/results/make_tables.py` from the Parquet files; "
                "unsolved runs count at their time limit in means."]
    fig10 = runs[runs["experiment"] == "fig10"].fillna({"preset": "default", "params": ""})  # older rows: no preset
    for (preset, params), group in fig10.groupby(["preset", "params"], sort=True):  # one run per preset and --param set
        overrides = ", ".join(f"{name} = {value:g}" for name, value in json.loads(params).items()) if params else ""
        label = ", ".join(filter(None, [f"preset {preset}", overrides]))
        title = f"Fig. 10 ({label}, {group['pose_index'].nunique()} poses per cell)"
        sections += [f"## {title}: planning time per object", by_category_table(group, "object", "object"),
                     f"## {title}: planning time per table", by_category_table(group, "scene", "table")]
    # The baselines run as published in both presets: the same tasks, in both files, shown once per preset.
    fig11 = runs[runs["experiment"] == "fig11"].drop_duplicates("task_id")
    baselines = fig11[fig11["planner"] != "slideplan"]
    for preset, ours in fig11[fig11["planner"] == "slideplan"].groupby("preset", sort=True):
        group = pd.concat([ours, baselines])
        sections += [f"## Fig. 11 (preset {preset} for slideplan, {group['pose_index'].nunique()} poses per object): "
                     "success rate within a time budget [95% Wilson interval]", success_table(group)]
    fig12 = runs[runs["experiment"] == "fig12"].fillna({"preset": "default"})
    for preset, group in fig12.groupby("preset", sort=True):
        sections += [f"## Fig. 12 (preset {preset}, {group['pose_index'].nunique()} poses per object): planning time per N*",
                     n_star_table(group)]
    return "\n\n".join(sections) + "\n"


class BlockError(Exception):
    """A page's markers are malformed or name no known value."""


def fill_blocks(text: str, values: dict[str, str], where: str) -> tuple[str, list[str]]:
    """Put each marked block's value in ``text``.

    Returns:
        The new text and the names of the blocks whose content changed, in order.

    Raises:
        BlockError: an unknown name, an unclosed or nested block, an inline block at the start of a line
            or given a value of several lines (naming ``where`` and the line).
    """
    pieces, changed, position = [], [], 0
    for match in BLOCK.finditer(text):
        line = text.count("\n", 0, match.start()) + 1
        name, body = match["name"], match["body"]
        if OPEN in body:
            raise BlockError(f"{where}:{line}: block {name} is not closed before the next one opens")
        if name not in values:
            raise BlockError(f"{where}:{line}: no value named {name!r} (known to numbers_*.py: see make_tables.py)")
        value = values[name]
        if body.startswith("\n"):
            new = "\n" + value.strip("\n") + "\n"
        else:
            if not text[text.rfind("\n", 0, match.start()) + 1:match.start()].strip():
                raise BlockError(f"{where}:{line}: inline block {name} starts a line (markdown would show it as raw HTML)")
            if "\n" in value:
                raise BlockError(f"{where}:{line}: block {name} is inline but its value has several lines")
            new = value
        if new != body:
            changed.append(name)
        pieces += [text[position:match.start()], f"{OPEN}{name} -->{new}{CLOSE}"]
        position = match.end()
    pieces.append(text[position:])
    result = "".join(pieces)
    if result.count(OPEN) != result.count(CLOSE) or text.count(OPEN) != len(BLOCK.findall(text)):
        raise BlockError(f"{where}: a '{OPEN}...' marker without its '{CLOSE}' (or the reverse)")
    return result, changed


def all_values() -> dict[str, str]:
    """Every block value, by name."""
    sys.path.insert(0, str(HERE))
    import numbers_benchmarks
    import numbers_closed_loop
    import numbers_execution
    import numbers_grasp_model
    import numbers_hands
    import numbers_headline
    import numbers_planning

    parts = [numbers_planning.values(), numbers_execution.values(), numbers_closed_loop.values(), numbers_benchmarks.values(),
             numbers_hands.values(), numbers_headline.values(), numbers_grasp_model.values()]
    names = [name for part in parts for name in part]
    clash = {name for name in names if names.count(name) > 1}
    assert not clash, f"block names defined twice: {sorted(clash)}"
    return {name: value for part in parts for name, value in part.items()}


def marked_pages(root: Path) -> list[Path]:
    """The pages that may hold marked blocks, sorted (tables.md is generated whole)."""
    pages = {path for pattern in MARKED_PAGES for path in root.glob(pattern)}
    return sorted(path for path in pages if path != root / TABLES)


def regenerate(root: Path, check: bool, values: dict[str, str] | None = None) -> list[str]:
    """Rewrite (or with ``check`` only compare) tables.md and every marked block under ``root``.

    Returns:
        One line per file and block that changed (or would change), e.g. ``README.md: block readme-dz0``.
    """
    values = all_values() if values is None else values
    report = []
    tables_text = tables(pd.concat([load_results(HERE / name) for name in FIGURE_INPUTS], ignore_index=True))
    outputs = {root / TABLES: tables_text}
    for page in marked_pages(root):
        text = page.read_text()
        new, changed = fill_blocks(text, values, str(page.relative_to(root)))
        report += [f"{page.relative_to(root)}: block {name}" for name in changed]
        outputs[page] = new
    tables_path = root / TABLES
    if not tables_path.exists() or tables_path.read_text() != tables_text:
        report.append(f"{TABLES}: the tables")
    if not check:
        for path, text in outputs.items():
            if not path.exists() or path.read_text() != text:
                path.write_text(text)
    return report


def main(argv: list[str] | None = None) -> int:
    """Rewrite or check the generated text; return the exit code (1: ``--check`` found changes, 2: bad markers)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 naming each block that would change")
    parser.add_argument("--root", type=Path, default=ROOT, help="repository whose README.md, docs/planning.md and docs/results/*.md to rewrite")
    parser.add_argument("--figures", action="store_true", help="also redraw figures/execution.png and .svg")
    parser.add_argument("--replan", action="store_true",
                        help="print the execution page's re-planned tables (needs the build of execution.parquet)")
    args = parser.parse_args(argv)
    if args.replan:
        sys.path.insert(0, str(HERE))
        import numbers_common
        import numbers_execution

        print(numbers_execution.replanned_tables(numbers_common.rows("execution.parquet", "execution")))
        return 0
    try:
        report = regenerate(args.root.resolve(), args.check)
    except BlockError as error:
        print(f"make_tables: error: {error}", file=sys.stderr)
        return 2
    for line in report:
        print(f"{'would change' if args.check else 'rewrote'}: {line}", file=sys.stderr if args.check else sys.stdout)
    if args.figures and not args.check:
        sys.path.insert(0, str(HERE))
        import numbers_execution

        for path in numbers_execution.draw_execution_figure():
            print(path)
    return 1 if args.check and report else 0


if __name__ == "__main__":
    sys.exit(main())
