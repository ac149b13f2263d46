"""Modules that moved into the layer packages keep working under their old names, with a warning naming
the new place; the packages that took an old module's name hand out what it held."""

import subprocess
import sys

import pytest

from slideplan._moved import MOVED

# Each old name, a name the docs used from it, and the module that now holds that name.
OLD_NAMES = [("slideplan.closed_loop", "run", "slideplan.sim.closed_loop"),
             ("slideplan.execute", "execute", "slideplan.sim.replay"),
             ("slideplan.execute.world", "object_boxes", "slideplan.sim.bodies"),
             ("slideplan.verify", "verify", "slideplan.checks.verify"),
             ("slideplan.viz", None, "slideplan.outputs.pictures"),
             ("slideplan.closed_loop_settings", "setting_draws", "slideplan.sim.conditions")]


@pytest.mark.parametrize("old, name, home", OLD_NAMES)
def test_an_old_module_name_imports_the_new_module_and_warns(old, name, home):
    # A fresh interpreter: this one may have imported the old name already (the warning comes once).
    code = (f"import importlib, warnings\nwarnings.simplefilter('error')\ntry:\n    importlib.import_module({old!r})\n"
            "except DeprecationWarning as warning:\n    print(warning)\n"
            f"warnings.simplefilter('ignore')\nmodule = importlib.import_module({old!r})\n"
            f"print(module.__name__ == {MOVED[old]!r})")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    warning, same = done.stdout.splitlines()
    parts = old.split(".")
    first = next(".".join(parts[:count]) for count in range(2, len(parts) + 1) if ".".join(parts[:count]) in MOVED)
    assert warning == f"{first} moved to {MOVED[first]}; the old name goes in a later release" and same == "True"
    if name and home:
        import importlib

        with pytest.warns(DeprecationWarning):
            module = importlib.import_module(old)
        assert getattr(module, name).__module__ == home


def test_the_packages_that_took_an_old_module_s_name_hand_out_its_contents():
    import slideplan.checks
    import slideplan.loop
    import slideplan.perception
    from slideplan.checks.common import pose_mismatch
    from slideplan.loop.decisions import SlideLoop
    from slideplan.perception.tabletop import perceive

    assert slideplan.perception.perceive is perceive and slideplan.loop.SlideLoop is SlideLoop  # their API: no warning
    with pytest.warns(DeprecationWarning, match="slideplan.checks.pose_mismatch moved to slideplan.checks.common"):
        assert slideplan.checks.pose_mismatch is pose_mismatch
    with pytest.raises(AttributeError):
        slideplan.perception.no_such_name  # noqa: B018
