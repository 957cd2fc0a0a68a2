"""Goals flown through the command path (quadsim.drivers.goal): from Python, a live input's
goal topics and a script's goto lines; reached within 0.1 m and 5 deg and held; a Twist takes
over at once; recorded as the commands and events they are, and re-flown by `check`."""

from __future__ import annotations

import math

import pytest

from quadsim import Fleet, FleetVehicle, QuadsimError, SimConfig, Simulator, StartPose, Twist, ZMode, record
from quadsim.drivers.scripted import ScriptedDriver, parse_script
from quadsim.drivers.subscribed import SubscribedDriver
from quadsim.sim.flight_events import EventKind
from tests.helpers.cli import run_main
from tests.helpers.mcap import topic_messages


def _off(state, x: float, y: float, z: float, yaw_deg: float) -> tuple[float, float]:
    """How far from (x, y, z), in m, and from the heading, in deg."""
    px, py, pz = state.position_m
    turn = (math.degrees(state.yaw_rad()) - yaw_deg + 180.0) % 360.0 - 180.0
    return math.dist((px, py, pz), (x, y, z)), abs(turn)


def _kinds(events) -> list[str]:
    return [e.kind.value for e in events if e.kind in (EventKind.GOAL, EventKind.GOAL_REACHED)]


@pytest.mark.parametrize("z_mode", [ZMode.VELOCITY, ZMode.HEIGHT])
def test_fly_to_reaches_the_goal_from_the_ground_and_holds_there(z_mode: ZMode) -> None:
    with Simulator(SimConfig(z_mode=z_mode, start=StartPose(yaw_rad=math.radians(30.0)))) as sim:
        sim.fly_to(3.0, -2.0, 1.5, math.radians(-120))
        sim.run_for(8.0)
        reached = [e for e in sim.events if e.kind is EventKind.GOAL_REACHED]
        assert len(reached) == 1 and reached[0].value == "at x=3.00 y=-2.00 z=1.50 yaw=-120.0deg"
        assert _off(sim.state, 3.0, -2.0, 1.5, -120.0) < (0.1, 5.0)
        for _ in range(10):  # and holds there
            sim.run_for(1.0)
            assert _off(sim.state, 3.0, -2.0, 1.5, -120.0) < (0.1, 5.0)
        assert _kinds(sim.events) == ["goal", "goal_reached"]


def test_a_twist_takes_over_at_once_and_a_reset_forgets_the_goal() -> None:
    with Simulator(SimConfig()) as sim:
        sim.fly_to(5.0, 0.0, 1.0)
        sim.run_for(1.0)
        sim.send(Twist(linear_z=0.5))  # a climb, nothing forward: the goal's pull stops at once
        step = sim.step_count
        sim.run_for(2.0)
        dropped = sim.events[-1]
        assert dropped.kind is EventKind.GOAL and dropped.value == "dropped: programmatic published a Twist"
        assert dropped.step - step < sim.config.rates.physics_hz // sim.config.rates.input_hz + 1
        assert sim.state.position_m[0] < 3.0 and sim.state.position_m[2] > 1.5
        sim.fly_to(0.0, 0.0)  # z and heading left open: those it has
        sim.reset()
        sim.run_for(2.0)
        assert sim.state.position_m[2] < 0.2 and _kinds(sim.events) == []  # nothing flown after the reset
        with pytest.raises(ValueError, match="finite"):
            sim.fly_to(float("nan"), 0.0)


def test_a_2d_goal_keeps_the_altitude_flown_and_lifts_off_to_one_metre_from_the_ground() -> None:
    with Simulator(SimConfig()) as sim:
        sim.fly_to(1.0, 1.0)
        sim.run_for(6.0)
        assert _off(sim.state, 1.0, 1.0, 1.0, 0.0) < (0.1, 5.0)
        sim.send(Twist(linear_z=1.0))
        sim.run_for(1.5)
        altitude = sim.state.position_m[2]
        sim.fly_to(-1.0, 0.0)
        sim.run_for(6.0)
        assert abs(sim.state.position_m[2] - altitude) < 0.1 and abs(sim.state.position_m[0] + 1.0) < 0.1


def test_each_vehicle_of_a_fleet_flies_to_its_own_goal() -> None:
    with Fleet([FleetVehicle("a"), FleetVehicle("b", start=StartPose(x_m=3.0))]) as fleet:
        fleet["a"].fly_to(0.0, 2.0, 1.0, math.pi / 2)
        fleet["b"].fly_to(3.0, -2.0, 2.0, -math.pi / 2)
        fleet.run_for(8.0)
        assert _off(fleet["a"].state, 0.0, 2.0, 1.0, 90.0) < (0.1, 5.0)
        assert _off(fleet["b"].state, 3.0, -2.0, 2.0, -90.0) < (0.1, 5.0)


def test_a_live_input_flies_its_goal_until_its_next_twist() -> None:
    driver = SubscribedDriver("ros2")
    with Simulator(SimConfig(), driver) as sim:
        assert driver.deliver_goal("map", (2.0, 1.0, 1.2), (0.0, 0.0, 0.0, 1.0)) is None
        sim.run_for(7.0)
        assert _off(sim.state, 2.0, 1.0, 1.2, 0.0) < (0.1, 5.0)
        assert driver.deliver((0.0, 0.0, 0.0), 0.5)  # a node's Twist: turn on the spot
        sim.run_for(1.0)
        assert _kinds(sim.events) == ["goal", "goal_reached", "goal"] and "dropped" in sim.events[-1].value
        assert math.degrees(sim.state.yaw_rad()) > 10.0
        with pytest.raises(QuadsimError, match="needs the programmatic driver"):
            sim.fly_to(0.0, 0.0)


def test_a_recorded_goto_script_is_re_flown_identically(tmp_path) -> None:
    script = parse_script("4.0 goto x=1.5 y=0.5 z=1.2 yaw_deg=45\n1.0 linear.x=0.5\n", "goals")
    out = tmp_path / "goals.mcap"
    with Simulator(SimConfig(), ScriptedDriver(script)) as sim, record(sim, out):
        sim.run_for(script.duration_s)
    logs = [msg.msg for _, msg in topic_messages(out, "/rosout")]
    assert any(text.startswith("goal_reached: at x=1.50 y=0.50 z=1.20") for text in logs), logs
    commands = topic_messages(out, "/quad_cmd_twist")
    assert len(commands) == 100  # the pilot's at 20 Hz for 4 s, then the script's
    checked = run_main("check", out)
    assert checked.returncode == 0 and "flies again identically" in checked.stdout, checked.stdout + checked.stderr
