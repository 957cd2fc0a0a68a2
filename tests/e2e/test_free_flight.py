"""quadsim's own step of a vehicle clear of everything (quadsim.physics.free_flight) against
PyBullet's.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_free_flight.py."""

from __future__ import annotations

import pytest

from quadsim.core.types import Stepping
from quadsim.recording.flight import load_flights
from tests.integration.test_cli import cli


@pytest.mark.parametrize("physics", ["quadsim", "pybullet"])
def test_the_command_line_records_the_stepping_and_check_re_flies_it_at_zero(tmp_path, physics):
    """`run --physics X` records X (the default: quadsim); `check` re-flies the recording the way it
    was flown, at zero error; and a wrong value is refused in one line naming the choices."""
    out = tmp_path / "flight.mcap"
    extra = () if physics == "quadsim" else ("--physics", physics)
    done = cli("run", "--script", "takeoff", "--duration", "3", "--cameras", "none", *extra, "--out", str(out))
    assert done.returncode == 0, done.stderr
    (flight,) = load_flights(out).values()
    assert flight.description is not None and flight.description.config.physics is Stepping(physics)
    assert max(s.position_m[2] for s in flight.states) > 0.5  # it flew
    check = cli("check", str(out), "--tolerance-m", "0", "--tolerance-rad", "0")
    assert check.returncode == 0, check.stdout + check.stderr
    wrong = cli("run", "--script", "takeoff", "--physics", "bullet", "--no-record")
    assert wrong.returncode == 2 and "Traceback" not in wrong.stderr
    assert "invalid choice: 'bullet' (choose from 'quadsim', 'pybullet')" in wrong.stderr, wrong.stderr
