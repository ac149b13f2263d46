"""Plan a slide and verify it: a crescent on the square table, planned with the bundled WAM + T42.

The plan is a joint trajectory that slides the object until it overhangs a table edge, and a side grasp.
The verifier re-checks every claim of the plan from its data alone.

    python examples/01_plan_and_verify.py [OUT.json]
"""

import sys

import slideplan

scene = slideplan.load_scene("square")
crescent = slideplan.load_object("crescent", table_height=scene.table.height, pose=(0.55, -0.08, 0.4))
result = slideplan.plan(scene, crescent, slideplan.PlannerConfig(seed=1, time_limit_s=10))
if not result.solved:
    sys.exit(f"not solved: {result.status}")
verification = slideplan.verify(result)
print(f"overhang {100 * result.overhang_m:.1f} cm, {len(result.trajectory)} waypoints, verified: {verification.ok}")
assert verification.ok, verification.violations
out = sys.argv[1] if len(sys.argv) > 1 else "plan.json"
with open(out, "w") as file:
    file.write(result.to_json())
print(f"wrote {out}")
