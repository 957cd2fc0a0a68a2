"""A fleet: several vehicles in one world on one clock (quadsim.sim.fleet)."""

from __future__ import annotations

import math
import re

import pytest

from quadsim import Fleet, FleetVehicle, SimConfig, Simulator, StartPose, Twist, ZMode
from quadsim.drivers.scripted import ScriptedDriver, load_script
from quadsim.errors import ConfigError, QuadsimError
from quadsim.sim.flight_events import EventKind
from tests.helpers import ROOT

HEIGHT = SimConfig(z_mode=ZMode.HEIGHT)


def _alone(script: str | None, start: StartPose, seconds: float):
    driver = ScriptedDriver(load_script(script)) if script else None
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT, start=start), driver) as sim:
        sim.run_for(seconds)
        return sim.state, [e.kind for e in sim.events]


def test_each_vehicle_flies_as_it_would_alone_on_one_clock():
    """A square, a yaw turn and an idle vehicle, in one world: each ends where it ends when it
    flies alone (to the bit: PyBullet solves bodies apart that do not touch), all on one clock."""
    plan = {
        "alpha": ("square", StartPose()),
        "bravo": ("yaw", StartPose(0.0, -4.0)),
        "charlie": (None, StartPose(-3.0, 2.0)),
    }
    vehicles = [
        FleetVehicle(name, start=start, driver=ScriptedDriver(load_script(script)) if script else None)
        for name, (script, start) in plan.items()
    ]
    with Fleet(vehicles, HEIGHT) as fleet:
        fleet.run_for(20.0)
        assert fleet.step_count == 4800 and fleet.time_s == 20.0
        assert [fleet[n].step_count for n in fleet] == [4800] * 3
        flown = {n: (fleet[n].state, [e.kind for e in fleet[n].events]) for n in fleet}
    for name, (script, start) in plan.items():
        state, kinds = _alone(script, start, 20.0)
        assert flown[name][0].position_m == state.position_m, name
        assert flown[name][0].orientation_xyzw == state.orientation_xyzw, name
        assert flown[name][1] == kinds, name
    alpha, bravo, charlie = (flown[n][0] for n in ("alpha", "bravo", "charlie"))
    assert math.dist(alpha.position_m[:2], (0.0, 3.0)) < 0.2  # the square's third corner at 20 s
    assert abs(math.remainder(bravo.yaw_rad() - 6.0, 2 * math.pi)) < 0.1  # turned 6 rad
    assert charlie.position_m[2] < 0.1  # idle: never took off


def _ramming_pair(reset_on_crash: bool = False) -> Fleet:
    """alpha and bravo 3 m apart, climbed to 1.5 m; alpha then flies at bravo at 3 m/s."""
    fleet = Fleet(
        [FleetVehicle("alpha"), FleetVehicle("bravo", start=StartPose(3.0, 0.0))],
        SimConfig(z_mode=ZMode.VELOCITY),
        reset_on_crash=reset_on_crash,
    )
    for name in fleet:
        fleet[name].send(Twist(linear_z=1.0))
    fleet.run_for(1.5)
    for name in fleet:
        fleet[name].send(Twist())
    fleet["alpha"].send(Twist(linear_x=3.0))
    return fleet


def test_vehicles_that_fly_into_each_other_both_crash_naming_the_other():
    with _ramming_pair() as fleet:
        fleet.run_for(2.0)
        crashes = {n: [e for e in fleet[n].events if e.kind is EventKind.CRASH] for n in fleet}
    assert crashes["alpha"] and crashes["alpha"][0].hit == "bravo", crashes
    assert crashes["bravo"] and crashes["bravo"][0].hit == "alpha", crashes
    assert crashes["alpha"][0].step == crashes["bravo"][0].step
    assert "hit bravo" in crashes["alpha"][0].value and "hit alpha" in crashes["bravo"][0].value


def test_with_reset_on_crash_vehicles_that_collide_both_crash_and_both_go_back():
    """The first vehicle's reset moves it away within the step: the second still has the
    step's contact with it (it was left uncrashed and hit again)."""
    with _ramming_pair(reset_on_crash=True) as fleet:
        fleet.run_for(2.0)
        kinds = {
            n: [(e.kind, e.step) for e in fleet[n].events if e.kind in (EventKind.CRASH, EventKind.RESET)]
            for n in fleet
        }
    crash = kinds["alpha"][0][1]
    assert kinds["alpha"][:2] == [(EventKind.CRASH, crash), (EventKind.RESET, crash)], kinds
    assert kinds["bravo"][:2] == [(EventKind.CRASH, crash), (EventKind.RESET, crash)], kinds


def test_the_contacts_asked_once_a_step_for_the_world_are_each_vehicles_own():
    """A fleet asks PyBullet for the world's contacts once a step and hands each vehicle its
    own: the same points, with the normal turned to point at it, as asking for each vehicle."""
    from quadsim.physics.pybullet_quiet import pb

    seen = {"floor": 0, "other vehicle": 0}
    with _ramming_pair() as fleet:  # into bravo, then both down to the floor
        bodies = {fleet[n].physics.body_id: n for n in fleet}
        cid = fleet.client.cid
        for _ in range(3 * 240):
            fleet.step()
            for body in bodies:
                asked = [(p[2], p[7][2]) for p in pb.getContactPoints(body, physicsClientId=cid)]
                assert list(fleet.client.touching(body)) == asked
                for other, _ in asked:
                    seen["other vehicle" if other in bodies else "floor"] += 1
    assert seen["floor"] > 0 and seen["other vehicle"] > 0, seen  # both kinds were compared


def test_only_the_fleet_steps_its_vehicles_and_a_reset_flies_again_the_same():
    vehicles = [
        FleetVehicle("alpha", driver=ScriptedDriver(load_script("step_forward"))),
        FleetVehicle("bravo", start=StartPose(0.0, 3.0)),
    ]
    with Fleet(vehicles, HEIGHT) as fleet:
        with pytest.raises(QuadsimError, match=r"alpha flies in a fleet.*step the fleet"):
            fleet["alpha"].step()
        fleet.run_for(5.0)
        first = fleet["alpha"].state
        fleet.reset()
        assert fleet.step_count == 0 and fleet["alpha"].state.position_m[2] < 0.1
        fleet.run_for(5.0)
        assert fleet["alpha"].state.position_m == first.position_m
        with pytest.raises(KeyError, match=r"no vehicle named 'zulu'.*alpha, bravo"):
            fleet["zulu"]


@pytest.mark.parametrize(
    "vehicles, error",
    [
        ([], "at least one vehicle"),
        ([FleetVehicle("alpha"), FleetVehicle("alpha", start=StartPose(3.0, 0.0))], "two vehicles are named 'alpha'"),
        ([FleetVehicle("Alpha")], "vehicle name 'Alpha': a ROS name segment"),
        ([FleetVehicle("a/b")], "vehicle name 'a/b'"),
        (
            [FleetVehicle("alpha"), FleetVehicle("bravo", start=StartPose(0.2, 0.0))],
            "'alpha' and 'bravo' start 0.20 m apart",
        ),
    ],
)
def test_a_bad_fleet_is_one_line_naming_the_vehicle(vehicles, error):
    with pytest.raises(ConfigError, match=error):
        Fleet(vehicles)


def test_the_docs_fleet_example_runs_and_does_what_it_says(capsys):

    page = (ROOT / "docs" / "reference" / "api.md").read_text()
    example = page.split("## Fleets", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    exec(compile(example, "api.md", "exec"), {})
    numbers = [float(v) for v in re.findall(r"-?\d+\.\d+(?:e-?\d+)?", capsys.readouterr().out)]
    time_s, alpha, bravo = numbers[0], numbers[1:4], numbers[4:7]
    assert time_s == 2.0
    assert 1.0 < alpha[2] < 2.5 and bravo[2] < 0.1  # alpha climbed at 1 m/s; bravo stayed on the ground


def test_a_start_on_a_landmark_is_refused_and_leaves_no_world_behind():
    """A start pose on the red tower's spot (the vehicle would start inside it) is one line
    naming the landmark, for one vehicle and in a fleet; no PyBullet client is left open."""
    import pybullet as pb

    def open_clients() -> int:
        return sum(pb.getConnectionInfo(cid)["isConnected"] for cid in range(64))

    before = open_clients()
    with pytest.raises(ConfigError, match=r"start pose \(6, 0\) is on the red_tower landmark's spot"):
        Simulator(SimConfig(start=StartPose(6.0, 0.0)))
    with pytest.raises(ConfigError, match=r"bravo: the start pose \(5.5, 0.3\) is on the red_tower"):
        Fleet([FleetVehicle("alpha"), FleetVehicle("bravo", start=StartPose(5.5, 0.3))])
    assert open_clients() == before
    with Simulator(SimConfig(start=StartPose(5.0, 0.0))) as sim:  # beside it: fine
        assert sim.state.position_m[0] == pytest.approx(5.0, abs=1e-6)
