"""Shared fixtures. Tests run headless: PyBullet DIRECT, SDL dummy drivers. A recording made
without --out (in this process or a command it starts) lands in a temporary folder, removed at the
end, never in the checkout's recordings/ or the user's $QUADSIM_RECORDINGS (a test once left a
file there on every run); tests of where recordings land by default unset it themselves."""

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import pytest

from tests.helpers import FLIGHT_CORE_VARIABLE
from tests.helpers.scheduling import SharedSetupScheduling, unit_of

# The flight core: compiled in the test processes themselves (numba is in the test extras), plain
# Python in the processes tests start. Importing numba and loading its cached code costs a process
# 0.7 CPU-s, most of what a short run costs, and the suite starts some 400 such runs. The two are
# the same to the bit (tests/unit/test_compiled.py, tests/e2e/test_compiled.py); tests of the
# compiled path in a process of its own, and of what a user meets by default (the wheel, the
# window), start it with tests.helpers.default_core(env).
os.environ.pop(FLIGHT_CORE_VARIABLE, None)  # a worker inherits it: this process is compiled
from quadsim.core.compiled import CHOICE  # chosen at import: before the variable is set

assert CHOICE == "", "the tests' own process flies the compiled core"
os.environ[FLIGHT_CORE_VARIABLE] = "python"

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
_RECORDINGS = tempfile.mkdtemp(prefix="quadsim-test-recordings-")
os.environ["QUADSIM_RECORDINGS"] = _RECORDINGS
atexit.register(shutil.rmtree, _RECORDINGS, ignore_errors=True)


@pytest.fixture(scope="session")
def vehicle():
    from quadsim.vehicle.params import load_vehicle

    return load_vehicle()


#: The kinds of test, each a folder of tests/ and the marker its tests carry (`-m unit`, ...):
#: unit: in-process, one part at a time, no process started, no sleep;
#: integration: several layers in-process, or at most one process started, no real peer;
#: e2e: real processes, signals, windows, ROS 2 and Foxglove peers, the wheel.
#: The shipped recordings (tests/recordings/, re-flown in-process by the quadsim plugin) are integration.
KINDS = {
    "unit": "in-process, one part at a time: no process started, no sleep (tests/unit/)",
    "integration": "several layers, in-process or one process started, no real peer (tests/integration/)",
    "e2e": "real processes, signals, windows, ROS 2 and Foxglove peers, the wheel (tests/e2e/)",
}
TESTS = Path(__file__).resolve().parent
FOLDER_KIND = {"unit": "unit", "integration": "integration", "e2e": "e2e", "recordings": "integration"}

#: Tests that need the machine to themselves: `make test` runs them one after another, after the
#: rest has run in parallel (pytest-xdist); `make test-fast` runs its unit and integration ones so
#: too. Only one: it serves on Foxglove's default port (8765). Everything else
#: runs in parallel, real-time flights with ROS 2 and Foxglove peers included: their peers keep
#: simulated time and each xdist worker has ROS 2 domains of its own (tests/helpers/ros2_env.py),
#: windows have an Xvfb each (-displayfd) and servers a port each (127.0.0.1:0). A file's path
#: under tests/ takes all its tests; "path::name" the tests whose name starts so.
WHOLE_MACHINE = frozenset(
    {
        "integration/test_foxglove.py::test_loopback_serving_says_no_warning",
    }
)


def _where(item: pytest.Item) -> str:
    """The item's file as a path under tests/ ("e2e/test_sweep.py"); outside tests/, its name."""
    try:
        return item.path.resolve().relative_to(TESTS).as_posix()
    except ValueError:
        return item.path.name


def _needs_the_whole_machine(item: pytest.Item) -> bool:
    where = _where(item)
    if where in WHOLE_MACHINE:
        return True
    return any(
        entry.startswith(f"{where}::") and item.name.startswith(entry.split("::", 1)[1]) for entry in WHOLE_MACHINE
    )


def _kind(item: pytest.Item) -> str | None:
    """unit, integration or e2e: the folder under tests/ the item's file is in."""
    return FOLDER_KIND.get(_where(item).split("/", 1)[0])


def pytest_configure(config):
    config.addinivalue_line("markers", "whole_machine: needs the machine to itself (make test runs these serially)")
    for kind, what in KINDS.items():
        config.addinivalue_line("markers", f"{kind}: {what}")
    if not hasattr(config, "workerinput"):  # once, before any worker starts: the compiled flight core
        _compile_the_flight_core()


def _compile_the_flight_core() -> None:
    """A fresh clone has no compiled flight core cached: build a vehicle once, so that no test's
    run (in parallel workers, all at once) meets the first compile and its note on stderr."""
    from quadsim.core.compiled import will_compile

    if will_compile():
        from quadsim import Simulator

        with Simulator() as sim:
            sim.step(1)


#: the longest tests (or files), longest first: a parallel run hands tests out one at a time in
#: this order (tests/helpers/scheduling.py), so that no long test starts last while the other
#: workers have run out of work. Only the order depends on it; a test missing here runs after
#: these, the end-to-end ones first.
LONG_FIRST = (
    "e2e/test_signals.py::test_no_traceback",  # the signal trials, two at a time, then the file's rest (130 s)
    "e2e/test_damaged_corpus.py",  # on two processes of its own (85 s)
    "e2e/test_sweep.py::test_the_wind_example",  # a local Ray instance, then the pool (50-160 s)
    "e2e/test_check_parallel.py",  # a local Ray instance among them (20-60 s)
    "e2e/test_foxglove.py::test_studio",  # a real Foxglove Studio (45 s)
    "e2e/test_foxglove_layout.py::test_studio",
    "e2e/test_sweep.py::test_ctrl_c_at_random",
    "e2e/test_wheel.py",  # built and installed once for its tests (70 s)
    "e2e/test_ros2.py::test_a_ros2_node_flies_quadsim",
    "e2e/test_replay.py::test_ctrl_c",
    "e2e/test_killed_camera_run.py",
    "e2e/test_one_path.py",
    "e2e/test_twist_matrix.py",
    "e2e/test_ros2.py",
    "e2e/test_foxglove.py",
    "e2e/test_sweep.py",
)
KIND_ORDER = {"e2e": 0, "integration": 1, "unit": 2}


def _rank(item: pytest.Item) -> tuple[int, int]:
    """Where the item goes in the order tests are handed out: LONG_FIRST, then by kind."""
    name = f"{_where(item)}::{item.name}"
    for index, entry in enumerate(LONG_FIRST):
        if name.startswith(entry):
            return index, 0
    return len(LONG_FIRST), KIND_ORDER.get(_kind(item) or "", 1)


def pytest_collection_modifyitems(config, items):
    # the tests of one unit (a setup they share) stay together, where the first of them goes
    unit_rank: dict[str, tuple[int, int]] = {}
    for item in items:
        unit = unit_of(item.nodeid)
        unit_rank[unit] = min(unit_rank.get(unit, _rank(item)), _rank(item))
    items.sort(key=lambda item: unit_rank[unit_of(item.nodeid)])
    for item in items:
        kind = _kind(item)
        if kind is not None:
            item.add_marker(getattr(pytest.mark, kind))
        if _needs_the_whole_machine(item):
            item.add_marker(pytest.mark.whole_machine)


@pytest.hookimpl(tryfirst=True)
def pytest_xdist_make_scheduler(config, log):
    """A parallel run hands out one test (or one unit of tests sharing a setup) at a time."""
    if config.getvalue("dist") == "load":  # what -n gives unless told otherwise
        return SharedSetupScheduling(config, log)
    return None


def pytest_xdist_auto_num_workers(config):
    """`-n auto`: one worker more than the cores. About a fifth of the suite's time is spent
    waiting in real time (flights paced to the clock, ROS 2 and Foxglove peers, windows), while
    the CPU idles: with two workers on two cores it was busy 81 % of the run. Measured on 2 cores:
    the parallel part took 16 min 2 s with two workers, 14 min 35 s with three."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return cores + 1
