"""Reading TOML files and checking their fields; every failure is an InputError
naming the file and the dotted field."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10 (pyproject allows it)
    import tomli as tomllib

_REQUIRED = object()


def read_toml(path: Path) -> dict[str, Any]:
    """Parse a TOML file.

    Args:
        path: the file.

    Returns:
        The top-level table.

    Raises:
        InputError: the file is missing, unreadable or not valid TOML (nested too deeply included).
    """
    try:
        with open(path, "rb") as stream:
            return tomllib.load(stream)
    except FileNotFoundError:
        raise InputError("file not found", source=str(path)) from None
    except OSError as error:
        raise InputError(f"cannot read file ({error.strerror})", source=str(path)) from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"invalid TOML ({error})", source=str(path)) from None
    except UnicodeDecodeError as error:
        raise InputError(f"not UTF-8 text ({error})", source=str(path)) from None
    except RecursionError:  # tomllib parses nested arrays by recursion: thousands deep exhaust the stack
        raise InputError("invalid TOML (arrays or tables nested too deeply)", source=str(path)) from None


def is_number(value: Any) -> bool:
    """Return True for a Python or numpy int or float (bool, which Python counts as int,
    is not a number)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


def require_within(values: Any, bound: float, *, source: str = "", field: str = "") -> None:
    """Refuse a NaN, an infinite number or one beyond ``bound`` in magnitude among ``values`` (a number,
    or an array of any shape), naming the first by its index.

    Raises:
        InputError: naming ``source`` and ``field`` with the index, e.g. ``trajectory[3][2]``.
    """
    numbers = np.asarray(values, dtype=float)
    outside = ~(np.abs(numbers) <= bound)
    if outside.any():
        first = tuple(np.argwhere(outside)[0])
        value = float(numbers[first])
        problem = f"{value} is not a finite number" if not math.isfinite(value) else f"{value:g} is beyond {bound:g} in magnitude"
        raise InputError(problem, source=source, field=field + "".join(f"[{index}]" for index in first))


SEED_LIMIT = 2**64  # seeds are the core's uint64: every seed a plan takes, the perception and the physics take too


def as_seed(value: Any, *, field: str = "seed") -> int:
    """A seed: a whole number in ``[0, 2**64)``.

    Raises:
        InputError: (``field``) anything else, naming it.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value < SEED_LIMIT:
        raise InputError(f"must be a whole number in [0, 2**64), got {value!r}", field=field)
    return int(value)


def as_number(value: Any, *, source: str, field: str, positive: bool = False, bound: float = math.inf) -> float:
    """Check that ``value`` is a finite number within ``bound`` in magnitude (and > 0 if ``positive``)
    and return it as float.

    Raises:
        InputError: naming ``source`` and ``field``.
    """
    if not is_number(value):
        raise InputError(f"expected a number, got {value!r}", source=source, field=field)
    if not math.isfinite(value):
        raise InputError(f"must be finite, got {value!r}", source=source, field=field)
    require_within(value, bound, source=source, field=field)
    if positive and value <= 0:
        raise InputError(f"must be > 0, got {value!r}", source=source, field=field)
    return float(value)


def as_numbers(value: Any, length: int, *, source: str, field: str, positive: bool = False,
               bound: float = math.inf) -> np.ndarray:
    """Check that ``value`` is a list of ``length`` finite numbers within ``bound`` in magnitude (each > 0 if
    ``positive``) and return it as a float array.

    Raises:
        InputError: naming ``source`` and ``field``.
    """
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) != length:
        raise InputError(f"expected a list of {length} numbers, got {value!r}", source=source, field=field)
    return np.array([as_number(item, source=source, field=field, positive=positive, bound=bound) for item in value])


def as_xy_points(value: Any, *, source: str, field: str, bound: float = math.inf) -> np.ndarray:
    """Check that ``value`` is a list of ``[x, y]`` pairs of finite numbers within ``bound`` in magnitude.

    Returns:
        An (n, 2) float array (n may be anything; polygon checks come later).

    Raises:
        InputError: naming ``source`` and ``field``.
    """
    if not isinstance(value, (list, tuple)):
        raise InputError(f"expected a list of [x, y] points, got {value!r}", source=source, field=field)
    points = [as_numbers(point, 2, source=source, field=f"{field}[{index}]", bound=bound) for index, point in enumerate(value)]
    return np.array(points).reshape(-1, 2)


class Fields:
    """One TOML table being read, with the file name and dotted prefix for error messages.

    Args:
        table: the parsed table (anything else is reported as an error).
        source: the file name.
        prefix: the dotted name of this table in the file ("" at top level).
        allowed: the keys this table may have; any other key is reported (it is most
            likely a typo that would otherwise be silently ignored).
        bound: the largest magnitude of a number read from it and its sub-tables.

    Raises:
        InputError: ``table`` is not a table or has an unknown key.
    """

    def __init__(self, table: Any, *, source: str, prefix: str = "", allowed: set[str], bound: float = math.inf) -> None:
        if not isinstance(table, dict):
            raise InputError(f"expected a table, got {table!r}", source=source, field=prefix)
        self.source = source
        self.prefix = prefix
        self.bound = bound
        self._table = table
        for key in table:
            if key not in allowed:
                raise InputError(
                    f"unknown field (expected one of: {', '.join(sorted(allowed))})",
                    source=source,
                    field=self.field(key),
                )

    def only(self, allowed: set[str]) -> None:
        """Narrow the allowed keys (e.g. per kind of entry).

        Raises:
            InputError: the table has a key outside ``allowed``, naming it.
        """
        for key in self._table:
            if key not in allowed:
                raise InputError(
                    f"not a key of this kind of entry (expected one of: {', '.join(sorted(allowed))})",
                    source=self.source,
                    field=self.field(key),
                )

    def field(self, key: str) -> str:
        """Return the dotted name of ``key`` for error messages."""
        return f"{self.prefix}.{key}" if self.prefix else key

    def has(self, key: str) -> bool:
        """Return True if the table has ``key``."""
        return key in self._table

    def raw(self, key: str, default: Any = _REQUIRED) -> Any:
        """Return the value of ``key``, or ``default`` if it is absent.

        Raises:
            InputError: ``key`` is absent and no default was given.
        """
        if key in self._table:
            return self._table[key]
        if default is _REQUIRED:
            raise InputError("missing required field", source=self.source, field=self.field(key))
        return default

    def number(self, key: str, default: Any = _REQUIRED, *, positive: bool = False) -> float:
        """Return ``key`` as a finite float (> 0 if ``positive``); see :func:`as_number`."""
        return as_number(self.raw(key, default), source=self.source, field=self.field(key), positive=positive, bound=self.bound)

    def numbers(self, key: str, length: int, default: Any = _REQUIRED, *, positive: bool = False) -> np.ndarray:
        """Return ``key`` as an array of ``length`` finite floats (each > 0 if ``positive``); see :func:`as_numbers`."""
        return as_numbers(self.raw(key, default), length, source=self.source, field=self.field(key), positive=positive,
                          bound=self.bound)

    def xy_points(self, key: str) -> np.ndarray:
        """Return the required ``key`` as an (n, 2) array; see :func:`as_xy_points`."""
        return as_xy_points(self.raw(key), source=self.source, field=self.field(key), bound=self.bound)

    def string(self, key: str, default: Any = _REQUIRED) -> str:
        """Return ``key`` as a non-empty string.

        Raises:
            InputError: absent without default, not a string, or empty.
        """
        value = self.raw(key, default)
        if not isinstance(value, str) or not value:
            raise InputError(f"expected a non-empty string, got {value!r}", source=self.source, field=self.field(key))
        return value

    def strings(self, key: str, default: Any = _REQUIRED) -> tuple[str, ...]:
        """Return ``key`` as a non-empty tuple of non-empty strings.

        Raises:
            InputError: absent without default, not a list of strings, or empty.
        """
        value = self.raw(key, default)
        if (
            not isinstance(value, (list, tuple))
            or not value
            or not all(isinstance(item, str) and item for item in value)
        ):
            raise InputError(
                f"expected a non-empty list of non-empty strings, got {value!r}",
                source=self.source,
                field=self.field(key),
            )
        return tuple(value)

    def table(self, key: str, *, allowed: set[str], required: bool = False) -> Fields | None:
        """Return the sub-table ``key`` (None if absent and not ``required``).

        Raises:
            InputError: absent but required, not a table, or has unknown keys.
        """
        value = self.raw(key) if required else self.raw(key, None)
        if value is None:
            return None
        return Fields(value, source=self.source, prefix=self.field(key), allowed=allowed, bound=self.bound)

    def array_of_tables(self, key: str, *, allowed: set[str]) -> list[Fields]:
        """Return the entries of the optional array of tables ``key`` (``[[key]]`` in TOML).

        Raises:
            InputError: not a list, or an entry is not a table or has unknown keys.
        """
        value = self.raw(key, [])
        if not isinstance(value, list):
            raise InputError(f"expected an array of tables, got {value!r}", source=self.source, field=self.field(key))
        return [
            Fields(entry, source=self.source, prefix=f"{self.field(key)}[{index}]", allowed=allowed, bound=self.bound)
            for index, entry in enumerate(value)
        ]
