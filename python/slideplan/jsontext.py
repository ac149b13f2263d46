"""JSON text of plans and reports: one line per key and per row, each list of numbers on one line.

``json.dumps(indent=...)`` puts every number of a trajectory on its own line (a plan becomes ~10,000
lines) and, with an indent, uses the pure-Python encoder; the C encoder writes the leaves here, so
a plan is written several times faster and reads as a table of waypoints.
"""

from __future__ import annotations

import json
from typing import Any


def dumps(data: Any, indent: int | None = None, allow_nan: bool = True) -> str:
    """JSON text of ``data`` (plain dicts, lists and scalars).

    Args:
        data: the document.
        indent: None for one line; a number of spaces per level for one line per key and per
            element of a list that holds lists or dicts (lists of scalars stay on one line).
        allow_nan: as :func:`json.dumps` (False: a NaN or infinity raises ValueError).
    """
    leaf = json.JSONEncoder(allow_nan=allow_nan, check_circular=False, separators=(", ", ": ")).encode
    if indent is None:
        return leaf(data)

    def text(item: Any, depth: int) -> str:
        pad, inner = " " * (indent * depth), " " * (indent * (depth + 1))
        if isinstance(item, dict) and item:
            body = ",\n".join(f"{inner}{json.dumps(str(key))}: {text(value, depth + 1)}" for key, value in item.items())
            return "{\n" + body + "\n" + pad + "}"
        if isinstance(item, (list, tuple)) and any(isinstance(element, (dict, list, tuple)) for element in item):
            return "[\n" + ",\n".join(inner + text(element, depth + 1) for element in item) + "\n" + pad + "]"
        return leaf(item)

    return text(data, 0)


class Document:
    """``to_json`` for a class with a ``to_dict`` (a plan, an execution's or a run's report)."""

    JSON_ALLOWS_NAN = True  # False: a NaN or infinity in the document raises ValueError

    def to_json(self, indent: int | None = None) -> str:
        """The document as JSON text (``to_dict``'s, through :func:`dumps`).

        Args:
            indent: None for one line; a number for one line per key and per waypoint.
        """
        return dumps(self.to_dict(), indent=indent, allow_nan=self.JSON_ALLOWS_NAN)
