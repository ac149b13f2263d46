"""The one exception type for bad user input (files, fields, values)."""

from __future__ import annotations


class InputError(ValueError):
    """Bad input: a file, a field in it, or a value passed to a loader is wrong.

    The message reads ``"<source>: <field>: <problem>"``, leaving out the parts that
    are empty, e.g. ``"scenes/x.toml: table.polygon: polygon is self-intersecting"``,
    so the CLI can print it as one line and exit with code 2.

    Args:
        problem: what is wrong, in words.
        source: the file the value came from ("" when there is none).
        field: the dotted field name inside the file, or the argument name ("" if none).

    Attributes:
        problem, source, field: the parts of the message, for programs that want them.
    """

    def __init__(self, problem: str, *, source: str = "", field: str = "") -> None:
        self.problem = problem
        self.source = str(source)
        self.field = field
        super().__init__(": ".join(part for part in (self.source, field, problem) if part))
