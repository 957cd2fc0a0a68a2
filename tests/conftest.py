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

#: Tests that need the machine to themselves: they fly in real time against real peers and
#: windows, post signals into running flights or load every core (CPU hogs, Ray). `make test` runs
#: them one after another, after the rest has run in parallel (pytest-xdist); `make test-fast` runs
#: its unit and integration ones so too. A file's path under tests/ takes all its tests;
#: "path::name" the tests whose name starts so.
WHOLE_MACHINE = frozenset(
    {
        "integration/test_camera_accounts.py",
        "e2e/test_check_parallel.py",
        "unit/test_foxglove.py",
        "integration/test_foxglove.py",
        "e2e/test_foxglove.py",
        "e2e/test_foxglove_front.py",
        "e2e/test_foxglove_layout.py::test_studio_148",
        "e2e/test_killed_camera_run.py",
        "integration/test_recording_safety.py",
        "e2e/test_recording_safety.py",
        "unit/test_ros2.py",
        "e2e/test_ros2.py",
        "unit/test_ros2_bridge.py",
        "e2e/test_ros2_bridge.py",
        "e2e/test_signals.py",
        "e2e/test_sweep.py::test_the_wind_example_on_ray",
        "e2e/test_sweep.py::test_ctrl_c_at_random_moments",
        "e2e/test_sweep.py::test_a_second_signal",
        "e2e/test_sweep.py::test_a_worker_killed_from_outside",
        "e2e/test_sweep.py::test_pool_workers_fork",
        "e2e/test_sweep.py::test_without_numba_a_long_sweep",
        "e2e/test_twist_matrix.py::test_every_path_flies_every_field[ros2",
        "e2e/test_twist_matrix.py::test_every_path_flies_every_field[foxglove",
        "integration/test_window_realtime.py",
        "e2e/test_window_realtime.py",
        "e2e/test_window_x11.py",
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


def pytest_collection_modifyitems(config, items):
    for item in items:
        kind = _kind(item)
        if kind is not None:
            item.add_marker(getattr(pytest.mark, kind))
        if _needs_the_whole_machine(item):
            item.add_marker(pytest.mark.whole_machine)
