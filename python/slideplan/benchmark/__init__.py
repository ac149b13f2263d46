"""SlideToEdge as a benchmark for policies (docs/benchmark.md): the frozen protocol and scoring a policy on it.

Modules:
    protocol: the tiers and their tasks, from the protocol's data file.
    policies: what acts in an episode: the planner's expert, a ``module:callable``, a LeRobot policy folder.
    evaluate: an episode of a task run to its end, its row, the tier's score (``slideplan eval``).
    lerobot_plugin: ``lerobot-eval --env.type=slideplan`` (the ``lerobot`` extra).
"""
