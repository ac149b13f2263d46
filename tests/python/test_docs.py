"""Every Python example in README.md and docs/*.md runs as written, in the order it is written."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import plyfile
import pytest
from typer.testing import CliRunner

from slideplan.cli import app

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = re.compile(r"```python\n(.*?)```", re.S)
# docs/demos.md's examples load a generated dataset with the lerobot extra: test_demos runs them, under make test-lerobot.
DOCUMENTS = [path for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
             if EXAMPLE.search(path.read_text()) and path.name != "demos.md"]


@pytest.fixture(scope="module")
def user_files(tmp_path_factory) -> Path:
    """What the examples expect a user to have at hand: a plan written by ``slideplan plan --json``
    and a depth camera's scene cloud (a rendered one) as ``scene.ply``."""
    from slideplan import load_scene
    from slideplan.perception.camera import Camera
    from slideplan.sim.rendering import place_objects, render_scene

    folder = tmp_path_factory.mktemp("user")
    result = CliRunner().invoke(app, ["plan", "--scene", "square", "--object", "crescent", "--pose", "0.55", "-0.08", "0.4",
                                      "--seed", "1", "--json", str(folder / "plan.json")])
    assert result.exit_code == 0, result.output
    rendered = render_scene(load_scene("square").table, place_objects([("crescent", (0.55, -0.08, 0.4))]),
                            camera=Camera((0.40, 0.0, 0.75), (0.50, 0.0, 0.0)), seed=1)
    vertices = np.array([tuple(point) for point in rendered.points], dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
    plyfile.PlyData([plyfile.PlyElement.describe(vertices, "vertex")]).write(str(folder / "scene.ply"))
    return folder


def test_the_documents_have_python_examples():
    assert {"README.md", "execution.md", "perception.md"} <= {path.name for path in DOCUMENTS}


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda path: path.name)
def test_every_python_example_runs_as_written(document, user_files, tmp_path, monkeypatch):
    for name in ("plan.json", "scene.ply"):
        shutil.copy(user_files / name, tmp_path / name)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}  # a document's examples build on each other, as a reader runs them
    for index, block in enumerate(EXAMPLE.findall(document.read_text())):
        exec(compile(block, f"{document.name} example {index + 1}", "exec"), namespace)


FENCE = re.compile(r"```(\w*)\n(.*?)```", re.S)
PLACEHOLDER = re.compile(r"\[|\||\b[A-Z]{2,}\b")  # a synopsis: [--option], a|b, SCENE, X Y Z


def shell_commands(path: Path) -> list[list[str]]:
    """The ``slideplan`` command lines of a document's shell blocks (continuations joined, comments cut),
    as argument lists without the program; synopses with placeholders are left out."""
    import shlex

    commands = []
    for language, body in FENCE.findall(path.read_text()):
        if language in ("python", "text"):
            continue
        for line in body.replace("\\\n", " ").splitlines():
            words = shlex.split(line.split("  #")[0])
            if words and words[0] in ("slideplan", ".venv/bin/slideplan") and not PLACEHOLDER.search(line.split("  #")[0]):
                commands.append(words[1:])
    return commands


COMMANDS = [(path.name, words) for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
            for words in shell_commands(path)]


def parse(words: list[str]) -> None:
    """Parse a command line as `slideplan` would, down to its (sub)command, without running it."""
    import typer

    command, context = typer.main.get_command(app), None
    while True:
        context = command.make_context(context.info_name if context else "slideplan", list(words), parent=context)
        if not hasattr(command, "resolve_command"):
            return
        protected = getattr(context, "_protected_args", None) or getattr(context, "protected_args", [])  # click >= 8.2 or older
        name, command, words = command.resolve_command(context, [*protected, *context.args])


def test_the_documents_have_commands():
    assert len(COMMANDS) >= 20 and {"README.md", "perception.md", "ros2.md", "execution.md"} <= {name for name, _ in COMMANDS}


@pytest.mark.parametrize("document, words", COMMANDS, ids=[f"{name}:{' '.join(words)[:60]}" for name, words in COMMANDS])
def test_every_command_in_the_documents_parses_as_written(document, words):
    parse(words)  # an unknown option, a missing value or a wrong type raises click's usage error


def test_a_mistyped_command_does_not_parse():
    from slideplan.cli.common import click_errors  # typer's own copy of click, or click

    with pytest.raises(click_errors.UsageError):
        parse(["plan", "--scene", "square", "--objekt", "crescent"])
    with pytest.raises(click_errors.UsageError):
        parse(["ros", "serve", "--camera-pose", "1", "2"])


# Hours of sweeps, their plots, nodes that serve until stopped, a whole tier's episodes (test_benchmark scores two);
# and demos, whose lerobot extra make test-physics does not install (test_demos runs generations like it under
# make test-lerobot).
LONG_RUNNING = ("experiment", "plot", "ros", "demos", "eval")


@pytest.mark.physics
def test_the_readme_commands_run_in_order_after_make_demo(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    assert runner.invoke(app, ["demo", "--out", "out"]).exit_code == 0  # what `make demo` leaves
    ran = 0
    for words in shell_commands(ROOT / "README.md"):
        if words[0] in LONG_RUNNING:
            continue
        result = runner.invoke(app, words)
        assert result.exit_code == 0, (words, result.output)
        ran += 1
    assert ran >= 3 and Path("execution.mp4").stat().st_size > 0 and Path("plan.json").exists()


@pytest.mark.parametrize("document", ["docs/closed-loop.md", "docs/ros2.md"])
def test_the_bounds_of_a_run_are_documented_as_the_loop_has_them(document):
    from slideplan.loop.bounds import MAX_REPLANS, MAX_SLIDE_S, NO_PROGRESS_MOVE_M, NO_PROGRESS_TRAVEL_M

    text = " ".join((ROOT / document).read_text().split())
    assert f"after {MAX_REPLANS} re-plans or {MAX_SLIDE_S:g} s of sliding" in text
    assert (f"travels {100 * NO_PROGRESS_TRAVEL_M:g} cm while the object, as seen, does not move "
            f"{1000 * NO_PROGRESS_MOVE_M:g} mm") in text


def test_every_apt_call_of_the_makefile_waits_for_another_apt_s_lock():
    calls = [line for line in (ROOT / "Makefile").read_text().splitlines() if "apt-get" in line and "$(SUDO)" in line]
    assert len(calls) >= 2 and all("-o DPkg::Lock::Timeout=" in line for line in calls), calls
