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
