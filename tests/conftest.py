"""Shared fixtures. Tests run headless: PyBullet DIRECT, SDL dummy drivers. A recording made
without --out (in this process or a command it starts) lands in a temporary folder, removed at the
end, never in the checkout's recordings/ or the user's $QUADSIM_RECORDINGS (a test once left a
file there on every run); tests of where recordings land by default unset it themselves."""

import atexit
import os
import shutil
import tempfile

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


#: Tests that need the machine to themselves: they fly in real time against real peers and
#: windows, post signals into running flights or load every core (CPU hogs, Ray). `make test` runs
#: them one after another, after the rest has run in parallel (pytest-xdist). A file's name takes
#: all its tests; "file.py::name" the tests whose name starts so.
WHOLE_MACHINE = frozenset(
    {
        "test_camera_accounts.py",
        "test_check_parallel.py",
        "test_foxglove.py",
        "test_foxglove_front.py",
        "test_foxglove_layout.py::test_studio_148",
        "test_killed_camera_run.py",
        "test_recording_safety.py",
        "test_ros2.py",
        "test_ros2_bridge.py",
        "test_signals.py",
        "test_sweep.py::test_the_wind_example_on_ray",
        "test_sweep.py::test_ctrl_c_at_random_moments",
        "test_sweep.py::test_a_second_signal",
        "test_sweep.py::test_a_worker_killed_from_outside",
        "test_sweep.py::test_pool_workers_fork",
        "test_sweep.py::test_without_numba_a_long_sweep",
        "test_twist_matrix.py::test_every_path_flies_every_field[ros2",
        "test_twist_matrix.py::test_every_path_flies_every_field[foxglove",
        "test_window_realtime.py",
        "test_window_x11.py",
    }
)


def _needs_the_whole_machine(item: pytest.Item) -> bool:
    if item.path.name in WHOLE_MACHINE:
        return True
    return any(
        entry.startswith(f"{item.path.name}::") and item.name.startswith(entry.split("::", 1)[1])
        for entry in WHOLE_MACHINE
    )


def pytest_configure(config):
    config.addinivalue_line("markers", "whole_machine: needs the machine to itself (make test runs these serially)")
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
        if _needs_the_whole_machine(item):
            item.add_marker(pytest.mark.whole_machine)
