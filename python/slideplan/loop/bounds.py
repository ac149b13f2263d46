"""Bounds on a closed-loop run: a run ends its sliding when the finger travels and the object
does not, after :data:`MAX_REPLANS` re-plans, or after :data:`MAX_SLIDE_S` of sliding; the run's report
says which (:attr:`slideplan.sim.closed_loop_run.ClosedLoopRun.slide_stop`)."""

from __future__ import annotations

import numpy as np

from ..transforms import move_planar, rotation_2d

MAX_REPLANS = 20  # the 49efcf6 sweep's closed loop needed at most 11 but in one run (45, pushing for 95 s)
MAX_SLIDE_S = 60.0  # simulated s: ten times a 30 cm slide at the 5 cm/s tip speed
NO_PROGRESS_TRAVEL_M = 0.05  # the fingertip's travel over which the object must be seen to move...
NO_PROGRESS_MOVE_M = 0.005  # ... at least this far where the finger touched it (above the tracker's ~3 mm scatter)


class Progress:
    """Whether a slide still carries the object: the point of the object (as seen) under the fingertip at
    one look must have moved :data:`NO_PROGRESS_MOVE_M` by the time the fingertip has travelled
    :data:`NO_PROGRESS_TRAVEL_M` more. A finger carrying the object moves that point with it, a finger
    turning it about its centre too; a finger slipping over it, or pushing an object stuck fast, does not."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Start afresh (a new slide)."""
        self.travel = 0.0
        self._tip: np.ndarray | None = None
        self._anchor: tuple[np.ndarray, np.ndarray, float] | None = None  # (point in the perceived frame, where, travel)

    def update(self, tip_xy, motion) -> bool:
        """After a look with the fingertip at ``tip_xy`` (m) and the object seen at ``motion`` (from its
        perceived pose; None: not seen). Returns True when the slide makes no progress."""
        tip = np.asarray(tip_xy, dtype=float)[:2]
        if self._tip is not None:
            self.travel += float(np.linalg.norm(tip - self._tip))
        self._tip = tip
        if motion is None:
            return False
        if self._anchor is None:
            x, y, yaw = (float(value) for value in motion)
            self._anchor = ((tip - (x, y)) @ rotation_2d(yaw), tip, self.travel)  # R(yaw)^T (tip - t)
            return False
        point, where, since = self._anchor
        if self.travel - since < NO_PROGRESS_TRAVEL_M:
            return False
        moved = float(np.linalg.norm(move_planar(point, motion) - where))
        self._anchor = None
        if moved < NO_PROGRESS_MOVE_M:
            return True
        self.update(tip, motion)  # anchored anew at this look (the travel already counted)
        return False
