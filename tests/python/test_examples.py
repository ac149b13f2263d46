"""The numbered examples in examples/ run as a user runs them, each in a fresh interpreter, and say what
they did; the long ones shortened through their arguments, the physics and lerobot ones under their markers."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def run_example(name: str, *arguments: str, cwd: Path) -> subprocess.CompletedProcess:
    done = subprocess.run([sys.executable, str(EXAMPLES / name), *arguments], capture_output=True, text=True, cwd=cwd,
                          timeout=900, env={**os.environ, "MUJOCO_GL": "egl"})
    assert done.returncode == 0, done.stdout + done.stderr
    return done


def test_the_examples_are_numbered_and_each_has_a_test():
    names = sorted(path.name for path in EXAMPLES.glob("*.py"))
    assert [name[:3] for name in names] == [f"{index:02d}_" for index in range(1, len(names) + 1)]
    tested = Path(__file__).read_text()
    assert all(f'"{name}"' in tested for name in names)


def test_plan_and_verify(tmp_path):
    done = run_example("01_plan_and_verify.py", "plan.json", cwd=tmp_path)
    assert "verified: True" in done.stdout
    assert json.loads((tmp_path / "plan.json").read_text())["status"] == "solved"


def test_execute_a_written_plan(tmp_path):
    run_example("01_plan_and_verify.py", "plan.json", cwd=tmp_path)
    done = run_example("02_execute.py", "plan.json", cwd=tmp_path)
    assert "success: True" in done.stdout and "lifted: True" in done.stdout


def test_your_own_robot(tmp_path):
    done = run_example("04_your_own_robot.py", cwd=tmp_path)
    assert "robot panda.urdf" in done.stdout and "solved; verified: True" in done.stdout


def test_the_environment_with_its_expert_a_few_steps(tmp_path):
    done = run_example("06_environment_with_its_expert.py", "7", "5", cwd=tmp_path)
    assert done.stdout.startswith("5 steps, return ")


@pytest.mark.physics
def test_the_closed_loop_recovers_from_the_push(tmp_path):
    done = run_example("03_closed_loop_with_a_push.py", cwd=tmp_path)
    assert done.stdout.startswith("closed loop: success True")


@pytest.mark.physics
def test_the_environment_s_expert_succeeds(tmp_path):
    done = run_example("06_environment_with_its_expert.py", cwd=tmp_path)
    assert done.stdout.rstrip().endswith("success: True")


@pytest.mark.lerobot
def test_demos_and_loading_them(tmp_path):
    done = run_example("05_demos_and_loading_them.py", str(tmp_path / "demos"), "2", cwd=tmp_path)
    assert "2 episodes" in done.stdout and "slide the" in done.stdout
