"""``slideplan/SlideToEdgeBenchmark-v1``: a tier of the frozen protocol as one Gymnasium environment, so that
any evaluator that resets with seeds 0, 1, 2, ... (``lerobot-eval``, ``slideplan eval``) plays the tier's tasks.

``reset(seed=k)`` starts task ``k`` (modulo the tier's count) of the tier: the
:class:`~slideplan.demos.env.SlideToEdgeEnv` of its table, reset with the task's seed, which draws the task's
object and pose (checked). Everything else (spaces, steps, rewards, the end, the verdict) is that
environment's; every table of the protocol carries the same robot, so the spaces are one.
"""

from __future__ import annotations

import gymnasium as gym

from ..errors import InputError
from .protocol import load_protocol


class BenchmarkEnv(gym.Env):
    """A tier of SlideToEdge's frozen benchmark protocol (:mod:`slideplan.benchmark.protocol`).

    Args:
        tier: ``nominal``, ``random`` or ``hard``.
        protocol: the protocol file (default: the bundled one).
        **kwargs: :class:`~slideplan.demos.env.SlideToEdgeEnv`'s ``obs_type``, ``action_type``,
            ``reward_type``, ``render_mode``, ``fps``, ``image_size`` and ``max_episode_steps``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, tier: str = "nominal", protocol=None, **kwargs) -> None:
        from ..demos.env import SlideToEdgeEnv

        self.protocol = load_protocol(protocol)
        self.tasks = self.protocol.tier(tier)
        self.tier = tier
        self._make = lambda scene: SlideToEdgeEnv(scene=scene, objects=self.protocol.objects,
                                                  setting=self.protocol.settings[tier], **kwargs)
        self._envs = {}
        self.current = self._env(self.tasks[0].scene)
        self.current_task = self.tasks[0]
        self.observation_space, self.action_space = self.current.observation_space, self.current.action_space
        self.render_mode, self.metadata = self.current.render_mode, self.current.metadata

    def _env(self, scene: str):
        if scene not in self._envs:
            env = self._make(scene)
            if self._envs and (env.observation_space != self.observation_space or env.action_space != self.action_space):
                raise InputError(f"table {scene} carries another robot than {self.tasks[0].scene}: a tier's spaces are one",
                                 field="protocol")
            self._envs[scene] = env
        return self._envs[scene]

    @property
    def task_description(self) -> str:
        return self.current.task_description

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start task ``seed`` (modulo the tier's count; a random one without a seed)."""
        super().reset(seed=seed)
        index = (int(self.np_random.integers(len(self.tasks))) if seed is None else int(seed)) % len(self.tasks)
        self.current_task = task = self.tasks[index]
        self.current = self._env(task.scene)
        observation, info = self.current.reset(seed=task.seed)
        if info["redrawn"] == 0:
            task.check(info["object"], info["pose"])
        return observation, {**info, "task_id": task.task_id}

    def step(self, action):
        return self.current.step(action)

    def render(self):
        return self.current.render()

    def expert_action(self):
        """The planner's action now (:meth:`slideplan.demos.env.SlideToEdgeEnv.expert_action`)."""
        return self.current.expert_action()

    def close(self) -> None:
        for env in self._envs.values():
            env.close()
