"""``slideplan eval``: a policy scored on a tier of the frozen protocol (:mod:`slideplan.benchmark.protocol`).

Each task is one episode of the environment (:class:`slideplan.demos.env.SlideToEdgeEnv`) on its table,
reset with its seed, the policy acting until the episode ends; its row (one Parquet file per task under
``OUT/results/POLICY/``, written whole) holds the world's verdict, why the episode ended and its length, with
the build that ran it. A run again with the same ``--out`` skips the tasks that have a row.
"""

from __future__ import annotations

import dataclasses
import hashlib
import re
import time
from pathlib import Path

import pandas as pd

from .._files import replacing
from ..errors import InputError
from ..provenance import run_provenance
from .policies import EXPERT, load_policy
from .protocol import Protocol, Task


@dataclasses.dataclass(frozen=True)
class Job:
    """One task for one policy (what a worker runs)."""

    task: Task
    policy: str
    setting: str
    env_id: str

    @property
    def task_id(self) -> str:
        return self.task.task_id


def policy_key(spec: str) -> str:
    """The folder name of a policy's rows: ``expert``, or the spec's readable tail and a hash of it."""
    if spec == EXPERT:
        return EXPERT
    tail = re.sub(r"[^A-Za-z0-9_.-]+", "_", spec.rstrip("/").split("/")[-1])[-40:]
    return f"{tail}-{hashlib.sha256(spec.encode()).hexdigest()[:8]}"


def rows_dir(out: str | Path, spec: str) -> Path:
    return Path(out) / "results" / policy_key(spec)


_POLICIES: dict[str, object] = {}  # loaded once per worker process
_ENVS: dict[tuple, object] = {}  # a tier's environment per observation and action type, built once per worker process


def run_episode(job: Job) -> dict:
    """Run ``job``'s episode to its end (:class:`~slideplan.benchmark.tier_env.BenchmarkEnv`, reset with the
    task's index). Returns its row."""
    from .tier_env import BenchmarkEnv

    task = job.task
    policy = _POLICIES.get(job.policy) or _POLICIES.setdefault(job.policy, load_policy(job.policy))
    started = time.perf_counter()
    key = (task.tier, policy.obs_type, policy.action_type)
    env = _ENVS.get(key) or _ENVS.setdefault(key, BenchmarkEnv(task.tier, obs_type=policy.obs_type, action_type=policy.action_type))
    try:
        observation, info = env.reset(seed=task.index)
        redrawn = int(info["redrawn"])
        policy.reset(env)
        steps = 0
        while True:
            observation, _, terminated, truncated, info = env.step(policy.act(observation))
            steps += 1
            if terminated or truncated:
                break
    finally:
        env.close()  # the episode's world; the environment is reset for the next
    return {"task_id": task.task_id, "tier": task.tier, "index": task.index, "scene": task.scene, "seed": task.seed,
            "object": task.object, "setting": job.setting, "policy": job.policy, "env_id": job.env_id,
            "success": bool(info["is_success"]), "end": info["end"], "steps": steps, "episode_s": steps / env.current.fps,
            "redrawn": redrawn, "wall_time_s": time.perf_counter() - started, **run_provenance()}


def evaluate(protocol: Protocol, tier: str, spec: str, out: str | Path, executor, episodes: int | None = None,
             progress=None) -> pd.DataFrame:
    """Score the policy ``spec`` on ``tier``'s first ``episodes`` tasks; the rows already in ``out`` are kept.
    The episodes are the bundled protocol's (``protocol`` names the tasks asked for).

    Returns:
        The tier's rows for this policy (those asked for), in task order.

    Raises:
        InputError: an unknown tier, a bad count or policy (named), a task whose seed draws another episode.
    """
    tasks = protocol.tier(tier, episodes)
    load_policy(spec)  # a bad policy is named before any episode
    folder = rows_dir(out, spec)
    folder.mkdir(parents=True, exist_ok=True)
    row = {task.task_id: folder / f"{task.task_id}.parquet" for task in tasks}
    todo = [Job(task, spec, protocol.settings[tier], protocol.env_id) for task in tasks
            if not row[task.task_id].exists()]
    lost = 0
    if progress is not None:
        progress(len(tasks) - len(todo), len(tasks))
    for job, outcome in executor.imap_unordered(run_episode, todo):
        if isinstance(outcome, InputError):
            raise outcome
        if isinstance(outcome, BaseException):
            lost += 1
        else:
            with replacing(row[job.task_id]) as partial:
                pd.DataFrame([outcome]).to_parquet(partial, index=False)
        if progress is not None:
            progress(sum(path.exists() for path in row.values()), len(tasks))
    rows = [pd.read_parquet(path) for path in row.values() if path.exists()]
    table = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    table.attrs["lost"] = lost
    return table


def expert_rows(out: str | Path, task_ids) -> pd.DataFrame | None:
    """The expert's rows for the same tasks in ``out``, if it has one for each of them."""
    folder = rows_dir(out, EXPERT)
    paths = [folder / f"{task_id}.parquet" for task_id in task_ids]
    if not all(path.exists() for path in paths):
        return None
    return pd.concat([pd.read_parquet(path) for path in paths], ignore_index=True)


def summary(rows: pd.DataFrame, expert: pd.DataFrame | None) -> list[str]:
    """What ``slideplan eval`` prints: success with its 95% Wilson interval, the mean episode length, and
    the paired comparison with the expert on the same tasks (McNemar's exact test)."""
    from ..experiments.stats import mcnemar_exact, wilson_interval

    n, successes = len(rows), int(rows["success"].sum())
    low, high = wilson_interval(successes, n)
    lines = [f"success {successes}/{n} ({100 * successes / n:.1f}%, 95% Wilson {100 * low:.1f}-{100 * high:.1f}%), "
             f"mean episode {rows['steps'].mean():.0f} steps ({rows['episode_s'].mean():.1f} s simulated)"]
    if expert is None:
        lines.append("no expert rows for these tasks in --out: run --policy expert with the same --out to compare")
    elif rows["policy"].iloc[0] != EXPERT:
        paired = rows.set_index("task_id")["success"].astype(bool).to_frame("policy").join(
            expert.set_index("task_id")["success"].astype(bool).rename("expert"))
        only_policy, only_expert, p = mcnemar_exact(paired["policy"], paired["expert"])
        lines.append(f"expert on the same tasks {int(paired['expert'].sum())}/{len(paired)}; the policy alone succeeded "
                     f"in {only_policy}, the expert alone in {only_expert} (McNemar p = {p:.3g})")
    return lines


