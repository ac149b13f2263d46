"""Your own robot: a scene file names the URDF, its mount and the hand's frames; the planner does the rest.
Here the Franka Panda of example-robot-data (the `robots` extra), from data/scenes/panda_square.toml, plans
and is verified; `slideplan check-scene` tells what stands between a new scene and its first plan.
docs/own-robot.md walks through the keys.

    python examples/04_your_own_robot.py [SCENE.toml]
"""

import sys

import slideplan

scene = slideplan.load_scene(sys.argv[1] if len(sys.argv) > 1 else "panda_square")
print(f"robot {scene.urdf_path.name}, contact frame {scene.tip_link}, grasp frame {scene.hand.grasp_link}")
centre = scene.table.polygon.centroid
crescent = slideplan.load_object("crescent", table_height=scene.table.height, pose=(centre.x, centre.y, 0.3))
result = slideplan.plan(scene, crescent, slideplan.PlannerConfig(seed=1, time_limit_s=20))  # the hand's parameters
print(f"{result.status}; verified: {result.solved and slideplan.verify(result).ok}")
sys.exit(0 if result.solved and slideplan.verify(result).ok else 1)
