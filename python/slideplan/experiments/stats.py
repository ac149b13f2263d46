"""Statistics of experiment results: Wilson intervals, success-rate curves, mean +- standard error.

The functions take the results DataFrame of :func:`slideplan.experiments.load_results`
(one row per run). Rows whose ``error`` is set (the task raised, a bug rather than a
planning failure) are left out of every statistic by :func:`planning_runs`.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np
import pandas as pd


def mcnemar_exact(first, second) -> tuple[int, int, float]:
    """McNemar's exact test of two paired success series: ``(first only, second only, p)``, p the two-sided
    binomial test of the discordant pairs (1 with none).

    Args:
        first, second: booleans, one per paired task, in the same order.
    """
    from scipy.stats import binomtest

    first, second = np.asarray(first, dtype=bool), np.asarray(second, dtype=bool)
    only_first, only_second = int((first & ~second).sum()), int((second & ~first).sum())
    p = binomtest(only_first, only_first + only_second, 0.5).pvalue if only_first + only_second else 1.0
    return only_first, only_second, float(p)


def wilson_interval(successes, n, confidence: float = 0.95):
    """Wilson score interval of a binomial proportion (closed form, no continuity correction).

    The same interval as ``scipy.stats.binomtest(k, n).proportion_ci(method="wilson")``.

    Args:
        successes: number of successes k (int or array of ints), 0 <= k <= n.
        n: number of trials (int or array), > 0.
        confidence: confidence level in (0, 1).

    Returns:
        (low, high): floats for scalar input, arrays for array input, within [0, 1].

    Raises:
        ValueError: n <= 0, k outside [0, n], or confidence outside (0, 1).
    """
    k = np.asarray(successes, dtype=float)
    trials = np.asarray(n, dtype=float)
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    if np.any(trials <= 0) or np.any(k < 0) or np.any(k > trials):
        raise ValueError(f"need 0 <= successes <= n and n > 0, got successes={successes!r}, n={n!r}")
    z = NormalDist().inv_cdf(0.5 + 0.5 * confidence)
    rate = k / trials
    denominator = 1 + z**2 / trials
    centre = (rate + z**2 / (2 * trials)) / denominator
    half_width = z / denominator * np.sqrt(rate * (1 - rate) / trials + z**2 / (4 * trials**2))
    low, high = np.clip(centre - half_width, 0.0, 1.0), np.clip(centre + half_width, 0.0, 1.0)
    if low.ndim == 0:
        return float(low), float(high)
    return low, high


def mean_and_standard_error(values) -> tuple[float, float]:
    """Mean and standard error of the mean (sample standard deviation / sqrt(n)).

    Args:
        values: a non-empty sequence of numbers.

    Returns:
        (mean, standard error); the standard error is NaN for a single value.

    Raises:
        ValueError: no values.
    """
    array = np.asarray(values, dtype=float)
    if array.size == 0:
        raise ValueError("no values")
    if array.size == 1:
        return float(array[0]), math.nan
    return float(array.mean()), float(array.std(ddof=1) / math.sqrt(array.size))


def planning_runs(results: pd.DataFrame) -> pd.DataFrame:
    """Return the rows that are planning runs: those whose task did not raise (``error`` unset)."""
    return results[results["error"].isna()]


def charged_planning_time(results: pd.DataFrame) -> pd.Series:
    """Planning time charged to each run: its planning time if solved, its time limit if not.

    An unsolved run stopped at its time limit, so its true time to a solution is unknown
    but at least that: charging the limit makes mean planning times lower bounds that
    still count failures, as the paper's averages over all runs do.
    """
    return results["planning_time_s"].where(results["solved"].astype(bool), results["time_limit_s"])


def planning_time_summary(results: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """Mean +- standard error of :func:`charged_planning_time` per group of planning runs.

    Args:
        results: results rows (rows with an error are dropped).
        by: the grouping columns, e.g. ``["object", "scale"]``.

    Returns:
        One row per group, sorted by the grouping columns, with the grouping columns and
        ``runs``, ``solved``, ``mean_s``, ``se_s``.
    """
    runs = planning_runs(results).assign(charged_s=charged_planning_time)
    rows = []
    for key, group in runs.groupby(by, sort=True):
        mean, error = mean_and_standard_error(group["charged_s"])
        key = key if isinstance(key, tuple) else (key,)
        rows.append({**dict(zip(by, key)), "runs": len(group), "solved": int(group["solved"].sum()),
                     "mean_s": mean, "se_s": error})
    return pd.DataFrame(rows, columns=[*by, "runs", "solved", "mean_s", "se_s"])


def success_rate_curve(results: pd.DataFrame, times, confidence: float = 0.95) -> pd.DataFrame:
    """Fraction of runs solved within each time budget, with Wilson intervals (Fig. 11).

    A run counts as a success at time t if it is solved with ``planning_time_s <= t``.

    Args:
        results: the runs of one setting (rows with an error are dropped), at least one.
        times: time budgets (s).
        confidence: level of the Wilson interval.

    Returns:
        Columns ``time_s``, ``runs``, ``successes``, ``rate``, ``low``, ``high``, one row per time.

    Raises:
        ValueError: no planning runs.
    """
    runs = planning_runs(results)
    if runs.empty:
        raise ValueError("no planning runs")
    times = np.asarray(times, dtype=float)
    solved_times = np.sort(runs.loc[runs["solved"].astype(bool), "planning_time_s"].to_numpy(dtype=float))
    successes = np.searchsorted(solved_times, times, side="right")
    low, high = wilson_interval(successes, np.full(times.shape, len(runs)), confidence)
    return pd.DataFrame({"time_s": times, "runs": len(runs), "successes": successes,
                         "rate": successes / len(runs), "low": low, "high": high})


def setting_label(planner: str, reconfiguration_range_m: float) -> str:
    """Name a Fig. 11 setting, e.g. ``"slideplan, dz* = 2 cm"`` or ``"cbirrt, dz* = 2 cm"``."""
    return f"{planner}, dz* = {100 * reconfiguration_range_m:g} cm"


def settings_in_order(results: pd.DataFrame) -> list[tuple[str, float]]:
    """The (planner, reconfiguration range) pairs present, slideplan first, then by planner and range."""
    pairs = results[["planner", "reconfiguration_range_m"]].drop_duplicates().itertuples(index=False)
    return sorted(((planner, float(value)) for planner, value in pairs),
                  key=lambda pair: (pair[0] != "slideplan", pair[0], pair[1]))
