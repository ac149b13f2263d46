"""The environment `slideplan/SlideToEdge-v1` (Gymnasium, the `execution` extra), driven by its expert: the
planner's action from the current state. Swap `expert_action()` for your policy's action.

    python examples/06_environment_with_its_expert.py [SEED] [MAX_STEPS]
"""

import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import gymnasium as gym

import slideplan.demos.env  # noqa: F401  registers slideplan/SlideToEdge-v1

seed = int(sys.argv[1]) if len(sys.argv) > 1 else 7
max_steps = int(sys.argv[2]) if len(sys.argv) > 2 else 10_000
env = gym.make("slideplan/SlideToEdge-v1", obs_type="state", action_type="joint")
observation, info = env.reset(seed=seed)
steps, total = 0, 0.0
for steps in range(1, max_steps + 1):
    observation, reward, terminated, truncated, info = env.step(env.unwrapped.expert_action())
    total += reward
    if terminated or truncated:
        break
print(f"{steps} steps, return {total:.2f}, success: {info['is_success']}")
env.close()
