"""Figures 10-12 of the paper from experiment results (PNG and SVG).

Every function takes the results DataFrame of :func:`slideplan.experiments.load_results`
(rows of one experiment), drops rows whose task raised (``error`` set), and writes
``<name>.png`` and ``<name>.svg``.

Planning times (Figs. 10 and 12): the paper averages the planning time of all its runs.
A run that is not solved within its time limit is counted **at the time limit**
(:func:`slideplan.experiments.charged_planning_time`), so failures raise the mean instead
of vanishing from it, and the mean is a lower bound of the true mean time to a solution.
The axis labels say so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from .results import load_results
from .stats import planning_runs, planning_time_summary, setting_label, settings_in_order, success_rate_curve
from .tasks import OBJECTS, TABLES
from ..outputs.pictures import save_figure

FORMATS = ("png", "svg")
_CURVE_POINTS = 400


def save_figures(figure: Figure, out_dir: str | Path, name: str) -> list[Path]:
    """Write ``name`` in every format of :data:`FORMATS` to ``out_dir`` and return the paths."""
    return [save_figure(figure, Path(out_dir) / f"{name}.{suffix}") for suffix in FORMATS]


def _time_label(results: pd.DataFrame) -> str:
    """Y-axis label of a mean planning time, saying how unsolved runs count."""
    limits = results["time_limit_s"].unique()
    limit = f"{limits[0]:g} s" if len(limits) == 1 else "its time limit"
    return f"mean planning time (s)\nunsolved runs counted at {limit}"


def _ordered(values, preferred: tuple[str, ...]) -> list[str]:
    """The distinct ``values``, in ``preferred`` order first, any others after, sorted."""
    present = set(values)
    return [name for name in preferred if name in present] + sorted(present - set(preferred))


def _grouped_bars(axes, summary: pd.DataFrame, category: str, order: list[str]) -> None:
    """Bars of mean +- s.e. per category, one bar per scale side by side."""
    scales = sorted(summary["scale"].unique(), reverse=True)
    width = 0.8 / len(scales)
    positions = np.arange(len(order))
    for index, scale in enumerate(scales):
        rows = summary[summary["scale"] == scale].set_index(category).reindex(order)
        axes.bar(positions + (index - (len(scales) - 1) / 2) * width, rows["mean_s"], width,
                 yerr=rows["se_s"].fillna(0.0), capsize=3, label=f"scale {scale:g}")
    axes.set_xticks(positions, order)
    axes.grid(True, axis="y", linewidth=0.3)
    axes.legend(title="object size")



def _runs_to_plot(results: pd.DataFrame) -> pd.DataFrame:
    """The planning runs of ``results``; ValueError if there are none."""
    runs = planning_runs(results)
    if runs.empty:
        raise ValueError("no planning runs to plot")
    return runs

def plot_planning_time_by_geometry(results: pd.DataFrame, out_dir: str | Path, name: str = "fig10") -> list[Path]:
    """Fig. 10: mean planning time +- standard error per object (top) and per table (bottom).

    Each panel shows full- and half-scale objects side by side. Every run counts, unsolved
    ones at the time limit (module docstring); the bottom panel averages over objects.

    Args:
        results: rows of the fig10 experiment (any scenes, objects and scales).
        out_dir: where to write ``<name>.png`` and ``<name>.svg``.
        name: the file name stem.

    Returns:
        The PNG and SVG paths.

    Raises:
        ValueError: no planning runs.
    """
    runs = _runs_to_plot(results)
    figure = Figure(figsize=(8, 7), layout="constrained")
    top, bottom = figure.subplots(2, 1)
    for axes, category, order, title in (
        (top, "object", _ordered(runs["object"], OBJECTS), "per object (averaged over tables)"),
        (bottom, "scene", _ordered(runs["scene"], TABLES), "per table (averaged over objects)"),
    ):
        _grouped_bars(axes, planning_time_summary(runs, [category, "scale"]), category, order)
        axes.set_title(f"Planning time {title}, n = {len(runs)} runs")
        axes.set_xlabel("object" if category == "object" else "table")
        axes.set_ylabel(_time_label(runs))
    return save_figures(figure, out_dir, name)


SHADED_MIN_RUNS = 30  # below this many runs per curve, intervals are wide: shading them washes the figure out


def draw_interval(axes, curve: pd.DataFrame, color, runs: int) -> None:
    """A success-rate curve's 95% Wilson interval: shaded, or for fewer than :data:`SHADED_MIN_RUNS`
    runs its two bounds as dotted lines (wide overlapping shades of small experiments mix into one)."""
    if runs >= SHADED_MIN_RUNS:
        axes.fill_between(curve["time_s"], 100 * curve["low"], 100 * curve["high"], step="post",
                          color=color, alpha=0.15, linewidth=0)
        return
    for bound in ("low", "high"):
        axes.step(curve["time_s"], 100 * curve[bound], where="post", color=color, linestyle=":", linewidth=0.8)


def plot_success_rate_vs_time(results: pd.DataFrame, out_dir: str | Path, name: str = "fig11") -> list[Path]:
    """Fig. 11: fraction of runs solved within a time budget, one curve per setting.

    Settings are the (planner, reconfiguration range) pairs present, e.g. slideplan at
    dz* = 0, 0.5 and 2 cm and the CBiRRT/CBiRRT2 baselines at 2 cm; shaded bands are 95%
    Wilson intervals. The time axis is logarithmic: solved runs span milliseconds to the
    time limit.

    Args:
        results: rows of the fig11 experiment.
        out_dir: where to write ``<name>.png`` and ``<name>.svg``.
        name: the file name stem.

    Returns:
        The PNG and SVG paths.

    Raises:
        ValueError: no planning runs.
    """
    runs = _runs_to_plot(results)
    solved_times = runs.loc[runs["solved"].astype(bool), "planning_time_s"]
    start = max(min(solved_times.min() if len(solved_times) else 1e-2, 1e-2), 1e-4)
    times = np.geomspace(start, runs["time_limit_s"].max(), _CURVE_POINTS)
    figure = Figure(figsize=(8, 5), layout="constrained")
    axes = figure.add_subplot()
    for planner, reconfiguration_range in settings_in_order(runs):
        rows = runs[(runs["planner"] == planner) & (runs["reconfiguration_range_m"] == reconfiguration_range)]
        curve = success_rate_curve(rows, times)
        line, = axes.step(curve["time_s"], 100 * curve["rate"], where="post",
                          label=f"{setting_label(planner, reconfiguration_range)} (n = {len(rows)})")
        draw_interval(axes, curve, line.get_color(), len(rows))
    axes.set_xscale("log")
    axes.set_ylim(0, 100)
    axes.set_xlabel("planning time budget (s)")
    axes.set_ylabel("runs solved within the budget (%)")
    axes.set_title(f"Success rate vs planning time (95% Wilson interval: shaded, dotted where n < {SHADED_MIN_RUNS})")
    axes.grid(True, which="both", linewidth=0.3)
    axes.legend(loc="lower right")
    return save_figures(figure, out_dir, name)


def plot_planning_time_vs_n_star(results: pd.DataFrame, out_dir: str | Path, name: str = "fig12") -> list[Path]:
    """Fig. 12: mean planning time +- standard error against N* (log axis).

    Every run counts, unsolved ones at the time limit (module docstring); the success
    rate of each N* is written next to its point.

    Args:
        results: rows of the fig12 experiment.
        out_dir: where to write ``<name>.png`` and ``<name>.svg``.
        name: the file name stem.

    Returns:
        The PNG and SVG paths.

    Raises:
        ValueError: no planning runs.
    """
    runs = _runs_to_plot(results)
    summary = planning_time_summary(runs, ["n_star"])
    figure = Figure(figsize=(7, 4.5), layout="constrained")
    axes = figure.add_subplot()
    axes.errorbar(summary["n_star"], summary["mean_s"], yerr=summary["se_s"].fillna(0.0), marker="o", capsize=4)
    for row in summary.itertuples():
        axes.annotate(f"{100 * row.solved / row.runs:.0f}% solved", (row.n_star, row.mean_s),
                      textcoords="offset points", xytext=(6, 6), fontsize=8)
    axes.set_xscale("log")
    axes.set_xlabel("N* (Eq. 5): larger adds start and goal roots more readily")
    axes.set_ylabel(_time_label(runs))
    ranges = ", ".join(f"{100 * value:g} cm" for value in sorted(runs["reconfiguration_range_m"].unique()))
    axes.set_title(f"Planning time vs N* (dz* = {ranges}, n = {len(runs)} runs)")
    axes.grid(True, which="both", linewidth=0.3)
    return save_figures(figure, out_dir, name)


_PLOTTERS = {
    "fig10": plot_planning_time_by_geometry,
    "fig11": plot_success_rate_vs_time,
    "fig12": plot_planning_time_vs_n_star,
}


def plot_results(results: pd.DataFrame | str | Path, out_dir: str | Path) -> list[Path]:
    """Draw every figure the results support: fig10, fig11 and fig12 for the experiments present.

    Args:
        results: a results DataFrame, or a path :func:`slideplan.experiments.load_results` reads.
        out_dir: where to write the figures (created if missing).

    Returns:
        The written paths (PNG and SVG per figure), empty if no experiment has planning runs.

    Raises:
        FileNotFoundError: ``results`` is a path that does not exist.
    """
    if not isinstance(results, pd.DataFrame):
        results = load_results(results)
    runs = planning_runs(results)
    paths = []
    for experiment, plotter in _PLOTTERS.items():
        rows = runs[runs["experiment"] == experiment]
        if not rows.empty:
            paths += plotter(rows, out_dir, experiment)
    return paths
