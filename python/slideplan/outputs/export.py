"""Export a timed plan for a robot controller: ROS ``JointTrajectory`` JSON or a flat CSV.

Two segments, each starting at t = 0 and at rest: ``slide`` (the plan's ``trajectory``) and
``approach`` (``grasp.approach``: lift, transfer and approach to the grasp). Send them one after
the other.

- ``ros-json``: ``{"format", "segments": [{"name", "joint_trajectory"}], "limits"}`` where each
  ``joint_trajectory`` has exactly the fields of ``trajectory_msgs/msg/JointTrajectory`` (ROS 2:
  ``header``, ``joint_names``, ``points`` with ``positions``, ``velocities``, ``accelerations``,
  ``effort``, ``time_from_start {sec, nanosec}``), so it can be published as it is (e.g. with
  rosbridge, or converted to YAML for ``ros2 topic pub``).
- ``csv``: one row per waypoint: ``segment, time_from_start`` (s), then ``position_<joint>``,
  ``velocity_<joint>``, ``acceleration_<joint>`` for every joint; numbers written so that they
  read back exactly.
"""

from __future__ import annotations

import csv
import dataclasses
import io
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import jsontext
from .._files import write_text
from ..errors import InputError
from ..checks.verify import require_motion

if TYPE_CHECKING:
    from ..plan.result import PlanResult

FORMATS = ("ros-json", "csv")
ROS_JSON_FORMAT = "slideplan.joint_trajectories/1"
SEGMENTS = (("slide", "trajectory"), ("approach", "approach"))  # (exported name, timing key)


def segments(result: PlanResult) -> list[dict[str, Any]]:
    """The timed segments of a solved plan with timing.

    Args:
        result: the plan (``timing`` not None).

    Returns:
        ``[{"name", "positions" (M, dof), "time_from_start" (M,), "velocities", "accelerations"}]``.
    """
    paths = {"trajectory": result.trajectory, "approach": result.grasp["approach"]}
    return [
        {"name": name, "positions": np.asarray(paths[key], dtype=float), **result.timing[key]}
        for name, key in SEGMENTS
    ]


def duration(seconds: float) -> dict[str, int]:
    """A ``builtin_interfaces/Duration`` (ROS 2) for a time in seconds, rounded to the nanosecond.

    Args:
        seconds: time >= 0 (s).

    Returns:
        ``{"sec": int, "nanosec": int}`` with ``0 <= nanosec < 10**9``.
    """
    total = round(float(seconds) * 1e9)
    return {"sec": total // 10**9, "nanosec": total % 10**9}


def to_ros_json(result: PlanResult) -> str:
    """The plan's segments as ROS ``JointTrajectory`` messages in one JSON document.

    Args:
        result: a solved plan with timing.

    Returns:
        JSON text (see the module docstring).
    """
    document = {
        "format": ROS_JSON_FORMAT,
        "segments": [
            {
                "name": segment["name"],
                "joint_trajectory": {
                    "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},  # zero stamp: start on receipt
                    "joint_names": list(result.joint_names),
                    "points": [
                        {
                            "positions": segment["positions"][index].tolist(),
                            "velocities": segment["velocities"][index].tolist(),
                            "accelerations": segment["accelerations"][index].tolist(),
                            "effort": [],
                            "time_from_start": duration(segment["time_from_start"][index]),
                        }
                        for index in range(len(segment["time_from_start"]))
                    ],
                },
            }
            for segment in segments(result)
        ],
        "limits": {key: np.asarray(value).tolist() for key, value in result.timing["limits"].items()},
    }
    return jsontext.dumps(document, indent=1)


def to_csv(result: PlanResult) -> str:
    """The plan's segments as one flat CSV table.

    Args:
        result: a solved plan with timing.

    Returns:
        CSV text with a header row (see the module docstring).
    """
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(
        ["segment", "time_from_start"]
        + [f"{quantity}_{joint}" for quantity in ("position", "velocity", "acceleration") for joint in result.joint_names]
    )
    for segment in segments(result):
        for index, time in enumerate(segment["time_from_start"]):
            values = np.concatenate([segment[key][index] for key in ("positions", "velocities", "accelerations")])
            writer.writerow([segment["name"], repr(float(time))] + [repr(float(value)) for value in values])
    return buffer.getvalue()


def export_plan(result: PlanResult, fmt: str, out: Path) -> None:
    """Write a solved plan's timed segments to a file, timing it first if it has no timing.

    Args:
        result: the plan; a ``slideplan.plan/1`` plan (no timing) is parameterized with the
            default limits (:func:`slideplan.plan.timing.parameterize`).
        fmt: ``"ros-json"`` or ``"csv"``.
        out: the output file (its directory is created).

    Raises:
        InputError: unknown format, a plan that is not solved or whose motion cannot be run
            (:func:`slideplan.checks.verify.require_motion`), or a timing failure.
        OSError: the file cannot be written.
    """
    if fmt not in FORMATS:
        raise InputError(f"unknown format {fmt!r} (expected one of: {', '.join(FORMATS)})", field="--format")
    if not result.solved:
        raise InputError(f"the plan is not solved (status {result.status!r}): nothing to export", field="status")
    require_motion(result)
    if result.timing is None:
        from ..plan.timing import parameterize

        result = dataclasses.replace(result, timing=parameterize(result))
    out.parent.mkdir(parents=True, exist_ok=True)
    write_text(out, to_ros_json(result) if fmt == "ros-json" else to_csv(result))
