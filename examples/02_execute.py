"""Execute a plan in MuJoCo physics: the slide with a compliant finger, then the grasp, a 5 cm lift and a
1 s hold (the `execution` extra). Plans first, as example 01 does, unless given a plan file.

    python examples/02_execute.py [PLAN.json]
"""

import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering, should a video be asked for

import slideplan
from slideplan.sim import execute

if len(sys.argv) > 1:
    result = slideplan.PlanResult.load(sys.argv[1])
else:
    scene = slideplan.load_scene("square")
    crescent = slideplan.load_object("crescent", table_height=scene.table.height, pose=(0.55, -0.08, 0.4))
    result = slideplan.plan(scene, crescent, slideplan.PlannerConfig(seed=1, time_limit_s=10))
execution = execute(result)
print(f"success: {execution.success}; Eq. 2 error {1000 * execution.position_error_m:.1f} mm / "
      f"{execution.yaw_error_deg:.1f} deg; lifted: {execution.lifted}; "
      f"{execution.sim_time_s:.1f} s simulated in {execution.wall_time_s:.1f} s")
sys.exit(0 if execution.success else 1)
