"""The modules that moved into the layer packages, by their old names: ``import slideplan.closed_loop`` and
``from slideplan.execute import execute`` still work, with a :class:`DeprecationWarning` naming the new
place. The old names go in the release after next (CHANGELOG.md)."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

# Old module name -> new one. slideplan.perception, slideplan.loop and slideplan.checks are packages now;
# their __init__ hands out what the old module of that name held.
MOVED = {
    "slideplan.geometry": "slideplan.world.geometry", "slideplan.objects": "slideplan.world.objects",
    "slideplan.scenes": "slideplan.world.scenes", "slideplan.timing": "slideplan.plan.timing",
    "slideplan.motions": "slideplan.plan.motions", "slideplan.grasp_checks": "slideplan.checks.grasp",
    "slideplan.verify": "slideplan.checks.verify", "slideplan.pipeline": "slideplan.checks.pipeline",
    "slideplan.check_scene": "slideplan.checks.scene", "slideplan.verdict": "slideplan.checks.verdict",
    "slideplan.camera": "slideplan.perception.camera", "slideplan.framing": "slideplan.perception.framing",
    "slideplan.perception_planes": "slideplan.perception.planes",
    "slideplan.registration": "slideplan.perception.registration",
    "slideplan.perception_files": "slideplan.perception.files", "slideplan.tracking": "slideplan.perception.tracking",
    "slideplan.export": "slideplan.outputs.export", "slideplan.viz": "slideplan.outputs.pictures",
    "slideplan.view": "slideplan.outputs.view3d", "slideplan.bounds": "slideplan.loop.bounds",
    "slideplan.watch": "slideplan.loop.watch", "slideplan.mjscene": "slideplan.sim.mjscene",
    "slideplan.rendering": "slideplan.sim.rendering", "slideplan.closed_loop_settings": "slideplan.sim.conditions",
    "slideplan.closed_loop_run": "slideplan.sim.closed_loop_run", "slideplan.closed_loop": "slideplan.sim.closed_loop",
    "slideplan.plots": "slideplan.experiments.plots", "slideplan.execute": "slideplan.sim",
    **{f"slideplan.execute.{name}": f"slideplan.sim.{name}"
       for name in ("settings", "contacts", "convex", "model", "runner", "video_frames", "video", "report", "replay")},
    "slideplan.execute.world": "slideplan.sim.bodies",
}


def moved_warning(old: str, new: str, stacklevel: int = 2) -> None:
    warnings.warn(f"{old} moved to {new}; the old name goes in a later release", DeprecationWarning, stacklevel=stacklevel)


class _OldNames(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old module name and loads it as the module it moved to (the same module object)."""

    def find_spec(self, name, path=None, target=None):
        return importlib.util.spec_from_loader(name, self) if name in MOVED else None

    def create_module(self, spec):
        moved_warning(spec.name, MOVED[spec.name], stacklevel=8)
        return importlib.import_module(MOVED[spec.name])

    def exec_module(self, module):
        pass  # the new module ran when it was imported


def install() -> None:
    """Put the old names' finder first on :data:`sys.meta_path` (once)."""
    if not any(isinstance(finder, _OldNames) for finder in sys.meta_path):
        sys.meta_path.insert(0, _OldNames())


def forwarding(package: str, path, module: str, api: tuple[str, ...]):
    """The ``__getattr__`` of a package that took an old module's name: it hands out what that module held,
    now in ``module``, the names in ``api`` quietly (the package's own API), the others with a warning.

    Args:
        package: the package's name (``slideplan.perception``).
        path: the package's ``__path__``: its submodules are imported, never looked up in ``module``.
        module: where the old module's contents live now (``slideplan.perception.tabletop``).
        api: the names the package offers as its own.
    """
    import pkgutil

    submodules = {info.name for info in pkgutil.iter_modules(path)}

    def __getattr__(name: str):
        if name.startswith("__") or name in submodules:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        if name not in api:
            moved_warning(f"{package}.{name}", f"{module}.{name}", stacklevel=3)
        return value

    return __getattr__
