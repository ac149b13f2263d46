"""Write SlideToEdge's frozen benchmark protocol, ``data/benchmark/slide_to_edge.toml`` (run once; the file is
committed and never edited: a new protocol is a new file and a new environment version).

Every tier (the closed loop's settings ``nominal``, ``random`` and ``hard``) has the same 100 draws: 25 seeds
on each of the paper's four tables, each seed drawing one of the held-out ``letters`` split's objects (Y, A,
L, E: no default ``slideplan demos`` draw uses them; never the closed loop's ``eval2`` objects) and a pose
wholly on the table, as ``slideplan demos`` and the environment draw (:func:`slideplan.demos.draw.draw`).

    python benchmarks/freeze_protocol.py
"""

from __future__ import annotations

from pathlib import Path

from slideplan.benchmark.protocol import PROTOCOL_FILE, Protocol, Task, format_protocol, rounded
from slideplan.demos.draw import draw, episode_seed
from slideplan.experiments.tasks import cached_scene

ENV_ID = "slideplan/SlideToEdge-v1"
SPLIT, OBJECTS = "letters", ("Y", "A", "L", "E")
TIERS = ("nominal", "random", "hard")
TABLES = ("square", "round", "triangle", "long")
PER_TABLE = 25
PROTOCOL_SEED = 2026_12_07  # the protocol's own: no dataset or test draws from it

HEADER = """SlideToEdge's frozen benchmark protocol (slideplan.benchmark.protocol): written once by
benchmarks/freeze_protocol.py, never edited. Each tier is a closed-loop setting; each task is the environment
on its table reset with its seed, which draws the object and pose listed (a test checks the draws)."""


def main() -> None:
    draws = []
    for table in TABLES:
        scene = cached_scene(table)
        for index in range(PER_TABLE):
            seed = episode_seed(PROTOCOL_SEED, len(draws))
            drawn = draw(scene, OBJECTS, "nominal", seed)  # the setting does not enter the object or pose
            draws.append((table, drawn))
    tasks = {tier: tuple(Task(tier, index, table, drawn.seed, drawn.object, rounded(drawn.pose))
                         for index, (table, drawn) in enumerate(draws)) for tier in TIERS}
    protocol = Protocol(ENV_ID, SPLIT, OBJECTS, {tier: tier for tier in TIERS}, tasks)
    path = Path(__file__).resolve().parent.parent / "data" / PROTOCOL_FILE  # the source tree, not the installed copy
    path.write_text(format_protocol(protocol, HEADER))
    print(f"wrote {path}: {len(TIERS)} tiers x {len(draws)} tasks")


if __name__ == "__main__":
    main()
