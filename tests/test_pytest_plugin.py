"""The quadsim pytest plugin, in pytest runs of their own (pytester): recordings under the
configured folder are test items that pass while they re-fly, fail with a readable divergence
report once the vehicle changed, can be selected and reported like any test, and nothing is
collected where a project did not ask for it."""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from tests.helpers import RECORDINGS
from tests.test_replay import _with_changed_attachment

pytest_plugins = ["pytester"]

SQUARE = RECORDINGS / "square_cascade.mcap"
CLIMB = RECORDINGS / "climb_cascade.mcap"


def _project(pytester: pytest.Pytester, ini: str = 'quadsim_recordings = ["flights"]') -> Path:
    pytester.makepyprojecttoml(f"[tool.pytest.ini_options]\n{ini}\n")
    flights = pytester.path / "flights"
    flights.mkdir()
    return flights


def test_recordings_pass_fail_readably_and_report_as_junit(pytester: pytest.Pytester) -> None:
    flights = _project(pytester)
    shutil.copy(SQUARE, flights / "square.mcap")
    shutil.copy(CLIMB, flights / "climb.mcap")
    _with_changed_attachment(  # the same flight with stronger rotor drag: it no longer re-flies
        SQUARE,
        flights / "heavier_drag.mcap",
        "quadsim_x.params.toml",
        lambda d: d.replace(b"rotor_drag_ns_per_m_rad = 1.7e-4", b"rotor_drag_ns_per_m_rad = 4.0e-4"),
    )
    result = pytester.runpytest("--junitxml=report.xml", "-rf")
    result.assert_outcomes(passed=2, failed=1)
    verdict = "heavier_drag.mcap no longer re-flies within 0.001 m and 0.001 rad: position off by up to * m, "
    result.stdout.fnmatch_lines(
        [
            f"{verdict}attitude by up to * rad",
            "*/quad/pose position: max * m at t=*, first beyond tolerance at t=*",
            "FAILED flights/heavier_drag.mcap::heavier_drag - heavier_drag.mcap no longer*",  # no dangling colon
        ]
    )
    junit = ET.parse(pytester.path / "report.xml").getroot()
    cases = {case.get("name"): case for case in junit.iter("testcase")}
    assert set(cases) == {"square", "climb", "heavier_drag"}
    assert cases["heavier_drag"].find("failure") is not None and cases["square"].find("failure") is None

    # the usual selection: -k, and a file named on the command line
    pytester.runpytest("-k", "climb").assert_outcomes(passed=1)
    pytester.runpytest("flights/square.mcap").assert_outcomes(passed=1)
    # a looser tolerance, from the command line, lets the changed vehicle pass
    pytester.runpytest(
        "-k", "heavier", "--quadsim-tolerance-m", "100", "--quadsim-tolerance-rad", "10"
    ).assert_outcomes(passed=1)


def test_an_unusable_recording_fails_saying_why(pytester: pytest.Pytester) -> None:
    flights = _project(pytester)
    data = SQUARE.read_bytes()
    (flights / "cut.mcap").write_bytes(data[: len(data) // 3])
    result = pytester.runpytest()
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["cut.mcap cannot be re-flown: *"])
    assert "ERROR" not in result.stdout.str().split("short test summary")[0].split("FAILURES")[-1].splitlines()[2]


def test_nothing_is_collected_where_a_project_did_not_ask(pytester: pytest.Pytester) -> None:
    pytester.makepyprojecttoml("[tool.pytest.ini_options]\n")
    shutil.copy(SQUARE, pytester.path / "square.mcap")
    result = pytester.runpytest()
    assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED
    pytester.runpytest("square.mcap").assert_outcomes(passed=1)  # unless named


def test_recordings_run_on_xdist_workers(pytester: pytest.Pytester) -> None:
    flights = _project(pytester)
    shutil.copy(SQUARE, flights / "square.mcap")
    shutil.copy(CLIMB, flights / "climb.mcap")
    pytester.runpytest_subprocess("-n", "2", "-p", "xdist").assert_outcomes(passed=2)


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
