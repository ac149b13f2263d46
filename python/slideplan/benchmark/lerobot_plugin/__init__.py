"""``lerobot-eval --env.type=slideplan``: SlideToEdge's benchmark as a LeRobot environment (the ``lerobot``
extra; lerobot 0.4.x). LeRobot imports this package when told where it is, its own plugin mechanism::

    lerobot-eval --env.discover_packages_path=slideplan.benchmark.lerobot_plugin --env.type=slideplan \\
        --env.tier=nominal --policy.path=PATH --eval.n_episodes=100 --eval.batch_size=1 --seed=0

``--seed=0`` and ``n_episodes`` 100 play the tier's 100 tasks in order (``reset(seed=k)`` is task ``k``:
:class:`slideplan.benchmark.tier_env.BenchmarkEnv`); lerobot reports ``pc_success``, the world's verdict.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_IMAGES, OBS_STATE

from ..._environments import BENCHMARK_ID, MAX_EPISODE_STEPS

ARM_JOINTS = 7  # every protocol table carries the WAM: its joints, and the gripper's closing


@EnvConfig.register_subclass("slideplan")
@dataclass
class SlideplanEnv(EnvConfig):
    """A tier of the frozen protocol; ``obs_type`` ``pixels`` (the front camera and the state, as the
    datasets' ``observation.images.front`` and ``observation.state``) or ``state``."""

    task: str | None = BENCHMARK_ID.split("/", 1)[1]
    tier: str = "nominal"
    fps: int = 10
    episode_length: int = MAX_EPISODE_STEPS
    obs_type: str = "pixels"
    render_mode: str = "rgb_array"
    observation_width: int = 256
    observation_height: int = 256
    features: dict[str, PolicyFeature] = field(default_factory=lambda: {
        ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(ARM_JOINTS + 1,)),
        "agent_pos": PolicyFeature(type=FeatureType.STATE, shape=(ARM_JOINTS + 7,)),
    })
    features_map: dict[str, str] = field(default_factory=lambda: {
        ACTION: ACTION, "agent_pos": OBS_STATE, "environment_state": OBS_ENV_STATE, "pixels/front": f"{OBS_IMAGES}.front",
    })

    def __post_init__(self) -> None:
        if self.obs_type == "pixels":
            self.features["pixels/front"] = PolicyFeature(type=FeatureType.VISUAL,
                                                          shape=(self.observation_height, self.observation_width, 3))

    @property
    def package_name(self) -> str:
        return "slideplan"  # its import registers the environments

    @property
    def gym_id(self) -> str:
        return f"slideplan/{self.task}"

    @property
    def gym_kwargs(self) -> dict:
        return {"tier": self.tier, "obs_type": self.obs_type, "fps": self.fps, "render_mode": self.render_mode,
                "image_size": (self.observation_width, self.observation_height),
                "max_episode_steps": self.episode_length}
