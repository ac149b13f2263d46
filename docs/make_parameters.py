"""Rewrite the generated tables of every setting: docs/parameters.md's of the planner's parameters (from the
registry the core declares, params.cpp) and docs/simulation.md's of the simulation's settings
(slideplan.sim.registry).

Usage: ``python docs/make_parameters.py [--check]``; ``--check`` exits 1 if a table is stale.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from slideplan.parameters import markdown_table as planner_table
from slideplan.sim.registry import markdown_table as simulation_table

HERE = Path(__file__).resolve().parent
PAGES = {HERE / "parameters.md": ("parameters", planner_table), HERE / "simulation.md": ("simulation", simulation_table)}


def block(name: str) -> re.Pattern:
    return re.compile(rf"(<!-- generated: {name} -->\n).*?(<!-- /generated -->)", re.S)


def main(argv: list[str]) -> int:
    stale = 0
    for page, (name, table) in PAGES.items():
        text = page.read_text()
        if not block(name).search(text):
            print(f"{page}: no '<!-- generated: {name} -->' block", file=sys.stderr)
            return 2
        new = block(name).sub(lambda match: match.group(1) + table() + "\n" + match.group(2), text)
        if new != text:
            if "--check" in argv:
                print(f"{page}: the {name} table is stale: run docs/make_parameters.py", file=sys.stderr)
                stale = 1
            else:
                page.write_text(new)
    return stale


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
