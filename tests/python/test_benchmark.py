"""SlideToEdge's frozen benchmark (slideplan.benchmark): the protocol's tasks are what their seeds draw, on
objects no default demonstration draws and never the held-out eval2 set's; `slideplan eval` names bad input;
a tier's environment plays task k on reset(seed=k); the expert scored end to end (physics)."""

from __future__ import annotations

import pandas as pd
import pytest
from typer.testing import CliRunner

from slideplan import InputError
from slideplan.benchmark.evaluate import policy_key, summary
from slideplan.benchmark.protocol import Task, load_protocol
from slideplan.cli import app
from slideplan.demos.draw import draw
from slideplan.demos.generate import Request
from slideplan.experiments.tasks import cached_scene
from slideplan.paths import held_out

runner = CliRunner()


def test_the_protocol_has_100_tasks_a_tier_on_a_named_split_no_demonstration_draws():
    protocol = load_protocol()
    assert protocol.tiers == ("nominal", "random", "hard") and protocol.settings == {tier: tier for tier in protocol.tiers}
    assert all(len(protocol.tier(tier)) >= 100 for tier in protocol.tiers)
    assert protocol.split == "letters" and not set(protocol.objects) & set(Request.objects)
    eval2 = {name.split("/", 1)[1] for name in held_out("objects", "eval2")}
    assert not set(protocol.objects) & eval2 and all("eval2" not in task.scene for tier in protocol.tiers
                                                       for task in protocol.tier(tier))
    assert protocol.env_id == "slideplan/SlideToEdge-v1"


def test_each_task_is_what_its_seed_draws():
    # The frozen file against today's draw: a build that draws another episode for a seed changes scores.
    protocol = load_protocol()
    for tier in protocol.tiers:
        for task in protocol.tier(tier):
            drawn = draw(cached_scene(task.scene), protocol.objects, protocol.settings[tier], task.seed)
            task.check(drawn.object, drawn.pose)  # raises on a difference


def test_a_task_drawn_otherwise_is_refused():
    task = Task("nominal", 3, "square", 7, "L", (0.5, 0.0, 0.1))
    with pytest.raises(InputError, match="nominal-003.*changes the benchmark") as caught:
        task.check("L", (0.5, 0.001, 0.1))
    assert caught.value.field == "protocol"
    task.check("L", (0.5 + 1e-7, 0.0, 0.1))  # the file's rounding


@pytest.mark.parametrize("args, words", [
    (["--tier", "easy"], ["--tier", "easy", "nominal, random, hard"]),
    (["--tier", "nominal", "--episodes", "0"], ["--episodes", "1..100"]),
    (["--tier", "nominal", "--episodes", "101"], ["--episodes", "1..100"]),
    (["--tier", "nominal", "--policy", "no_such_module:act"], ["--policy", "no_such_module"]),
    (["--tier", "nominal", "--policy", "numpy"], ["--policy", "neither 'expert', a folder, nor module:callable"]),
    (["--tier", "nominal", "--policy", "math:pi"], ["--policy", "not callable"]),
])
def test_bad_options_are_one_line_naming_the_option(tmp_path, args, words):
    argv = ["eval", "--out", str(tmp_path / "o"), "--workers", "1", *args]
    if "--policy" not in args:
        argv += ["--policy", "expert"]
    result = runner.invoke(app, argv)
    assert result.exit_code == 2, result.output
    line = result.output.strip().splitlines()[-1]
    assert all(word in line for word in words), line
    assert not list((tmp_path / "o").glob("results/*/*.parquet"))


def test_a_folder_without_a_lerobot_config_is_named(tmp_path):
    result = runner.invoke(app, ["eval", "--policy", str(tmp_path), "--tier", "nominal", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "config.json" in result.output and "--policy" in result.output


def test_rows_of_a_policy_are_kept_apart_and_the_paired_comparison_counts_discordant_tasks():
    assert policy_key("expert") == "expert"
    assert policy_key("a/b/pretrained_model") != policy_key("c/b/pretrained_model")
    ids = [f"nominal-{index:03d}" for index in range(10)]
    policy = pd.DataFrame({"task_id": ids, "success": [True] * 3 + [False] * 7, "steps": 100, "episode_s": 10.0,
                           "policy": "mine:act"})
    expert = pd.DataFrame({"task_id": ids, "success": [True] * 9 + [False], "steps": 200, "episode_s": 20.0,
                           "policy": "expert"})
    lines = summary(policy, expert)
    assert lines[0].startswith("success 3/10 (30.0%, 95% Wilson 10.8-60.3%)") and "mean episode 100 steps" in lines[0]
    assert "expert on the same tasks 9/10; the policy alone succeeded in 0, the expert alone in 6" in lines[1]
    assert "McNemar p = 0.0312" in lines[1]  # 2 x 0.5^6 = 0.03125, three digits
    assert "run --policy expert" in summary(policy, None)[1]


@pytest.mark.physics
def test_the_expert_scored_on_two_tasks_writes_a_row_each_and_a_rerun_runs_nothing(tmp_path):
    import gymnasium as gym

    env = gym.make("slideplan/SlideToEdgeBenchmark-v1", tier="nominal")
    _, info = env.reset(seed=101)  # task 1 (modulo 100): its seed drew its object
    task = load_protocol().tier("nominal")[1]
    assert info["task_id"] == "nominal-001" and info["object"] == task.object and info["seed"] == task.seed
    env.close()
    argv = ["eval", "--policy", "expert", "--tier", "nominal", "--episodes", "2", "--out", str(tmp_path), "--workers", "1"]
    first = runner.invoke(app, argv)
    assert first.exit_code == 0, first.output
    rows = pd.concat([pd.read_parquet(path) for path in sorted((tmp_path / "results" / "expert").glob("*.parquet"))])
    assert rows["task_id"].tolist() == ["nominal-000", "nominal-001"]
    assert set(rows["end"]) <= {"success", "fell", "simulation", "time_limit"}
    assert (rows["success"] == (rows["end"] == "success")).all() and rows["build"].notna().all()
    assert f"success {int(rows['success'].sum())}/2" in first.output
    again = runner.invoke(app, argv)
    assert again.exit_code == 0 and "2/2" in again.output
    assert pd.concat([pd.read_parquet(path) for path in sorted((tmp_path / "results" / "expert").glob("*.parquet"))])["date"].tolist() == rows["date"].tolist()


def _tiny_act(folder) -> None:
    """An untrained ACT policy on the state (a few thousand parameters), saved as lerobot-train saves one."""
    import torch
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.act.configuration_act import ACTConfig
    from lerobot.policies.act.modeling_act import ACTPolicy
    from lerobot.policies.factory import make_pre_post_processors

    features = {"observation.state": (FeatureType.STATE, 14), "observation.environment_state": (FeatureType.ENV, 4),
                "action": (FeatureType.ACTION, 8)}
    config = ACTConfig(input_features={key: PolicyFeature(kind, (size,)) for key, (kind, size) in features.items() if key != "action"},
                       output_features={"action": PolicyFeature(FeatureType.ACTION, (8,))}, chunk_size=5, n_action_steps=5,
                       dim_model=16, n_heads=2, dim_feedforward=32, n_encoder_layers=1, n_decoder_layers=1, use_vae=False,
                       device="cpu", push_to_hub=False)
    torch.manual_seed(0)
    stats = {key: {"mean": torch.zeros(size), "std": torch.ones(size)} for key, (_, size) in features.items()}
    pre, post = make_pre_post_processors(config, dataset_stats=stats)
    ACTPolicy(config).save_pretrained(folder)
    pre.save_pretrained(folder)
    post.save_pretrained(folder)


@pytest.mark.lerobot
def test_lerobot_eval_plays_the_tiers_tasks_and_slideplan_eval_scores_the_same_policy_alike(tmp_path, monkeypatch):
    import json
    import sys

    from slideplan.benchmark import tier_env

    _tiny_act(tmp_path / "policy")
    played = []
    reset, step = tier_env.BenchmarkEnv.reset, tier_env.BenchmarkEnv.step

    def recording_reset(self, **kwargs):
        observation, info = reset(self, **kwargs)
        played.append([info["task_id"], 0, None])
        return observation, info

    def recording_step(self, action):
        result = step(self, action)
        played[-1][1] += 1
        played[-1][2] = result[-1].get("end", played[-1][2])
        return result

    monkeypatch.setattr(tier_env.BenchmarkEnv, "reset", recording_reset)
    monkeypatch.setattr(tier_env.BenchmarkEnv, "step", recording_step)
    monkeypatch.setenv("MUJOCO_GL", "egl")
    monkeypatch.setattr(sys, "argv", ["lerobot-eval", "--env.discover_packages_path=slideplan.benchmark.lerobot_plugin",
                                      "--env.type=slideplan", "--env.tier=nominal", "--env.obs_type=state",
                                      f"--policy.path={tmp_path / 'policy'}", "--policy.device=cpu", "--eval.n_episodes=2",
                                      "--eval.batch_size=1", "--seed=0", f"--output_dir={tmp_path / 'lerobot'}"])
    from lerobot.scripts.lerobot_eval import main

    main()
    overall = json.loads((tmp_path / "lerobot" / "eval_info.json").read_text())["overall"]
    assert overall["n_episodes"] == 2 and "pc_success" in overall
    episodes = [entry for entry in played if entry[1]]  # lerobot resets once more after the last episode
    assert [task_id for task_id, _, _ in episodes[:2]] == ["nominal-000", "nominal-001"]
    # The same policy on the same tasks through slideplan eval: the same episodes, step for step.
    result = runner.invoke(app, ["eval", "--policy", str(tmp_path / "policy"), "--tier", "nominal", "--episodes", "2",
                                 "--out", str(tmp_path / "ours"), "--workers", "1"])
    assert result.exit_code == 0, result.output
    rows = pd.concat([pd.read_parquet(path) for path in sorted((tmp_path / "ours" / "results").glob("*/*.parquet"))])
    assert [[row.task_id, row.steps, row.end] for row in rows.itertuples()] == [list(entry) for entry in episodes[:2]]
    assert 100 * rows["success"].mean() == overall["pc_success"]
