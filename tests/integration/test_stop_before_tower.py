"""The LiDAR example (examples/stop_before_tower.py, docs/autonomy.md): flown at the red tower, it
stops 1 m before it seeing it with the 2D scan alone, and never touches it."""

from __future__ import annotations

import math
import runpy

import numpy as np
import pytest

from quadsim.assets import asset_path
from quadsim.physics.world_spec import load_world
from tests.helpers import ROOT

EXAMPLE = runpy.run_path(str(ROOT / "examples" / "stop_before_tower.py"))
TOWER = next(lm for lm in load_world(asset_path("worlds", "default.toml")).landmarks if lm.name == "red_tower")


@pytest.mark.parametrize(("start_yaw_deg", "cruise_mps"), [(0.0, 1.0), (5.0, 2.0)])
def test_it_stops_one_metre_before_the_tower(start_yaw_deg: float, cruise_mps: float) -> None:
    flight = EXAMPLE["stop_before_tower"](math.radians(start_yaw_deg), cruise_mps)
    assert flight.stopped and not flight.crashed, flight
    x, y, _ = flight.final.position_m
    face_x = TOWER.position_m[0] - TOWER.size_m[0] / 2  # the face it flies at
    along = (face_x - x) / math.cos(math.radians(start_yaw_deg))  # from the vehicle along its heading
    assert abs(along - 1.0) < 0.15, (x, y, along)
    assert math.hypot(*flight.final.linear_velocity_mps) < 0.1


def test_the_sector_ahead_takes_the_nearest_return_and_reads_rep_117() -> None:
    nearest = EXAMPLE["nearest_ahead"]
    ranges = np.full(360, np.inf, np.float32)
    assert nearest(ranges) == math.inf  # nothing ahead
    ranges[180] = 3.0  # straight ahead (the beams start behind, at -pi)
    ranges[175] = 2.5  # 5 deg to the right: within the sector
    ranges[120] = 0.5  # 60 deg to the right: not ahead
    assert nearest(ranges) == 2.5
    ranges[181] = -np.inf  # something nearer than the minimum range, ahead
    assert nearest(ranges) == 0.0
