"""The quadsim pytest plugin, in pytest runs of their own (pytester): recordings under the
configured folder are test items that pass while they re-fly, fail with a readable divergence
report once the vehicle changed, can be selected and reported like any test, and nothing is
collected where a project did not ask for it."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tests.helpers import RECORDINGS

pytest_plugins = ["pytester"]

SQUARE = RECORDINGS / "square_cascade.mcap"
CLIMB = RECORDINGS / "climb_cascade.mcap"


def _project(pytester: pytest.Pytester, ini: str = 'quadsim_recordings = ["flights"]') -> Path:
    pytester.makepyprojecttoml(f"[tool.pytest.ini_options]\n{ini}\n")
    flights = pytester.path / "flights"
    flights.mkdir()
    return flights


def test_an_unusable_recording_fails_saying_why(pytester: pytest.Pytester) -> None:
    flights = _project(pytester)
    data = SQUARE.read_bytes()
    (flights / "cut.mcap").write_bytes(data[: len(data) // 3])
    result = pytester.runpytest()
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["cut.mcap cannot be re-flown: *"])
    assert "ERROR" not in result.stdout.str().split("short test summary")[0].split("FAILURES")[-1].splitlines()[2]


@pytest.mark.parametrize(
    ("ini", "args", "said"),
    [
        ('quadsim_recordings = ["flights"]\nquadsim_tolerance_m = "abc"', (), "quadsim_tolerance_m must be a number"),
        ('quadsim_recordings = ["flights"]', ("--quadsim-tolerance-m=-3",), "quadsim_tolerance_m (--quadsim"),
        ('quadsim_recordings = ["flightz"]', (), "flightz, which does not exist"),
    ],
)
def test_a_bad_setting_is_one_usage_error_before_anything_runs(
    pytester: pytest.Pytester, ini: str, args: tuple[str, ...], said: str
) -> None:
    """A bad tolerance failed every recording with some 1,250 lines of pytest internals; a misspelt
    folder collected nothing and said nothing."""
    flights = pytester.path / "flights"
    flights.mkdir()
    shutil.copy(SQUARE, flights / "square.mcap")
    pytester.makepyprojecttoml(f"[tool.pytest.ini_options]\n{ini}\n")
    result = pytester.runpytest(*args)
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    assert said in result.stderr.str() and "Traceback" not in result.stderr.str() + result.stdout.str()
    assert len(result.stderr.lines) <= 2, result.stderr.lines
