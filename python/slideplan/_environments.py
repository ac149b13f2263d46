"""The Gymnasium environment's registration: ``gym.make("slideplan/SlideToEdge-v1")`` works after
``import slideplan``, whichever of slideplan and gymnasium is imported first, and ``import slideplan`` does
not import gymnasium (about 0.1 s) for a command that never uses it: the registration waits for gymnasium's
own import. It names the environment's class by its path, so nothing of the simulation loads until
``gym.make``."""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys

ENV_ID = "slideplan/SlideToEdge-v1"
# Earlier versions still made (the same class; gymnasium warns that a newer version exists).
OLDER_IDS = ("slideplan/SlideToEdge-v0",)
ENTRY_POINT = "slideplan.demos.env:SlideToEdgeEnv"
BENCHMARK_ID = "slideplan/SlideToEdgeBenchmark-v1"  # a tier of the frozen protocol (slideplan.benchmark)
BENCHMARK_ENTRY_POINT = "slideplan.benchmark.tier_env:BenchmarkEnv"
MAX_EPISODE_STEPS = 800  # slideplan.demos.env.EPISODE_S at the default 10 steps a second (a test checks)


def register(gymnasium) -> None:
    """Register the environment with ``gymnasium`` (once)."""
    for env_id, entry_point in ((ENV_ID, ENTRY_POINT), *((old, ENTRY_POINT) for old in OLDER_IDS),
                                (BENCHMARK_ID, BENCHMARK_ENTRY_POINT)):
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=entry_point, max_episode_steps=MAX_EPISODE_STEPS)


class _Registering(importlib.abc.Loader):
    """gymnasium's own loader, then the registration."""

    def __init__(self, loader) -> None:
        self.loader = loader

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module) -> None:
        self.loader.exec_module(module)
        register(module)

    def __getattr__(self, name: str):  # resources, source and the like: gymnasium's loader answers
        return getattr(self.loader, name)


class _WhenGymnasiumLoads(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name != "gymnasium":
            return None
        sys.meta_path.remove(self)  # once, and so that the lookup below finds gymnasium's own spec
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None:
            spec.loader = _Registering(spec.loader)
        return spec


def install() -> None:
    """Register now if gymnasium is loaded, else when it loads."""
    if "gymnasium" in sys.modules:
        register(sys.modules["gymnasium"])
    elif not any(isinstance(finder, _WhenGymnasiumLoads) for finder in sys.meta_path):
        sys.meta_path.insert(0, _WhenGymnasiumLoads())
