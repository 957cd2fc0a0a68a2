"""Every input path flies every Twist field.

Its integration tests (several layers, in-process or one process started); the others are in tests/e2e/test_twist_matrix.py."""

from __future__ import annotations

from pathlib import Path

import pytest

from quadsim import SimConfig, Simulator, Twist, ZMode, record
from tests.e2e.test_twist_matrix import PAUSE_S, SEGMENT_S, judge


def test_the_judge_sees_a_field_in_its_neighbours_place(tmp_path: Path) -> None:
    """The bug this matrix exists for: yaw rate sent, angular_x recorded and nothing turned."""
    out = tmp_path / "flight.mcap"
    with Simulator(SimConfig()) as sim, record(sim, out):
        sim.send(Twist(angular_x=-0.8))
        sim.run_for(SEGMENT_S)
        sim.send(Twist())
        sim.run_for(PAUSE_S)
    with pytest.raises(AssertionError, match="angular_z was never commanded alone"):
        judge(out, {"angular_z": -0.8}, ZMode.VELOCITY)
