"""What acts in a benchmark episode (``slideplan eval --policy``): an object with ``obs_type`` and
``action_type`` (the environment's, :class:`slideplan.demos.env.SlideToEdgeEnv`), ``reset(env)`` at each
episode's start and ``act(observation) -> action`` at each step.

- ``expert``: the planner's action (:meth:`~slideplan.demos.env.SlideToEdgeEnv.expert_action`).
- ``module:callable``: a function ``observation -> action``; its attributes ``obs_type`` and
  ``action_type`` (default ``state`` and ``joint``) and ``reset(env)`` are used where it has them.
- a folder: a LeRobot pretrained policy, as ``lerobot-train`` writes it (``.../pretrained_model``: its
  ``config.json``, weights and processors; the ``lerobot`` extra), fed as ``lerobot-eval`` feeds it.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import InputError

EXPERT = "expert"


class Expert:
    """The planner's action at every step."""

    obs_type, action_type = "state", "joint"

    def reset(self, env) -> None:
        self.env = env

    def act(self, observation) -> np.ndarray:
        return self.env.expert_action()


class Function:
    """A ``module:callable`` policy."""

    def __init__(self, function: Callable[[Any], Any]) -> None:
        self.function = function
        self.obs_type = getattr(function, "obs_type", "state")
        self.action_type = getattr(function, "action_type", "joint")

    def reset(self, env) -> None:
        if callable(getattr(self.function, "reset", None)):
            self.function.reset(env)

    def act(self, observation) -> np.ndarray:
        return np.asarray(self.function(observation), dtype=float)


class LeRobotPolicy:
    """A LeRobot pretrained policy folder, stepped as ``lerobot-eval`` steps one: the observation mapped to
    LeRobot's keys (``preprocess_observation``), the task text added, the policy's own pre- and
    post-processors around ``select_action``."""

    action_type = "joint"

    def __init__(self, path: Path) -> None:
        import torch  # noqa: F401 - the extra's; named in the error below when missing
        from lerobot.configs.policies import PreTrainedConfig
        from lerobot.policies.factory import get_policy_class, make_pre_post_processors

        config = PreTrainedConfig.from_pretrained(path)
        config.device = "cpu"
        self.policy = get_policy_class(config.type).from_pretrained(path, config=config)
        self.policy.eval()
        self.pre, self.post = make_pre_post_processors(config, pretrained_path=str(path))
        images = [key for key in config.input_features if key.startswith("observation.images.")]
        self.obs_type = "pixels" if images else "state"

    def reset(self, env) -> None:
        self.env = env
        self.policy.reset()

    def act(self, observation) -> np.ndarray:
        import torch
        from lerobot.envs.utils import preprocess_observation

        batch = preprocess_observation(_batched(observation))
        batch["task"] = [self.env.task_description]
        with torch.inference_mode():
            action = self.post(self.policy.select_action(self.pre(batch)))
        return action.to("cpu").numpy()[0].astype(float)


def _batched(observation):
    """An observation with a batch of one in front (lerobot's preprocessing expects a vector env's)."""
    if isinstance(observation, dict):
        return {key: _batched(value) for key, value in observation.items()}
    return np.asarray(observation)[None]


def load_policy(spec: str):
    """The policy ``spec`` names (see the module's docstring).

    Raises:
        InputError: no such module, attribute or folder, a folder that is no LeRobot policy, or no ``lerobot``
            extra for one (field ``--policy``).
    """
    if spec == EXPERT:
        return Expert()
    path = Path(spec)
    if path.is_dir():
        if not (path / "config.json").is_file():
            raise InputError(f"{path} holds no config.json: give a LeRobot pretrained policy folder "
                             "(lerobot-train's .../checkpoints/last/pretrained_model)", field="--policy")
        try:
            return LeRobotPolicy(path)
        except ImportError as error:
            raise InputError(f"a LeRobot policy needs the lerobot extra (pip install \"slideplan[lerobot]\"): {error}",
                             field="--policy") from None
    module_name, _, attribute = spec.partition(":")
    if not attribute:
        raise InputError(f"{spec!r} is neither 'expert', a folder, nor module:callable", field="--policy")
    try:
        function = getattr(importlib.import_module(module_name), attribute)
    except (ImportError, AttributeError) as error:
        raise InputError(f"cannot load {spec!r}: {error}", field="--policy") from None
    if not callable(function):
        raise InputError(f"{spec!r} is not callable", field="--policy")
    return Function(function)
