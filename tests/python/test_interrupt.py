"""Ctrl-C during a long C++ solve: the GIL is released, the termination condition polls Python's
signal handlers, and KeyboardInterrupt reaches the caller promptly."""

import signal
import subprocess
import sys
import time

import pytest

# An impossible task: a 10 cm square turned by at most 0.2 rad overhangs an edge by at most 5.4 cm
# with its centre of mass 5 mm inside, so the planner would run to its 60 s limit unless interrupted.
SCRIPT = """
import sys, time
from slideplan import PlannerConfig, load_object, load_scene, plan
scene = load_scene("square")
obj = load_object("square", table_height=0.0, pose=(0.5, 0.0, 0.0))
print("planning", flush=True)
started = time.monotonic()
try:
    plan(scene, obj, PlannerConfig(u_star=0.055, max_object_yaw=0.2, time_limit_s=60.0))
except KeyboardInterrupt:
    print("interrupted after %.3f" % (time.monotonic() - started), flush=True)
    sys.exit(42)
print("not interrupted", flush=True)
"""


def test_ctrl_c_stops_planning_within_half_a_second():
    # A background job inherits SIGINT ignored, and Python then installs no KeyboardInterrupt handler:
    # give the child the default disposition, as a terminal's foreground process has.
    process = subprocess.Popen([sys.executable, "-c", SCRIPT], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        assert process.stdout.readline().strip() == "planning"
        time.sleep(1.5)  # well inside the solve
        signalled = time.monotonic()
        process.send_signal(signal.SIGINT)
        output = process.stdout.readline()
        latency = time.monotonic() - signalled
        assert process.wait(timeout=10) == 42, process.stderr.read()
    finally:
        process.kill()
    assert output.startswith("interrupted after"), output
    assert latency < 0.5, f"planning stopped {latency:.3f} s after Ctrl-C"


DAEMON = """
import sys, threading, time
from slideplan import PlannerConfig, load_object, load_scene, plan
scene = load_scene("square")
obj = load_object("square", table_height=0.0, pose=(0.5, 0.0, 0.0))
thread = threading.Thread(target=plan, args=(scene, obj, PlannerConfig(u_star=0.055, max_object_yaw=0.2, time_limit_s=60.0)),
                          daemon=True)
thread.start()
time.sleep(1.0)  # inside the solve
print("exiting", flush=True)
{exit}
"""


@pytest.mark.parametrize("exit_call", ["sys.exit(0)", "pass", "raise SystemExit(0)"])
def test_the_interpreter_exits_cleanly_while_a_daemon_thread_plans(exit_call):
    # Once: SIGABRT, "terminate called without an active exception", when the planning thread took the GIL
    # back during shutdown.
    done = subprocess.run([sys.executable, "-c", DAEMON.format(exit=exit_call)], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "exiting"
    assert done.returncode == 0, done.stderr
    assert "terminate" not in done.stderr


# A Ctrl-C while the command's modules import (about 0.3 s), made certain: the import of slideplan.cli
# is interrupted as SIGINT would interrupt it.
LAUNCH = """
import sys

class Interrupt:
    def find_spec(self, name, path=None, target=None):
        if name == "slideplan.cli":
            raise KeyboardInterrupt

sys.meta_path.insert(0, Interrupt())
sys.argv = ["slideplan", "--help"]
from importlib.metadata import entry_points
(script,) = entry_points(group="console_scripts", name="slideplan")
script.load()()
"""


# The same Ctrl-C landing inside NumPy's C extensions: NumPy re-raises it as an ImportError telling the user to
# reinstall it ("Importing the numpy C-extensions failed"), the KeyboardInterrupt as its context.
LAUNCH_IN_NUMPY = LAUNCH.replace("raise KeyboardInterrupt", """try:
                raise KeyboardInterrupt
            except KeyboardInterrupt:
                raise ImportError("Importing the numpy C-extensions failed.")""")


def test_ctrl_c_inside_numpy_s_import_is_an_interrupt_too():
    done = subprocess.run([sys.executable, "-c", LAUNCH_IN_NUMPY], capture_output=True, text=True, timeout=60)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip() == "slideplan: aborted"


def test_an_import_error_of_its_own_is_not_taken_for_an_interrupt():
    broken = LAUNCH.replace("raise KeyboardInterrupt", "raise ImportError('no module named something')")
    done = subprocess.run([sys.executable, "-c", broken], capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and "no module named something" in done.stderr


def test_ctrl_c_while_the_command_imports_exits_130_with_one_line():
    done = subprocess.run([sys.executable, "-c", LAUNCH], capture_output=True, text=True, timeout=60)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip() == "slideplan: aborted"


def test_the_entry_point_and_the_command_line_exit_130_alike():
    import _slideplan_entry

    from slideplan.cli.common import EXIT_INTERRUPTED

    assert _slideplan_entry.EXIT_INTERRUPTED == EXIT_INTERRUPTED == 130
