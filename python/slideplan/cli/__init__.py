"""Command line: ``slideplan plan``, ``demo``, ``export``, ``view``, ``perceive``, ``execute``, ``run`` (the
closed loop), ``experiment``, ``plot`` (docs/design.md 5), ``demos`` (docs/demos.md) and ``ros serve`` / ``ros sim``
(docs/ros2.md).

Exit codes of ``plan``: 0 solved (and verified), 1 not solved within the time limit,
2 bad input (one line ``slideplan: error: ...`` on stderr), 3 solved but the plan fails
verification (``slideplan.checks.verify``: a planner bug; the violations go to stderr and the JSON
is written with status ``"invalid"``); every command exits 130 when stopped by Ctrl-C.

``experiment`` and ``plot`` need the ``experiments`` extra (pandas, pyarrow, dask); ``view`` the
``view`` extra (viser, yourdfpy); ``perceive`` the ``perception`` extra (scikit-learn, SciPy). Warnings (e.g. a URDF velocity limit replaced by a default) go to
stderr as one line ``slideplan: warning: ...`` each.

The commands live in one module per group (:mod:`~slideplan.cli.plans`, :mod:`~slideplan.cli.outputs`,
:mod:`~slideplan.cli.physics`, :mod:`~slideplan.cli.experiments`, :mod:`~slideplan.cli.benchmark`,
:mod:`~slideplan.cli.ros`), each adding its
commands to the one :data:`app` of :mod:`~slideplan.cli.common` when imported (in this order: ``--help``
lists them so).
"""

# Each module adds its commands to app when imported; --help lists them in this order.
from . import plans, outputs, physics, experiments, benchmark, ros
from .common import app

__all__ = ["app"]
