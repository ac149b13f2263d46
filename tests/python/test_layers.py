"""The package's import layers (docs/design.md, "The Python packages, by layer"): every import of every
module, function-level and TYPE_CHECKING ones included, goes to its own package or to a package listed
above it in the table, the modules at the root being the foundation; no chain of imports comes back to
where it started, the console entry included; the table names every package. The ROS node for a real
robot and the closed loop's decisions load no simulation module, however indirectly, and reading or
making a plan loads no perception, simulation or verifier."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "python" / "slideplan"
ENTRY = ROOT / "python" / "_slideplan_entry"
DESIGN = ROOT / "docs" / "design.md"
GENERATED = {"slideplan._core", "slideplan._build"}  # built, not in the source tree
FOUNDATION = "slideplan._foundation"  # the table's name for the modules at the package's root
# What a real robot's node must not load: MuJoCo and the simulation package. ros.sim is the simulator.
SIMULATION = ("mujoco", "slideplan.sim")
REAL_ROBOT = ("slideplan.ros.task", "slideplan.ros.execution", "slideplan.ros.serve", "slideplan.ros.guards",
              "slideplan.ros.messages", "slideplan.ros.call", "slideplan.loop.watch", "slideplan.loop.decisions",
              "slideplan.loop.bounds", "slideplan.plan.motions")


def documented_order(text: str) -> list[str]:
    """The packages of the layer table, top (lowest) first; the foundation row is :data:`FOUNDATION`."""
    section = text.split("### The Python packages, by layer", 1)[1].split("\n#", 1)[0]
    rows = re.findall(r"^\| ([^|]+) \| ([^|]+) \|", section, re.M)
    return [FOUNDATION if layer.strip() == "foundation" else re.search(r"`(slideplan[\w.]*)`", package).group(1)
            for layer, package in rows if "`" in package]


def layer_of(name: str, order: list[str]) -> str:
    """The table's row of a module: its package's (the longest listed prefix), or the foundation for a
    module at the package's root; the root package itself is the ``slideplan`` row."""
    parts = name.split(".")
    for count in range(len(parts), 0, -1):
        if ".".join(parts[:count]) in order and (count > 1 or name == "slideplan"):
            return ".".join(parts[:count])
    return FOUNDATION if len(parts) == 2 else ""


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
    """Every import of a module in a package below the importer's in ``order``, every package ``order``
    lacks, and every row that names no package."""
    files = {module_name(path, package): path for path in sorted(package.rglob("*.py"))}
    rank = {name: index for index, name in enumerate(order)}
    problems = [f"{name} ({path.relative_to(package.parent)}) has no row in the layer table of docs/design.md"
                for name, path in files.items() if layer_of(name, order) not in rank]
    problems += [f"the layer table names {name}, which does not exist" for name in order
                 if name != FOUNDATION and name not in files]
    known = set(files) | GENERATED
    for name, path in files.items():
        for line, target in imports(path, name, known):
            mine, theirs = layer_of(name, order), layer_of(target, order)
            if mine in rank and theirs in rank and rank[theirs] > rank[mine]:
                problems.append(f"{path.relative_to(package.parent)}:{line}: {name} imports {target}, "
                                "whose package the layer table of docs/design.md puts below it")
    return problems


def cycles(packages: list[Path]) -> list[str]:
    """Every chain of imports that comes back to where it started (``a -> b -> a``), one per cycle found:
    every import followed, function-level ones included, importing ``a.b.c`` running ``a`` and ``a.b``."""
    files = {module_name(path, package): path for package in packages for path in sorted(package.rglob("*.py"))}
    known = set(files) | GENERATED

    def loaded(name: str) -> list[str]:
        parts = name.split(".")
        return [".".join(parts[:count]) for count in range(1, len(parts) + 1) if ".".join(parts[:count]) in files]

    # A module's own packages ran (or are running) before it: an import of them closes no cycle.
    edges = {name: sorted({step for _, target in imports(path, name, known, outside=("_slideplan_entry",))
                           for step in loaded(target) if step != name and not name.startswith(step + ".")})
             for name, path in files.items()}
    found, state, stack = [], {}, []

    def visit(name: str) -> None:
        state[name] = "open"
        stack.append(name)
        for target in edges.get(name, ()):
            if state.get(target) == "open":
                found.append(" -> ".join(stack[stack.index(target):] + [target]))
            elif target not in state:
                visit(target)
        stack.pop()
        state[name] = "done"

    for name in sorted(files):
        if name not in state:
            visit(name)
    return found


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


def scratch(tmp_path: Path, files: dict[str, str]) -> Path:
    """A scratch package ``slideplan`` of the given files (path -> text), each package with an ``__init__``."""
    package = tmp_path / "slideplan"
    for name, text in {"__init__.py": "", **files}.items():
        path = package / name
        path.parent.mkdir(parents=True, exist_ok=True)
        for folder in [path.parent, *path.parent.parents]:
            if folder == package.parent:
                break
            (folder / "__init__.py").touch()
        path.write_text(text)
    return package


def test_every_import_goes_up_the_layer_table():
    order = documented_order(DESIGN.read_text())
    assert order[0] == FOUNDATION and order[-1] == "slideplan" and len(set(order)) == len(order) >= 12
    assert violations(PACKAGE, order) == []


def test_only_the_foundation_lies_at_the_package_s_root():
    section = DESIGN.read_text().split("### The Python packages, by layer", 1)[1].split("\n#", 1)[0]
    foundation_row = next(row for row in section.splitlines() if row.startswith("| foundation"))
    listed = set(re.findall(r"`(\w+)`", foundation_row))
    at_root = {path.stem for path in PACKAGE.glob("*.py") if path.stem != "__init__"} | {"_core", "_build"}
    assert at_root == listed


def test_an_import_of_a_lower_package_is_found_and_named(tmp_path):
    # b's module imports a inside a function (the kind of import a cycle hides in); a imports b.
    package = scratch(tmp_path, {"a/x.py": "from ..b import y\n", "b/y.py": "def late():\n    from ..a.x import thing\n"})
    problems = violations(package, [FOUNDATION, "slideplan.a", "slideplan.b", "slideplan"])
    assert problems == ["slideplan/a/x.py:1: slideplan.a.x imports slideplan.b.y, whose package the layer table of "
                        "docs/design.md puts below it"]
    assert violations(package, [FOUNDATION, "slideplan.b", "slideplan.a", "slideplan"])[0].startswith("slideplan/b/y.py:2:")
    assert cycles([package]) == ["slideplan.a.x -> slideplan.b.y -> slideplan.a.x"]


def test_a_cycle_through_a_package_s_init_or_the_console_entry_is_found(tmp_path):
    package = scratch(tmp_path, {"a/__init__.py": "from .x import thing\n", "a/x.py": "", "b.py": "import slideplan.a.x\n",
                                 "a/z.py": "def late():\n    from .. import b\n", "cli/common.py": "from _slideplan_entry import CODE\n",
                                 "cli/__init__.py": "from . import common\n"})
    assert cycles([package]) == []  # a module's own package running first closes no cycle
    (package / "a" / "x.py").write_text("from .. import b\n")
    assert "slideplan.a -> slideplan.a.x -> slideplan.b -> slideplan.a" in cycles([package])
    (package / "a" / "x.py").write_text("")
    entry = tmp_path / "_slideplan_entry"
    entry.mkdir()
    (entry / "__init__.py").write_text("CODE = 1\ndef main():\n    from slideplan.cli import app\n")
    assert cycles([package, entry]) == ["_slideplan_entry -> slideplan.cli -> slideplan.cli.common -> _slideplan_entry"]


def test_no_import_cycle_anywhere_the_console_entry_included():
    assert cycles([PACKAGE, ENTRY]) == []


@pytest.mark.parametrize("missing", ["slideplan.a", "slideplan.b"])
def test_a_package_without_a_row_is_named(tmp_path, missing):
    package = scratch(tmp_path, {"a/x.py": "", "b/y.py": ""})
    order = [name for name in (FOUNDATION, "slideplan.a", "slideplan.b", "slideplan") if name != missing]
    problems = violations(package, order)
    assert problems and all(missing in problem and "has no row" in problem for problem in problems)


def test_the_real_robots_node_and_the_loops_decisions_load_no_simulation():
    assert simulation_chains(PACKAGE, REAL_ROBOT) == []


def test_a_simulation_import_is_found_however_deep_and_its_chain_named(tmp_path):
    # ros.task imports the decisions, whose function imports the harness; ros.call's helper imports mujoco in
    # a function; ros.messages imports a module whose package's __init__ imports the harness; ros.guards is clean.
    package = scratch(tmp_path, {
        "sim/closed_loop.py": "", "helper.py": "def render():\n    import mujoco.renderer\n", "pkg/leaf.py": "",
        "pkg/__init__.py": "from ..sim import closed_loop\n", "ros/messages.py": "from ..pkg.leaf import thing\n",
        "ros/task.py": "from ..loop.decisions import SlideLoop\n",
        "loop/decisions.py": "def later():\n    from ..sim import closed_loop\n",
        "ros/call.py": "from .. import helper\n", "ros/guards.py": "import numpy\n"})
    chains = simulation_chains(package, ["slideplan.ros.task", "slideplan.ros.call", "slideplan.ros.messages",
                                         "slideplan.ros.guards"])
    assert chains == ["slideplan.ros.task -> slideplan.loop.decisions -> slideplan.sim",
                      "slideplan.ros.task -> slideplan.loop.decisions -> slideplan.sim.closed_loop",
                      "slideplan.ros.call -> slideplan.helper -> mujoco",
                      "slideplan.ros.messages -> slideplan.pkg -> slideplan.sim",
                      "slideplan.ros.messages -> slideplan.pkg -> slideplan.sim.closed_loop"]


@pytest.mark.parametrize("module", ["slideplan.plan", "slideplan.plan.result", "slideplan.world.scenes"])
def test_reading_or_making_a_plan_loads_no_perception_simulation_or_verifier(module):
    code = f"import sys, {module}; print(' '.join(sorted(sys.modules)))"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert module in loaded and "slideplan.plan.planner" in loaded
    assert [name for name in loaded if name.split(".")[0] == "mujoco" or name.startswith(
        ("slideplan.perception", "slideplan.sim", "slideplan.checks"))] == []


def test_the_layout_s_counts_are_the_tree_s():
    layout = DESIGN.read_text().split("## 4. Layout", 1)[1].split("###", 1)[0]
    headers = len(list((ROOT / "cpp" / "include" / "slideplan").glob("*.hpp")))
    scenes, objects = (len(list((ROOT / "data" / kind).glob("*.toml"))) for kind in ("scenes", "objects"))
    assert f"one header per concept ({headers})" in layout
    assert f"{scenes} scenes (TOML)" in layout and f"{objects} outlines (TOML)" in layout
