"""The quadsim pytest plugin, in pytest runs of their own (pytester).

Its integration tests (several layers, in-process or one process started); the others are in tests/unit/test_pytest_plugin.py."""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET

import pytest

from tests.e2e.test_replay import _with_changed_attachment
from tests.unit.test_pytest_plugin import CLIMB, SQUARE, _project


def test_recordings_run_on_xdist_workers(pytester: pytest.Pytester) -> None:
    flights = _project(pytester)
    shutil.copy(SQUARE, flights / "square.mcap")
    shutil.copy(CLIMB, flights / "climb.mcap")
    pytester.runpytest_subprocess("-n", "2", "-p", "xdist").assert_outcomes(passed=2)


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


def test_nothing_is_collected_where_a_project_did_not_ask(pytester: pytest.Pytester) -> None:
    pytester.makepyprojecttoml("[tool.pytest.ini_options]\n")
    shutil.copy(SQUARE, pytester.path / "square.mcap")
    result = pytester.runpytest()
    assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED
    pytester.runpytest("square.mcap").assert_outcomes(passed=1)  # unless named
