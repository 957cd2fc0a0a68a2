"""Landing and the landed state, the altitude limits in both z-modes, and angular.z as the heading
rate, for both controllers (the landing layer is shared)."""

import math

import pytest

from quadsim import ControllerKind, SimConfig, Simulator, Twist, ZMode
from quadsim.apps.flight_quality import banked_turn_metrics, touchdown_metrics
from quadsim.control.landing import FlightPhase, LandingSettings
from quadsim.sim.flight_events import EventKind
from quadsim.sim.loop import StateLog

REST_Z_M = 0.051  # base_link's height resting on the floor


@pytest.fixture(params=list(ControllerKind), ids=lambda c: c.value)
def controller(request):
    return request.param


def _tilt_deg(state) -> float:
    x, y, _, _ = state.orientation_xyzw
    return math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y)))))


def test_a_full_rate_descent_touches_down_gently_and_idles(controller):
    m = touchdown_metrics(controller)
    assert m["touchdown_speed_mps"] <= 0.5, m
    assert m["landed"] == 1.0 and m["final_z_m"] == pytest.approx(REST_Z_M, abs=0.005)


def test_a_hard_landing_is_not_slowed():
    with Simulator(SimConfig(z_mode=ZMode.VELOCITY), landing=LandingSettings(hard_landing=True)) as sim:
        sim.send(Twist(linear_z=1.0))
        sim.run_for(2.5)
        sim.send(Twist(linear_z=-1.5))
        sim.run_for(5.0)
        (touchdown,) = [e for e in sim.events if e.kind is EventKind.TOUCHDOWN]
        assert touchdown.speed_mps > 1.2
        assert sim.describe()["controller"]["landing"]["hard_landing"] is True  # recorded


def test_landed_with_no_climb_wanted_rotors_idle_and_it_does_not_skim(controller):
    # armed by a forward command on the ground: no climb wanted, so it stays landed, rotors idle
    with Simulator(SimConfig(controller=controller, z_mode=ZMode.VELOCITY)) as sim:
        sim.send(Twist(linear_x=1.5))
        log = StateLog()
        sim.add_sink(log)
        sim.run_for(3.0)
        assert sim.phase is FlightPhase.LANDED
        assert max(math.hypot(*s.position_m[:2]) for s in log.states) < 0.005
        assert max(_tilt_deg(s) for s in log.states) < 0.5
        assert max(max(s.rotor_thrusts_n) for s in log.states) < 1e-6
        assert sim.events == []


def test_height_mode_lands_at_the_ground_and_takes_off_again(controller):
    with Simulator(SimConfig(controller=controller, z_mode=ZMode.HEIGHT)) as sim:
        sim.send(Twist())  # 2 m
        sim.run_for(5.0)
        assert sim.state.position_m[2] == pytest.approx(2.0, abs=0.1)
        sim.send(Twist(linear_z=-2.0))  # the ground (below min_altitude_m, 0.3 m, which blocked it)
        sim.run_for(8.0)
        assert sim.phase is FlightPhase.LANDED and sim.state.position_m[2] == pytest.approx(REST_Z_M, abs=0.005)
        assert max(sim.state.rotor_thrusts_n) < 1e-3
        sim.send(Twist(linear_z=-1.0))  # 1 m: take off again
        sim.run_for(5.0)
        assert sim.phase is FlightPhase.FLYING and sim.state.position_m[2] == pytest.approx(1.0, abs=0.1)
        kinds = [e.kind for e in sim.events]
        assert kinds == [EventKind.TAKEOFF, EventKind.TOUCHDOWN, EventKind.LANDED, EventKind.TAKEOFF]
        touchdown = sim.events[1]
        assert touchdown.hit == "floor" and touchdown.speed_mps <= 0.5


def test_below_the_minimum_altitude_no_altitude_is_held(controller):
    # velocity z-mode: a short hop to 0.2 m, then no command: it goes down and lands
    with Simulator(SimConfig(controller=controller, z_mode=ZMode.VELOCITY)) as sim:
        sim.send(Twist(linear_z=0.5))
        sim.run_for(0.4)
        assert sim.state.position_m[2] > 0.12
        sim.send(Twist())
        sim.run_for(4.0)
        assert sim.phase is FlightPhase.LANDED and sim.state.position_m[2] == pytest.approx(REST_Z_M, abs=0.005)


def test_velocity_mode_stops_at_the_maximum_altitude(controller):
    with Simulator(SimConfig(controller=controller, z_mode=ZMode.VELOCITY)) as sim:
        limit = sim.vehicle.limits.max_altitude_m
        sim.send(Twist(linear_z=sim.vehicle.limits.max_climb_rate_mps))
        log = StateLog()
        sim.add_sink(log)
        sim.run_for(limit / 2.5 + 10.0)
        top = max(s.position_m[2] for s in log.states)
        assert limit - 0.5 < top <= limit + 0.1, top
        assert sim.state.position_m[2] == pytest.approx(limit, abs=0.3)


def test_angular_z_is_the_heading_rate_in_a_banked_turn(controller):
    # 3 m/s with 1.5 rad/s: banked ~25 degrees; the body yaw rate tracked instead turned the
    # heading 15.6 % too fast (the cascade before this change)
    m = banked_turn_metrics(controller)
    assert m["bank_deg"] > 15.0
    assert m["heading_rate_error_pct"] < 2.0, m
