"""How a parallel run (`pytest -n N`, as `make test` runs) hands tests to its workers: one unit at
a time, in the order tests/conftest.py sorts them (the longest first, so that no long test starts
last while the other workers have run out of work). A unit is one test, or every test of a file
that shares a setup made once for the file (a module-scoped fixture: the signal trials, the
damaged corpus, the installed wheel), so that the setup is made once, on one worker.

pytest-xdist's own `--dist loadgroup` would group tests from `xdist_group` marks, but with pytest
9.2 it silently stops grouping (pytest-dev/pytest-xdist#1386), and its plain `load` hands each
worker a quarter of the suite at once: the end-to-end tests, first in the collection, all went to
one worker, which ran ten minutes after the other had finished."""

from __future__ import annotations

from typing import Any

from xdist.scheduler import LoadScopeScheduling

#: the files (under tests/) whose tests share a setup made once for the file, and which of their
#: tests share it: "file" all of them, "param" those of one parameter (a parametrised fixture).
#: tests/unit/test_suite_rules.py checks that every file with a module- or class-scoped fixture of
#: its own is here.
SHARED_SETUP = {
    "e2e/test_check_parallel.py": "file",
    "e2e/test_damaged_corpus.py": "file",
    "e2e/test_foxglove_layout.py": "file",
    "e2e/test_killed_camera_run.py": "file",
    "e2e/test_ros2.py": "param",
    "e2e/test_signals.py": "file",
    "e2e/test_wheel.py": "file",
    "integration/test_contact.py": "file",
    "integration/test_damaged_files.py": "file",
    "integration/test_depth_images.py": "file",
    "integration/test_fanout.py": "file",
    "integration/test_ranging.py": "file",
    "integration/test_recording.py": "file",
    "integration/test_replay.py": "file",
    "integration/test_run_description.py": "file",
    "unit/test_crazyflie.py": "file",
    "unit/test_flight_quality.py": "file",
    "unit/test_hexa.py": "file",
    "unit/test_ranging.py": "file",
}


def unit_of(nodeid: str) -> str:
    """The unit a test is handed out in: its file (or its file and parameter) where it shares a
    setup with the file's other tests, else itself."""
    path, _, rest = nodeid.partition("::")
    how = SHARED_SETUP.get(path.removeprefix("tests/"))
    if how == "file":
        return path
    if how == "param" and rest.endswith("]") and "[" in rest:
        return f"{path}[{rest.split('[', 1)[1]}"
    return nodeid


class SharedSetupScheduling(LoadScopeScheduling):
    """xdist's scope scheduling with `unit_of` for scopes and the collection's own order (its
    default reorders the units by size)."""

    def __init__(self, config: Any, log: Any = None) -> None:
        super().__init__(config, log)
        config.option.loadscopereorder = False

    def _split_scope(self, nodeid: str) -> str:
        return unit_of(nodeid)
