"""A fleet: several vehicles in one world on one clock (quadsim.sim.fleet)."""

from __future__ import annotations

import math
import re

import pytest

from quadsim import Fleet, FleetVehicle, SimConfig, Simulator, StartPose, ZMode
from quadsim.drivers.scripted import ScriptedDriver, load_script
from quadsim.errors import ConfigError, QuadsimError
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
