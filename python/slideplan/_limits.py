"""The bounds on what a plan or scene file may hold, and the bounded reader of files a plan names:
input from anywhere must be refused in one line, not hang a reader or fill its memory."""

from __future__ import annotations

import os
import stat
from typing import Any

from .errors import InputError

# No number in a plan is larger (metres, radians, seconds, counts): beyond it geometry loses its precision
# (an object moved 1e300 m has no outline left) and it is a corrupted file, not a plan.
MAX_MAGNITUDE = 1e9

# No length or angle in a scene is larger (m, rad): a scene is one robot's workspace, a few metres across,
# and a 1e308 vertex overflows MuJoCo's floats and leaves the planner sampling an endless table.
MAX_SCENE_MAGNITUDE = 1e3

# Waypoints per path of a plan (trajectory, fingertip_poses, grasp.approach). A real plan's slide has tens
# and its approach hundreds (0.02 rad per joint between waypoints: 20,000 is 400 rad of joint travel); 10^6
# took 55 s and 1.5 GB to read.
MAX_WAYPOINTS = 20_000

# A plan file's size. A real plan is ~0.3 MB; one of MAX_WAYPOINTS timed waypoints in both paths, written
# with an indent, is 21 MB (read in 1 s). Parsing a file takes up to 25 times its size (a file of empty
# lists: 0.8 GB at this limit; of numbers, 0.3 GB).
MAX_PLAN_BYTES = 32 << 20

# A robot file (URDF, attached fragment): the largest in example-robot-data (tiago_dual) is 0.2 MB.
MAX_ROBOT_FILE_BYTES = 16 << 20


def read_regular_file(path: str | os.PathLike, limit: int, what: str, field: str = "") -> bytes:
    """The bytes of ``path`` if it is a regular file of at most ``limit`` bytes: a FIFO would block its
    reader forever and a device such as /dev/zero never ends.

    Args:
        path: the file.
        limit: the most bytes it may hold.
        what: the file in words, for messages (``"the plan"``).
        field: where it was named ("" for a file given by the user).

    Raises:
        InputError: naming the file: missing or unreadable, not a regular file, or over ``limit``.
    """
    def fail(problem: str) -> InputError:
        return InputError(problem, source=str(path), field=field)

    try:
        handle = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # a FIFO opens at once, not when a writer comes
    except OSError as error:
        raise fail(f"cannot read {what} ({error.strerror})") from None
    status = os.fstat(handle)
    if not stat.S_ISREG(status.st_mode):  # before fdopen, which refuses a directory naming the descriptor alone
        os.close(handle)
        raise fail(f"{what} is not a regular file" + (" but a directory" if stat.S_ISDIR(status.st_mode) else ""))
    with os.fdopen(handle, "rb") as stream:
        data = stream.read(limit + 1) if status.st_size <= limit else b""  # read to limit + 1: it may grow
        size = max(status.st_size, len(data))
    if size > limit:
        raise fail(f"{what} has {size:,} bytes, more than the limit of {limit >> 20} MB")
    return data


def parse_int(text: str) -> int | float:
    """A JSON integer (``json.loads(..., parse_int=parse_int)``): past 20 digits (no seed or count has
    more) a float, which the magnitude check names by its field, as Python would refuse to convert one of
    over 4300 digits in a ValueError naming none."""
    return int(text) if len(text) <= 20 else float(text)


def require_waypoints(data: dict[str, Any]) -> None:
    """Refuse a plan dict (with all its fields) with a path of more than :data:`MAX_WAYPOINTS` waypoints,
    before the work of reading its rows.

    Raises:
        InputError: naming the path.
    """
    for field, rows in (("trajectory", data["trajectory"]), ("fingertip_poses", data["fingertip_poses"]),
                        ("grasp.approach", data["grasp"].get("approach") if isinstance(data["grasp"], dict) else None)):
        if isinstance(rows, list) and len(rows) > MAX_WAYPOINTS:
            raise InputError(f"{len(rows):,} waypoints, more than the limit of {MAX_WAYPOINTS:,}", field=field)
