"""The whole task from a depth camera's view, with a push: perceive, plan, slide; 2 s into the slide someone
pushes the object 3 cm and 10 degrees; the loop sees it, re-plans from where the arm is, and grasps the
object where it is seen. Success is the world's verdict (the object held 3 cm up through the hold), in
both modes; the open loop executes its first plan blind.

    python examples/03_closed_loop_with_a_push.py [--open-loop]
"""

import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")  # the depth camera renders headless

from slideplan.sim.closed_loop import run
from slideplan.sim.conditions import Disturbance

push = Disturbance(dx=0.0, dy=-0.03, dyaw=0.17, after_s=2.0)
report = run("square", "crescent", (0.55, -0.08, 0.4), seed=1, closed="--open-loop" not in sys.argv, disturbance=push)
print(f"{report.mode} loop: success {report.success}, {report.replans} re-plans"
      + (f", failed at {report.failed_stage}: {report.failure}" if not report.success else ""))
sys.exit(0 if report.success else 1)
