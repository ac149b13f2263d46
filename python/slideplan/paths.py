"""Where the bundled data (robots, scenes, objects) lives."""

from __future__ import annotations

from pathlib import Path

from .errors import InputError


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


def find_data_file(name_or_path: str | Path, kind: str) -> Path:
    """Resolve a built-in name or a file path to a TOML file.

    Args:
        name_or_path: a built-in name (case-sensitive, e.g. ``"square"``) or a path.
        kind: the data subdirectory, ``"objects"`` or ``"scenes"``.

    Returns:
        ``data/<kind>/<name>.toml`` for a built-in name, else the path itself.

    Raises:
        InputError: neither a built-in name nor an existing file.
    """
    builtins = _toml_stems(kind)
    if str(name_or_path) in builtins:
        return data_dir() / kind / f"{name_or_path}.toml"
    path = Path(name_or_path)
    if path.is_file():
        return path
    raise InputError(
        f"no such file, and not a built-in {kind.rstrip('s')} name (built-in: {', '.join(builtins)})",
        source=str(name_or_path),
    )
