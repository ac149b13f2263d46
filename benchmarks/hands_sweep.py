"""Execution of every bundled hand: each robot's plans executed in MuJoCo with its own gripper.

For each scene, 5 objects x N seeded poses (the poses drawn on its table as ``slideplan demo`` draws
one), plan (10 s limit, the pose's seed) and execute the plan with the default settings. Writes one row per
run (scene, object, seed, solved, whether the slide ended within tolerance of Eq. 2, lifted, success, the
errors, the failure, and the provenance columns) to ``--rows``; docs/results/make_tables.py writes
docs/results/hands.md's tables from the committed rows (docs/results/numbers_hands.py). Not a test:
``make bench``.

    python benchmarks/hands_sweep.py [--poses 2] [--scenes square panda_square ...] [--rows docs/results/hands.parquet]
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from slideplan import PlannerConfig, load_scene, plan
from slideplan.errors import SlideplanWarning
from slideplan.sim import execute
from slideplan.experiments.results import PROVENANCE_FIELDS
from slideplan.world.objects import load_object, load_outline, sample_pose_on_table
from slideplan.provenance import run_provenance

OBJECTS = ("square", "circle", "triangle", "crescent", "irregular")
SCENES = ("square", "panda_square", "ur5_gripper_square", "z1_square", "so101_square")


def sweep(scene_name: str, poses: int) -> list[dict]:
    """One row per run of a scene: object, seed, solved, and what execution reported."""
    scene = load_scene(scene_name)
    rows = []
    for name in OBJECTS:
        outline, _, _ = load_outline(name)
        for seed in range(poses):
            pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(seed))
            obj = load_object(name, table_height=scene.table.height, pose=pose)
            result = plan(scene, obj, PlannerConfig.for_scene(scene, seed=seed, time_limit_s=10.0))
            row = {"scene": scene_name, "object": name, "seed": seed, "solved": bool(result.solved), "slid": None,
                   "lifted": None, "success": None, "position_error_mm": np.nan, "yaw_error_deg": np.nan,
                   "failure": None}
            if result.solved:
                run = execute(result)
                row.update(slid=run.failed_stage not in ("slide", "simulation"), lifted=bool(run.lifted),
                           success=bool(run.success), position_error_mm=1e3 * (run.position_error_m or np.nan),
                           yaw_error_deg=abs(run.yaw_error_deg or np.nan), failure=run.failure)
            rows.append({**row, **run_provenance()})
            print(row, flush=True)
    return rows


def write_rows(rows: list[dict], path: Path) -> None:
    """The rows as Parquet, the provenance columns with the types every results file gives them."""
    table = pa.Table.from_pandas(pd.DataFrame(rows), preserve_index=False)
    schema = table.schema
    for field in PROVENANCE_FIELDS:
        schema = schema.set(schema.get_field_index(field.name), field)
    pq.write_table(table.cast(schema), path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=2, help="seeded poses per object")
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), help="built-in scenes or scene files")
    parser.add_argument("--rows", type=Path, default=Path(__file__).resolve().parents[1] / "docs/results/hands.parquet")
    arguments = parser.parse_args()
    warnings.simplefilter("ignore", SlideplanWarning)  # the Z1's meshes checked as triangles: said in the docs
    rows = []
    for name in arguments.scenes:
        rows += sweep(name, arguments.poses)
        write_rows(rows, arguments.rows)  # after every scene: a stopped run keeps its rows
    print(f"{arguments.rows}: {len(rows)} rows; docs/results/make_tables.py writes the page")


if __name__ == "__main__":
    main()
