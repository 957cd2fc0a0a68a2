"""The API autonomy code uses: create a sim, send a Twist, step, read the state; a fleet of
vehicles in one world (quadsim.Fleet), made and refused as the API reference says."""

import gc
import re

import pytest

from quadsim import ConfigError, Fleet, FleetVehicle, QuadsimError, SimConfig, Simulator, StartPose, Twist, ZMode
from quadsim.drivers.scripted import ScriptedDriver, load_script
from tests.helpers import ROOT


def test_send_step_read():
    with Simulator(SimConfig()) as sim:
        sim.send(Twist(linear_z=1.0))
        state = sim.run_for(2.0)
        assert 1.0 < state.position_m[2] < 2.2
        sim.send(Twist(linear_x=0.5))
        state = sim.step(240)
        assert state.linear_velocity_mps[0] > 0.3
        assert sim.time_s == pytest.approx(3.0)
        info = sim.describe()
        assert info["controller"]["name"] == "cascade" and info["config"]["rates"]["physics_hz"] == 240


def test_stop_sending_means_hold():
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT)) as sim:
        sim.send(Twist(linear_x=1.0))
        sim.run_for(5.0)
        sim.driver.stop()
        state = sim.run_for(4.0)
        assert abs(state.linear_velocity_mps[0]) < 0.05


def test_send_refused_when_a_script_drives():
    with Simulator(SimConfig(), ScriptedDriver(load_script("hover"))) as sim:
        with pytest.raises(QuadsimError, match="programmatic"):
            sim.send(Twist())


def test_creating_simulators_in_a_loop_keeps_memory_flat():
    """PyBullet keeps a mesh given as arrays for the life of the process: 165 kB a simulator
    once. Measured as resident memory over the 10th to 40th simulator and the 40th to 70th."""

    def resident_kb() -> float:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * 4096 / 1024

    marks = []
    for i in range(70):
        with Simulator(SimConfig()) as sim:
            sim.step(1)
        if i in (9, 39, 69):
            gc.collect()
            marks.append(resident_kb())
    # a leak grows in both stretches of 30 simulators; the C allocator's heap grows by some 32 MB
    # once, somewhere (as it may in any process), which only one of them sees
    growth_kb = min(marks[1] - marks[0], marks[2] - marks[1])
    assert growth_kb < 1000, f"memory grew {growth_kb:.0f} kB over 30 simulators, twice: {marks}"


def test_step_and_run_for_refuse_what_is_not_a_time_ahead():
    """Negative or non-finite times were taken silently (or failed deep in the loop with NaN)."""
    import numpy as np

    from quadsim import Fleet, FleetVehicle, StartPose

    with Simulator(SimConfig()) as sim:
        sim.step(np.int64(3))
        sim.run_for(np.float32(0.1))
        assert sim.step_count == 3 + 24
        for bad in (-5, 1.5, True):
            with pytest.raises(ValueError, match="steps must be a whole number of physics steps, 0 or more"):
                sim.step(bad)
        for bad_s in (-1.0, float("nan"), float("inf")):
            with pytest.raises(ValueError, match="seconds must be a finite number, 0 or more"):
                sim.run_for(bad_s)
        assert sim.step_count == 27
    with Fleet([FleetVehicle("a"), FleetVehicle("b", start=StartPose(x_m=3.0))]) as fleet:
        with pytest.raises(ValueError, match="seconds must be"):
            fleet.run_for(float("nan"))
        with pytest.raises(ValueError, match="steps must be"):
            fleet.step(-1)
        assert fleet.step_count == 0


def test_a_config_takes_the_names_the_command_line_takes_and_refuses_the_rest(tmp_path):
    """SimConfig(z_mode="height") flew in velocity mode (climbing at 1 m/s instead of holding 3 m),
    and recording it ended in AttributeError; controller="seed" did too."""
    from quadsim import ControllerKind, record

    config = SimConfig(z_mode="height", controller="Seed")
    assert config.z_mode is ZMode.HEIGHT and config.controller is ControllerKind.SEED
    with Simulator(SimConfig(z_mode="height")) as sim, record(sim, tmp_path / "h.mcap"):
        sim.send(Twist(linear_z=1.0))  # height mode: hold 2 m + 1 m
        sim.run_for(5.0)
        assert sim.state.position_m[2] == pytest.approx(3.0, abs=0.05)
    with Simulator(SimConfig()) as sim:  # and so does set_z_mode (a string was ignored: it flew on climbing)
        sim.set_z_mode("height")
        sim.send(Twist(linear_z=1.0))
        sim.run_for(5.0)
        assert sim.state.position_m[2] == pytest.approx(3.0, abs=0.05)
        for bad in ("bogus", 3, None):
            with pytest.raises(QuadsimError, match="z_mode must be one of"):
                sim.set_z_mode(bad)
    for bad, said in (
        ({"z_mode": "bogus"}, "z_mode must be one of 'velocity', 'height'"),
        ({"controller": 3}, "controller must be one of 'cascade', 'seed'"),
        ({"gui": 1}, "gui must be True or False"),
        ({"rates": None}, "rates must be a Rates"),
        ({"command_timeout_s": None, "start": (0, 0, 0)}, "start must be a StartPose"),  # None skipped the check
    ):
        with pytest.raises(QuadsimError, match=said):
            SimConfig(**bad)


# --- fleets -------------------------------------------------------------------------------------


def test_only_the_fleet_steps_its_vehicles_and_a_missing_one_is_named():
    """(A fleet's reset, as a vehicle's: tests/integration/test_loop.py.)"""
    vehicles = [FleetVehicle("alpha"), FleetVehicle("bravo", start=StartPose(0.0, 3.0))]
    with Fleet(vehicles, SimConfig(z_mode=ZMode.HEIGHT)) as fleet:
        with pytest.raises(QuadsimError, match=r"alpha flies in a fleet.*step the fleet"):
            fleet["alpha"].step()
        assert fleet.step_count == 0 and fleet["alpha"].step_count == 0
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


#: a run whose vehicle starts on the red tower's spot (it would start inside it), what it is told,
#: and the same run with that vehicle beside the tower (x = 5 m)
ON_THE_TOWER = {
    "alone": (
        lambda x, y: Simulator(SimConfig(start=StartPose(x, y))),
        (6.0, 0.0),
        r"start pose \(6, 0\) is on the red_tower landmark's spot",
    ),
    "fleet of 2": (
        lambda x, y: Fleet([FleetVehicle("alpha"), FleetVehicle("bravo", start=StartPose(x, y))]),
        (5.5, 0.3),
        r"bravo: the start pose \(5.5, 0.3\) is on the red_tower",
    ),
}


@pytest.mark.parametrize("shape", list(ON_THE_TOWER))
def test_a_start_on_a_landmark_is_refused_and_leaves_no_world_behind(shape):
    """A start pose on the red tower's spot is one line naming the landmark (in a fleet, and the
    vehicle); no PyBullet client is left open; beside the tower the vehicle starts there."""
    import pybullet as pb

    def open_clients() -> int:
        return sum(pb.getConnectionInfo(cid)["isConnected"] for cid in range(64))

    make, on_it, said = ON_THE_TOWER[shape]
    gc.collect()  # an env or simulator another test dropped unclosed lets go of its client when collected
    before = open_clients()
    with pytest.raises(ConfigError, match=said):
        make(*on_it)
    assert open_clients() == before
    with make(5.0, 0.0) as run:  # beside it: fine
        started = run if isinstance(run, Simulator) else run["bravo"]
        assert started.state.position_m[0] == pytest.approx(5.0, abs=1e-6)
