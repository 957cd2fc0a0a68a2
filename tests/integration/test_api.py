"""The API autonomy code uses: create a sim, send a Twist, step, read the state."""

import pytest

from quadsim import QuadsimError, SimConfig, Simulator, Twist, ZMode
from quadsim.drivers.scripted import ScriptedDriver, load_script


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
    import gc

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
