"""The one exception type for bad user input (files, fields, values)."""

from __future__ import annotations


class SlideplanWarning(UserWarning):
    """Something the user should know that does not stop the work (the CLI prints each as one
    ``slideplan: warning: ...`` line)."""


class MeshWarning(SlideplanWarning):
    """A hand link's collision mesh is checked as its triangles because its convex hull would fill a
    concavity: exact, but slower than a hull."""


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


def require_type(value, kind, field: str, what: str) -> None:
    """Refuse an argument of the wrong type where it enters the public API (deeper in it would be an
    AttributeError or a TypeError that names neither the argument nor what it should be).

    Args:
        value: the argument.
        kind: the type or tuple of types it must be an instance of.
        field: the argument's name.
        what: what it should be, in words, e.g. ``"a Scene (from load_scene)"``.

    Raises:
        InputError: ``value`` is not a ``kind``.
    """
    if not isinstance(value, kind):
        raise InputError(f"expected {what}, got {type(value).__name__} {_shown(value)}", field=field)


def _shown(value) -> str:
    """A short form of a wrong argument for a message."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."
