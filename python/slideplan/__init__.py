"""slideplan: pre-grasp sliding planning of thin objects (Hang, Morgan, Dollar, RA-L 2019).

Typical use::

    import numpy as np
    import slideplan

    scene = slideplan.load_scene("square")
    obj = slideplan.load_object("crescent", table_height=scene.table.height, pose=(0.6, 0.0, 0.3))
    result = slideplan.plan(scene, obj, slideplan.PlannerConfig(seed=1, time_limit_s=20))
    if result.solved and slideplan.verify(result).ok:
        open("plan.json", "w").write(result.to_json())

Set the environment variable ``SLIDEPLAN_OMPL_LOG`` to keep OMPL's own log level
(otherwise OMPL prints warnings and errors only).

The packages are the layers, each importing only those before it: the foundation (this folder's
modules), :mod:`~slideplan.world`, :mod:`~slideplan.plan`, :mod:`~slideplan.checks`,
:mod:`~slideplan.perception`, :mod:`~slideplan.outputs`, :mod:`~slideplan.loop`, :mod:`~slideplan.sim`,
:mod:`~slideplan.experiments`, :mod:`~slideplan.demos`, :mod:`~slideplan.ros`, :mod:`~slideplan.cli`
(docs/design.md). Importing this package loads the planner, not the perception or the verifier:
``perceive`` and ``verify`` load theirs when first used.
"""

import os

from . import _core, _environments, _moved
from .errors import InputError
from .plan.config import PlannerConfig
from .plan.planner import plan
from .plan.result import PlanResult
from .provenance import build_info
from .world.geometry import SupportSurface
from .world.objects import ThinObject, load_object
from .world.scenes import Scene, load_scene

_moved.install()
_environments.install()  # gym.make("slideplan/SlideToEdge-v1") after import slideplan
_ON_FIRST_USE = {"Perception": "slideplan.perception.tabletop", "perceive": "slideplan.perception.tabletop",
                 "Verification": "slideplan.checks.verify", "verify": "slideplan.checks.verify"}


def __getattr__(name: str):
    if name in _ON_FIRST_USE:
        from importlib import import_module

        value = getattr(import_module(_ON_FIRST_USE[name]), name)
        globals()[name] = value  # once: later lookups find it here
        return value
    # __version__ on demand: importlib.metadata costs every CLI call 40-80 ms to import.
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            return version("slideplan")
        except PackageNotFoundError:  # running from a source checkout without installing
            return "0.1.0"
    raise AttributeError(f"module 'slideplan' has no attribute {name!r}")


if "SLIDEPLAN_OMPL_LOG" not in os.environ:
    _core.set_ompl_log_level(4)  # warnings and errors only: Debian's OMPL logs debug output by default

__all__ = [
    "InputError",
    "Perception",
    "PlanResult",
    "PlannerConfig",
    "Scene",
    "SupportSurface",
    "ThinObject",
    "Verification",
    "__version__",
    "build_info",
    "load_object",
    "load_scene",
    "perceive",
    "plan",
    "verify",
]
