"""The package's import layers (docs/design.md, "The Python modules, by layer"): every import of every
module, function-level and TYPE_CHECKING ones included, goes to a module listed above it in the table,
so no two modules import each other, and the table names every module. The ROS node for a real robot
and the closed loop's decisions load no simulation module, however indirectly."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "python" / "slideplan"
DESIGN = ROOT / "docs" / "design.md"
GENERATED = {"slideplan._core", "slideplan._build"}  # built, not in the source tree
# What a real robot's node must not load: MuJoCo, the execution package (its __init__ builds on the MuJoCo
# model) and the closed loop's MuJoCo harness. ros.sim is the simulator, so not in REAL_ROBOT.
SIMULATION = ("mujoco", "slideplan.execute", "slideplan.closed_loop")
REAL_ROBOT = ("slideplan.ros.task", "slideplan.ros.execution", "slideplan.ros.serve", "slideplan.ros.guards",
              "slideplan.ros.messages", "slideplan.ros.call", "slideplan.watch", "slideplan.loop", "slideplan.motions")


def documented_order(text: str) -> list[str]:
    """The modules of the layer table, top (lowest) first."""
    section = text.split("### The Python modules, by layer", 1)[1].split("\n#", 1)[0]
    return re.findall(r"^\| [^|]+ \| `(slideplan[\w.]*)` \|", section, re.M)


def module_name(path: Path, package: Path) -> str:
    parts = list(path.relative_to(package.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path, name: str, known: set[str], outside: tuple[str, ...] = ()) -> list[tuple[int, str]]:
    """``(line, module)`` of every import of a slideplan module in the file, anywhere in it, and of the
    packages named in ``outside`` (as their top-level name: ``mujoco`` for ``mujoco.viewer``)."""
    found = []
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            # `from . import x` imports the module x when there is one, else a name of the package.
            targets = [f"{target}.{alias.name}" if f"{target}.{alias.name}" in known else target for alias in node.names]
        else:
            continue
        for target in targets:
            if target.split(".")[0] in ("slideplan", *outside):
                while target not in known and "." in target:
                    target = target.rsplit(".", 1)[0]
                if target != name:
                    found.append((node.lineno, target))
    return found


def violations(package: Path, order: list[str]) -> list[str]:
    """Every import of a module not above the importer in ``order``, and every module ``order`` lacks."""
    files = {module_name(path, package): path for path in sorted(package.rglob("*.py"))}
    rank = {name: index for index, name in enumerate(order)}
    problems = [f"{name} ({path.relative_to(package.parent)}) has no row in the layer table of docs/design.md"
                for name, path in files.items() if name not in rank]
    problems += [f"the layer table names {name}, which does not exist" for name in order
                 if name not in files and name not in GENERATED]
    known = set(files) | GENERATED
    for name, path in files.items():
        for line, target in imports(path, name, known):
            if name in rank and target in rank and rank[target] >= rank[name]:
                problems.append(f"{path.relative_to(package.parent)}:{line}: {name} imports {target}, "
                                "which the layer table of docs/design.md puts at or below it")
    return problems


def simulation_chains(package: Path, roots) -> list[str]:
    """How each of ``roots`` loads a module of :data:`SIMULATION`, one chain of imports per module it
    reaches (``a -> b -> mujoco``): every import followed through the package, function-level ones
    included, and importing ``a.b.c`` runs ``a`` and ``a.b`` as well."""
    files = {module_name(path, package): path for path in sorted(package.rglob("*.py"))}
    known = set(files) | GENERATED

    def simulated(name: str) -> bool:
        return any(name == module or name.startswith(module + ".") for module in SIMULATION)

    def loaded(name: str) -> list[str]:
        parts = name.split(".")
        return [".".join(parts[:count]) for count in range(1, len(parts) + 1)]

    chains = []
    for root in roots:
        via = {name: [root] if name == root else [root, name] for name in loaded(root)}
        queue = list(via)
        while queue:
            name = queue.pop(0)
            if simulated(name):
                chains.append(" -> ".join(via[name]))
            elif name in files:
                for _, target in imports(files[name], name, known, outside=("mujoco",)):
                    for step in loaded(target):
                        if step not in via:
                            via[step] = via[name] + [step]
                            queue.append(step)
    return chains


def test_every_import_goes_up_the_layer_table():
    order = documented_order(DESIGN.read_text())
    assert len(order) > 40 and len(set(order)) == len(order), "the layer table lists each module once"
    assert violations(PACKAGE, order) == []


def test_a_cycle_is_found_and_named(tmp_path):
    # A scratch package: b imports a inside a function (the kind of import a cycle hides in).
    package = tmp_path / "slideplan"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from . import b\n")
    (package / "b.py").write_text("def late():\n    from .a import thing\n")
    problems = violations(package, ["slideplan.a", "slideplan.b", "slideplan"])
    assert problems == ["slideplan/a.py:1: slideplan.a imports slideplan.b, which the layer table of docs/design.md "
                        "puts at or below it"]
    assert violations(package, ["slideplan.b", "slideplan.a", "slideplan"])[0].startswith("slideplan/b.py:2:")


@pytest.mark.parametrize("missing", ["slideplan.a", "slideplan.b"])
def test_a_module_without_a_row_is_named(tmp_path, missing):
    package = tmp_path / "slideplan"
    package.mkdir()
    for name in ("__init__", "a", "b"):
        (package / f"{name}.py").write_text("")
    order = [name for name in ("slideplan.a", "slideplan.b", "slideplan") if name != missing]
    assert violations(package, order) == [f"{missing} (slideplan/{missing[10:]}.py) has no row in the layer table "
                                          "of docs/design.md"]


def test_the_real_robots_node_and_the_loops_decisions_load_no_simulation():
    assert simulation_chains(PACKAGE, REAL_ROBOT) == []


def test_a_simulation_import_is_found_however_deep_and_its_chain_named(tmp_path):
    # A scratch package: ros.task imports the decisions, whose function imports the harness; ros.call's
    # helper imports mujoco in a function; ros.messages imports a module whose package's __init__ imports
    # the harness; ros.guards is clean.
    package = tmp_path / "slideplan"
    (package / "ros").mkdir(parents=True)
    (package / "pkg").mkdir()
    for name in ("__init__", "ros/__init__", "closed_loop", "helper", "pkg/leaf"):
        (package / f"{name}.py").write_text("")
    (package / "pkg" / "__init__.py").write_text("from .. import closed_loop\n")
    (package / "ros" / "messages.py").write_text("from ..pkg.leaf import thing\n")
    (package / "ros" / "task.py").write_text("from ..loop import SlideLoop\n")
    (package / "loop.py").write_text("def later():\n    from . import closed_loop\n")
    (package / "ros" / "call.py").write_text("from .. import helper\n")
    (package / "helper.py").write_text("def render():\n    import mujoco.renderer\n")
    (package / "ros" / "guards.py").write_text("import numpy\n")
    chains = simulation_chains(package, ["slideplan.ros.task", "slideplan.ros.call", "slideplan.ros.messages",
                                         "slideplan.ros.guards"])
    assert chains == ["slideplan.ros.task -> slideplan.loop -> slideplan.closed_loop",
                      "slideplan.ros.call -> slideplan.helper -> mujoco",
                      "slideplan.ros.messages -> slideplan.pkg -> slideplan.closed_loop"]
