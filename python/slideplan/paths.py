"""Where the bundled data (robots, scenes, objects) lives."""

from __future__ import annotations

import re
from pathlib import Path

from .errors import InputError

_HELD_OUT_NAME = re.compile(r"[A-Za-z0-9_]+/[A-Za-z0-9_]+")  # SET/NAME: one folder down, never out of data/


def data_dir() -> Path:
    """Return the directory holding ``robots/``, ``scenes/`` and ``objects/``.

    Returns:
        The installed package data ``<package>/data`` if it exists, else the
        repository's top-level ``data/`` (for running from a source checkout).
    """
    installed = Path(__file__).resolve().parent / "data"
    if installed.is_dir():
        return installed
    return Path(__file__).resolve().parents[2] / "data"


def _toml_stems(subdir: str) -> list[str]:
    return sorted(path.stem for path in (data_dir() / subdir).glob("*.toml"))


def builtin_objects() -> list[str]:
    """Return the names of the bundled object outlines (``data/objects/*.toml``), sorted."""
    return _toml_stems("objects")


def builtin_scenes() -> list[str]:
    """Return the names of the bundled scenes (``data/scenes/*.toml``), sorted."""
    return _toml_stems("scenes")


def held_out(kind: str, set_name: str) -> list[str]:
    """Return the names of a held-out set's bundled files of one kind, sorted: ``SET/NAME`` for each
    ``data/<kind>/<SET>/<NAME>.toml``. They load by that name, and :func:`builtin_objects` and
    :func:`builtin_scenes` leave them out, so nothing that walks the built-in data meets them.

    Args:
        kind: ``"objects"`` or ``"scenes"``.
        set_name: the set's folder, e.g. ``"eval2"``.
    """
    return [f"{set_name}/{name}" for name in _toml_stems(f"{kind}/{set_name}")]


def find_data_file(name_or_path: str | Path, kind: str) -> Path:
    """Resolve a built-in name or a file path to a TOML file.

    Args:
        name_or_path: a built-in name (case-sensitive, e.g. ``"square"``) or a path.
        kind: the data subdirectory, ``"objects"`` or ``"scenes"``.

    Returns:
        ``data/<kind>/<name>.toml`` for a built-in name (``SET/NAME`` for a held-out set's, see
        :func:`held_out`), else the path itself.

    Raises:
        InputError: neither a built-in name nor an existing file.
    """
    builtins = _toml_stems(kind)
    if str(name_or_path) in builtins or _HELD_OUT_NAME.fullmatch(str(name_or_path)) and (
            data_dir() / kind / f"{name_or_path}.toml").is_file():
        return data_dir() / kind / f"{name_or_path}.toml"
    path = Path(name_or_path)
    if path.is_file():
        return path
    raise InputError(
        f"no such file, and not a built-in {kind.rstrip('s')} name (built-in: {', '.join(builtins)})",
        source=str(name_or_path),
    )
