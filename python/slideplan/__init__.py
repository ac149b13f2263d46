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
"""

import os

from . import _core
from .errors import InputError
from .geometry import SupportSurface
from .objects import ThinObject, load_object
from .perception import Perception, perceive
from .plan.config import PlannerConfig
from .plan.result import PlanResult
from .plan.planner import plan
from .provenance import build_info
from .scenes import Scene, load_scene
from .verify import Verification, verify


def __getattr__(name: str):
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
