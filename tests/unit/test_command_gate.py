"""Clamping, NaN rejection, the dead-man timeout and arming live in the command gate."""

import logging
import math

import pytest

from quadsim.control.gate import CommandGate
from quadsim.core.types import Twist, ZMode


@pytest.fixture
def gate(vehicle):
    return CommandGate(vehicle.limits, ZMode.VELOCITY, timeout_steps=120)


def test_not_armed_before_first_command(gate):
    active = gate.active(0)
    assert not active.armed and active.twist == Twist()


def test_clamps_to_vehicle_limits(gate, vehicle):
    lim = vehicle.limits
    got = gate.receive(Twist(linear_x=30.0, linear_y=40.0, linear_z=9.0, angular_z=-9.0), 0)
    assert math.hypot(got.linear_x, got.linear_y) == pytest.approx(lim.max_horizontal_speed_mps)
    assert got.linear_x / got.linear_y == pytest.approx(0.75)  # direction kept
    assert got.linear_z == lim.max_climb_rate_mps and got.angular_z == -lim.max_yaw_rate_radps
    assert gate.receive(Twist(linear_z=-9.0), 1).linear_z == -lim.max_descent_rate_mps


def test_height_mode_clamps_altitude(vehicle):
    gate = CommandGate(vehicle.limits, ZMode.HEIGHT, timeout_steps=None)
    # down to the ground, not to min_altitude_m: an altitude below that lands (control/landing.py)
    assert 2.0 + gate.receive(Twist(linear_z=-5.0), 0).linear_z == pytest.approx(0.0)
    assert 2.0 + gate.receive(Twist(linear_z=1e6), 0).linear_z == pytest.approx(vehicle.limits.max_altitude_m)


def test_nan_rejected_last_good_stands_warned_once(gate, caplog):
    gate.receive(Twist(linear_x=1.0), 0)
    with caplog.at_level(logging.WARNING):
        assert gate.receive(Twist(linear_x=math.nan), 5) is None
        assert gate.receive(Twist(angular_z=math.inf), 6) is None
    assert gate.active(7).twist.linear_x == 1.0
    assert gate.rejected_count == 2
    assert len([r for r in caplog.records if "NaN" in r.message]) == 1


def test_dead_man_timeout_holds(gate):
    gate.receive(Twist(linear_x=1.0), 100)
    assert not gate.active(220).hold  # 120 steps later: still fresh
    assert gate.active(221).hold  # past the timeout: hold
    gate.receive(Twist(linear_x=1.0), 230)
    assert not gate.active(231).hold


def test_timeout_can_be_disabled(vehicle):
    gate = CommandGate(vehicle.limits, ZMode.VELOCITY, timeout_steps=None)
    gate.receive(Twist(linear_x=1.0), 0)
    assert not gate.active(10**6).hold
