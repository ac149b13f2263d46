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
DOCUMENTS = [path for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))] if EXAMPLE.search(path.read_text())]


@pytest.fixture(scope="module")
def user_files(tmp_path_factory) -> Path:
    """What the examples expect a user to have at hand: a plan written by ``slideplan plan --json``
    and a depth camera's scene cloud (a rendered one) as ``scene.ply``."""
    from slideplan import load_scene
    from slideplan.camera import Camera
    from slideplan.rendering import place_objects, render_scene

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
