"""Provenance: the installed package knows its build, and every results row records it."""

import dataclasses
import datetime
import importlib.metadata
import os
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import slideplan
from slideplan.experiments import ROW_SCHEMA, build_spec, load_results, run_task
from slideplan.experiments.closed_loop import (
    CLOSED_LOOP_ROW_SCHEMA, MODES, SETTINGS, closed_loop_runs, load_closed_loop, run_closed_loop_task,
)
from slideplan.experiments.execution import EXECUTION_ROW_SCHEMA, load_execution, run_execution_task
from slideplan.experiments.results import write_row
from slideplan.provenance import PROVENANCE_COLUMNS, cpu_model, run_provenance

REPO = Path(__file__).resolve().parents[2]
RESULTS = REPO / "docs" / "results"
PARQUET_FILES = sorted(RESULTS.glob("*.parquet")) + sorted((RESULTS / "partial").glob("*.parquet"))
BUILD = re.compile(r"[0-9a-f]{7}(\+dirty)?|unknown")


def git(*args: str) -> str:
    # safe.directory: as in CMakeLists.txt, a checkout owned by another user (a CI container) still answers.
    command = ["git", "-c", f"safe.directory={REPO}", *args]
    return subprocess.run(command, cwd=REPO, capture_output=True, text=True, check=True).stdout.strip()


def test_build_info_names_the_commit_the_installed_package_was_built_from():
    from slideplan import _build

    info = slideplan.build_info()
    assert set(info) == {"build", "commit", "dirty", "version"}
    assert info["build"] == info["commit"] + ("+dirty" if info["dirty"] else "")
    assert BUILD.fullmatch(info["build"]), info
    assert info["version"] == importlib.metadata.version("slideplan")
    # Built from this checkout (as `make install` and CI do; a wheel built elsewhere names its own commit, or
    # "unknown" from a tarball): the commit is the HEAD the checkout had when CMake configured. In CI (a fresh
    # clone) that is HEAD; in a working tree, commits made since may follow it, but none made before (a
    # configure that did not re-run would leave the older commit of an earlier build).
    if Path(_build.SOURCE_DIR).resolve() == REPO and (REPO / ".git").exists():
        assert info["commit"] != "unknown", "built from this checkout, but git did not answer at configure time"
        since = [int(time) for time in git("log", "--format=%ct", f"{info['commit']}..HEAD").split()]
        assert all(time >= _build.CONFIGURED_AT for time in since), (
            f"installed from {info['build']}, but of the {len(since)} commits up to HEAD ({git('rev-parse', '--short', 'HEAD')}) "
            "some are older than the build: make install")
        if os.environ.get("CI"):  # a fresh clone: HEAD itself, and a build that dirties tracked files is a bug
            assert not since and not info["dirty"], info


def test_run_provenance_is_the_build_the_cpu_and_the_utc_date_now():
    before = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)
    row = run_provenance()
    after = datetime.datetime.now(datetime.timezone.utc)
    assert tuple(row) == PROVENANCE_COLUMNS
    assert row["build"] == slideplan.build_info()["build"] and row["version"] == slideplan.build_info()["version"]
    assert row["cpu"] == cpu_model() and row["cpu"] not in ("", "unknown")
    assert row["build_recorded_at_run"] is True
    assert row["date"].endswith("Z")
    assert before <= datetime.datetime.fromisoformat(row["date"].replace("Z", "+00:00")) <= after


@pytest.mark.parametrize("run, schema", [
    (run_task, ROW_SCHEMA), (run_execution_task, EXECUTION_ROW_SCHEMA), (run_closed_loop_task, CLOSED_LOOP_ROW_SCHEMA),
], ids=["plan", "execution", "closed-loop"])
def test_a_row_written_by_each_experiment_records_its_build(run, schema, tmp_path):
    # A task with an object that does not exist: the worker's error row, at once (no planning, no physics).
    task = dataclasses.replace(build_spec("fig11", quick=True).tasks[0], object="no_such_object")
    row = run(task)
    assert row["error"] is not None and set(row) == set(schema.names)
    expected = run_provenance()
    assert {name: row[name] for name in ("build", "version", "cpu", "build_recorded_at_run")} == {
        name: expected[name] for name in ("build", "version", "cpu", "build_recorded_at_run")}
    (tmp_path / "results").mkdir()
    write_row(tmp_path, row, schema)
    written = load_results(tmp_path, schema)
    assert written.loc[0, "build"] == expected["build"] and written.loc[0, "date"] == row["date"]
    assert bool(written.loc[0, "build_recorded_at_run"])


def test_each_closed_loop_run_keeps_its_task_provenance():
    outcomes = {f"{setting}_{mode}_success": True for setting in SETTINGS for mode in MODES}
    row = {field.name: None for field in CLOSED_LOOP_ROW_SCHEMA} | {"task_id": "t", "solved": True} | outcomes | run_provenance()
    runs = closed_loop_runs(pd.DataFrame([row]))
    assert len(runs) == len(SETTINGS) * len(MODES)
    assert (runs["build"] == row["build"]).all() and (runs["date"] == row["date"]).all()
    assert list(runs.columns[-len(PROVENANCE_COLUMNS):]) == list(PROVENANCE_COLUMNS)


@pytest.mark.parametrize("path", PARQUET_FILES, ids=lambda path: str(path.relative_to(RESULTS)))
def test_every_committed_results_file_has_the_provenance_columns(path):
    table = pq.read_table(path)
    assert set(PROVENANCE_COLUMNS) <= set(table.column_names)
    for name in PROVENANCE_COLUMNS:
        assert table[name].null_count == 0, name
    builds = set(table["build"].to_pylist())
    assert all(BUILD.fullmatch(build) or build == "unrecorded" for build in builds), builds
    # Its readers still read it, the provenance included: load_results reads every file (make_tables.py
    # takes them all), the execution and closed-loop task files have their own.
    frames = [load_results(path)]
    if path.name.startswith("execution"):
        frames.append(load_execution(path))
    if "tasks" in path.name or path.parent.name == "partial":
        frames.append(load_closed_loop(path))
    for frame in frames:
        assert len(frame) == table.num_rows and frame["build"].notna().all() and frame["build_recorded_at_run"].notna().all()


def test_the_backfill_script_leaves_the_committed_files_as_they_are():
    sys.path.insert(0, str(RESULTS))
    try:
        import backfill_provenance
    finally:
        sys.path.remove(str(RESULTS))
    assert sorted(RESULTS / name for name in backfill_provenance.FILES) == sorted(PARQUET_FILES)
    for name in backfill_provenance.FILES:
        table = pq.read_table(RESULTS / name)
        assert backfill_provenance.backfilled(table, name).equals(table), name
    # A row that recorded its build at run time keeps it; the others get the page's values again.
    table = pq.read_table(RESULTS / "fig12.parquet").slice(0, 2)
    for name, values in (("build", ["abc1234", "abc1234"]), ("build_recorded_at_run", [True, False])):
        table = table.set_column(table.schema.get_field_index(name), name, pa.array(values))
    again = backfill_provenance.backfilled(table, "fig12.parquet")
    assert again["build"].to_pylist() == ["abc1234", "a37807a"]
    assert again["build_recorded_at_run"].to_pylist() == [True, False]
