"""Files written whole or not at all: every file a command writes goes to a temporary name beside it and is
renamed into place when complete, so a failed write (a full disk, a Ctrl-C, a crash) leaves the file that
was there, never a truncated one, and a reader never sees half a file."""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Iterator
from pathlib import Path


def temporary_path(path: str | Path) -> Path:
    """A fresh hidden name beside ``path`` with the same suffix (writers that pick a format by it still do)."""
    path = Path(path)
    return path.with_name(f".{path.stem}.{os.getpid()}-{uuid.uuid4().hex[:8]}.partial{path.suffix}")


@contextlib.contextmanager
def replacing(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path to write ``path``'s new content to; when the block ends normally, rename it onto
    ``path`` (atomic on one file system); when it raises, remove it and leave ``path`` as it was."""
    temporary = temporary_path(path)
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        with contextlib.suppress(OSError):  # gone already, or its folder never was
            os.unlink(temporary)


def write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` whole or not at all."""
    with replacing(path) as temporary:
        temporary.write_text(text)


def write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` whole or not at all."""
    with replacing(path) as temporary:
        temporary.write_bytes(data)
