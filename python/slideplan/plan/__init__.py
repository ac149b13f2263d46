"""The plan package, one module per concept, each importing only those above it:

- :mod:`~slideplan.plan.config`: :class:`PlannerConfig`, from the parameter registry, and its presets;
- :mod:`~slideplan.plan.schema`: every check of a plan file (``slideplan.plan/1`` and ``/2``);
- :mod:`~slideplan.plan.robot`: the robot description, its C++ model and the one collision-world builder;
- :mod:`~slideplan.plan.result`: :class:`PlanResult`, its loader and its JSON;
- :mod:`~slideplan.plan.planner`: :func:`plan`, the core's task and the grasp-map cache.

Readers of plans import ``result`` and ``robot``, never ``planner``. (``slideplan.plan``, the function,
is :func:`slideplan.plan.planner.plan`.)
"""
