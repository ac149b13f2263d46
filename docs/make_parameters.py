"""Rewrite docs/parameters.md's table of every planner parameter from the registry (params.cpp).

Usage: ``python docs/make_parameters.py [--check]``; ``--check`` exits 1 if the table is stale.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from slideplan.parameters import markdown_table

PAGE = Path(__file__).resolve().parent / "parameters.md"
BLOCK = re.compile(r"(<!-- generated: parameters -->\n).*?(<!-- /generated -->)", re.S)


def main(argv: list[str]) -> int:
    text = PAGE.read_text()
    if not BLOCK.search(text):
        print(f"{PAGE}: no '<!-- generated: parameters -->' block", file=sys.stderr)
        return 2
    new = BLOCK.sub(lambda match: match.group(1) + markdown_table() + "\n" + match.group(2), text)
    if "--check" in argv:
        if new != text:
            print(f"{PAGE}: the parameter table is stale: run docs/make_parameters.py", file=sys.stderr)
            return 1
        return 0
    PAGE.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
