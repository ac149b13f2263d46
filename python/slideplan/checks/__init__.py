"""Checks of plans and runs, each recomputed from data, never taken from the planner's word.

- :mod:`.common`: what every check of a plan shares: tolerances, the plan's world, limit, collision and
  step violations;
- :mod:`.grasp`: the grasp's checks: the grasp frame, the hold, the approach;
- :mod:`.verify`: the verifier, :func:`~slideplan.checks.verify.verify`: every claim of a plan recomputed;
- :mod:`.pipeline`: plan, verify, mark: the one pipeline of the CLI, the ROS node, the loop and the experiments;
- :mod:`.scene`: what stands between a new scene and its first plan;
- :mod:`.verdict`: the world's verdict on a run, from the simulator's true state (the one success rule).
"""

from .._moved import forwarding

__getattr__ = forwarding(__name__, __path__, "slideplan.checks.common", api=())
