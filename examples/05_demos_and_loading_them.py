"""Demonstrations for robot learning: record closed-loop episodes as a LeRobotDataset v3.0 with
`slideplan demos` (the `lerobot` extra), then load them with lerobot's own API.

    python examples/05_demos_and_loading_them.py [OUT_DIR] [EPISODES]
"""

import subprocess
import sys

out = sys.argv[1] if len(sys.argv) > 1 else "demos/example"
episodes = sys.argv[2] if len(sys.argv) > 2 else "4"
subprocess.run([sys.executable, "-m", "slideplan.cli", "demos", "--scene", "square", "--episodes", episodes,
                "--out", out, "--workers", "1", "--seed", "1"], check=True)

from lerobot.datasets.lerobot_dataset import LeRobotDataset  # noqa: E402

dataset = LeRobotDataset("slideplan/demos", root=out)
frame = dataset[0]
print(f"{dataset.num_episodes} episodes, {dataset.num_frames} frames; task: {frame['task']!r}")
print("state", tuple(frame["observation.state"].shape), "action", tuple(frame["action"].shape))
