"""The world's verdict on a whole task: what happened to the object, from the simulator's true
state, the same rule for every mode.

A run succeeds when the object is in the hand, at least :data:`HOLD_HEIGHT_M` above the table top,
through the whole hold after the lift. What a camera saw is a diagnostic, never part of the verdict.
:class:`Hold` is the object's true trajectory over the hold (sampled by
:meth:`slideplan.sim.runner.Runner.grasp`); :func:`held` judges it, a pure function of it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

HOLD_HEIGHT_M = 0.03  # the object's lowest point at least 3 cm above the table top
SAMPLE_GAP_S = 0.02  # samples further apart than this (or a record that starts or ends this far from the hold's ends) do not cover it


@dataclass(frozen=True)
class Hold:
    """The object's true state over the hold, sampled.

    Attributes:
        times: (N,) time since the hold began (s), increasing.
        lowest_z: (N,) height of the object's lowest point (m, world).
        in_hand: (N,) the object touched the robot (and only what touches it holds it up off the table).
        duration_s: how long the hold was meant to last (s).
    """

    times: np.ndarray
    lowest_z: np.ndarray
    in_hand: np.ndarray
    duration_s: float

    @classmethod
    def from_samples(cls, samples: list[tuple[float, float, bool]], duration_s: float) -> Hold:
        """From ``(time, lowest z, in hand)`` tuples."""
        array = np.asarray(samples, dtype=float).reshape(-1, 3)
        return cls(array[:, 0], array[:, 1], array[:, 2].astype(bool), float(duration_s))


def held(hold: Hold | None, table_top: float, height: float = HOLD_HEIGHT_M) -> tuple[bool, str]:
    """Whether the object was in the hand, at least ``height`` above ``table_top``, through the whole hold.

    Args:
        hold: the true trajectory over the hold; None when there was none (no grasp, or the run ended first).
        table_top: the table top's height (m).
        height: the least clearance of the object's lowest point over the table top (m).

    Returns:
        (True, "") or (False, why: when in the hold and how the rule was broken).
    """
    if hold is None or len(hold.times) == 0:
        return False, "no hold: the run never reached it"
    times = np.asarray(hold.times, dtype=float)
    if times[0] > SAMPLE_GAP_S or times[-1] < hold.duration_s - SAMPLE_GAP_S or np.any(np.diff(times) > SAMPLE_GAP_S):
        return False, f"the record covers {times[0]:.2f}-{times[-1]:.2f} s of a {hold.duration_s:.2f} s hold"
    clearance = np.asarray(hold.lowest_z, dtype=float) - table_top
    broken = ~np.asarray(hold.in_hand, dtype=bool) | (clearance < height)
    if not broken.any():
        return True, ""
    first = int(np.argmax(broken))
    if not hold.in_hand[first]:
        return False, f"the object was out of the hand {times[first]:.2f} s into the hold"
    return False, (f"the object was {100 * clearance[first]:.1f} cm above the table top {times[first]:.2f} s into the hold "
                   f"(< {100 * height:.0f} cm)")


def judge(hold: Hold | None, table_top: float, failure: tuple[str, str] | None = None,
          clutter: tuple[str, str] | None = None) -> tuple[bool, str | None, str]:
    """A run's outcome: ``(success, failed stage or None, why)``. Success is :func:`held`, with no obstacle
    touched on the way (``clutter``: the stage and what touched what; a plan promises to pass clutter by); a
    failure's stage is the one the run reported on the way (``failure``: e.g. ``("grasp", "not lifted")``),
    else an obstacle's touch, else ``"hold"`` (lifted, then lost or sagging in the hold)."""
    ok, why = held(hold, table_top)
    if ok and clutter is not None:
        return False, clutter[0], clutter[1]
    if ok:
        return True, None, ""
    if failure is None and clutter is not None:
        return False, clutter[0], clutter[1]
    stage, message = failure or ("hold", why)
    return False, stage, message


class HoldWatch:
    """:func:`held` applied while an episode runs, for an agent that lifts when it likes (the environment): the
    samples of the object's true state go in as they come, and the watch says when the last ``duration_s`` of
    them pass :func:`held`, the same rule, at the same sampling, as a run's fixed hold.

    Args:
        table_top: the table top's height (m).
        duration_s: how long the object must be held (s), a run's hold time.
    """

    def __init__(self, table_top: float, duration_s: float) -> None:
        self.table_top, self.duration_s = float(table_top), float(duration_s)
        self._stretch: list[tuple[float, float, bool]] = []  # the samples since the rule last broke

    def add(self, time: float, lowest_z: float, in_hand: bool) -> bool:
        """Take one sample (simulated time s, lowest point's height m, touching the robot); True once the
        object has been held through a whole hold ending now."""
        if self._stretch and time - self._stretch[-1][0] > SAMPLE_GAP_S:
            self._stretch = []  # a gap in the record: it covers nothing before
        if not in_hand or lowest_z - self.table_top < HOLD_HEIGHT_M:
            self._stretch = []
            return False
        self._stretch.append((float(time), float(lowest_z), True))
        start = self._stretch[0][0]
        if self._stretch[-1][0] - start < self.duration_s:
            return False
        samples = [(t - start, z, hand) for t, z, hand in self._stretch]
        return held(Hold.from_samples(samples, self.duration_s), self.table_top)[0]
