"""The flight-quality targets of the cascade, and the seed port flying the same scenarios."""

import math

import pytest

from quadsim.apps.flight_quality import SCENARIO_METRICS, TARGETS, envelope_metrics, fly
from quadsim.control import ControllerKind


@pytest.fixture(scope="module")
def cascade_results():
    return {name: SCENARIO_METRICS[name](fly(name)) for name in {s for s, _, _ in TARGETS}}


@pytest.mark.parametrize("scenario,metric,bound", TARGETS, ids=[f"{s}-{m}" for s, m, _ in TARGETS])
def test_cascade_meets_target(cascade_results, scenario, metric, bound):
    value = cascade_results[scenario][metric]
    assert value < bound, f"{scenario}: {metric} = {value:.4f}, target < {bound}"


def test_takeoff_trace_reaches_two_metres():
    flight = fly("takeoff")
    assert flight.at(0.0).position_m[2] < 0.1
    assert flight.at(3.0).position_m[2] == pytest.approx(2.0, abs=0.05)
    assert flight.states[-1].position_m[2] == pytest.approx(2.0, abs=0.01)


def test_step_response_is_in_heading_frame_and_does_not_cross_couple():
    flight = fly("step_forward")
    end = flight.at(10.0)
    assert end.position_m[0] > 4.0  # ~5 s at 1 m/s, minus the rise
    assert abs(end.position_m[1]) < 0.02 and abs(end.position_m[2] - 2.0) < 0.02


@pytest.mark.parametrize("scenario", ["takeoff", "hover", "step_forward", "step_left", "yaw", "square", "figure8"])
def test_seed_flies_without_diverging(scenario):
    flight = fly(scenario, ControllerKind.SEED)
    env = envelope_metrics(flight)
    assert env["max_tilt_deg"] < 25.0
    assert 1.5 < flight.states[-1].position_m[2] < 2.5
    assert env["max_z_m"] < 3.0
    final = flight.states[-1]
    assert all(math.isfinite(v) for v in final.position_m)
    assert math.hypot(*final.linear_velocity_mps) < 0.5  # settled, not flying off
    metrics = SCENARIO_METRICS[scenario](flight)
    if scenario.startswith("step"):
        assert metrics["rise_90_s"] < 2.0 and metrics["steady_error_pct"] < 15.0
    if scenario == "yaw":
        assert metrics["rate_error_max_pct"] < 10.0


def test_coordinated_turn_holds_speed_without_slipping():
    # the figure-8's circles: 1 m/s along the heading while yawing at 0.785 rad/s
    from quadsim.apps.flight_quality import turn_metrics

    m = turn_metrics(fly("figure8"))
    assert m["turn_slip_max_mps"] < 0.05, m
    assert m["turn_speed_error_max_pct"] < 10.0, m
    assert m["altitude_error_max_m"] < 0.02, m
