"""A second airframe: the shipped hexacopter flies with the cascade controller and re-flies exactly."""

import math

import pytest

from quadsim import ConfigError, SimConfig, Simulator, Twist, ZMode
from quadsim.apps.flight_quality import SCENARIO_METRICS, TARGETS, fly
from quadsim.control import ControllerKind
from quadsim.recording.flight import load_flight
from quadsim.session.outputs import OutputOptions, RecordedRun
from quadsim.session.resim import resimulate
from quadsim.vehicle.mixer import Mixer
from quadsim.vehicle.params import SHIPPED_VEHICLES, Spin, load_vehicle

HEXA = SHIPPED_VEHICLES["hexa"]


@pytest.fixture(scope="module")
def hexa():
    return load_vehicle(HEXA)


def test_six_rotors_on_arms_around_the_body_with_alternating_spins(hexa):
    assert [r.link_name for r in hexa.rotors] == [f"rotor_{i}" for i in range(1, 7)]
    assert [r.spin for r in hexa.rotors] == [Spin.CCW, Spin.CW] * 3
    # numbered counter-clockwise seen from above, every 60 degrees from 30 degrees left of the nose
    bearings = [math.degrees(math.atan2(r.position_m[1], r.position_m[0] + hexa.com_m[0])) for r in hexa.rotors]
    assert bearings == pytest.approx([30, 90, 150, -150, -90, -30], abs=0.01)
    assert all(
        math.hypot(r.position_m[0] + hexa.com_m[0], r.position_m[1]) == pytest.approx(0.17, abs=1e-5)
        for r in hexa.rotors
    )
    # base 0.9 + six rotors 0.025 + two cameras 0.005
    assert hexa.mass_kg == pytest.approx(1.06)
    assert hexa.rotor_count == 6


def test_hexa_mixer_shares_a_wrench_among_six_rotors(hexa):
    mixer = Mixer(hexa)
    assert mixer.allocation.shape == (4, 6)
    wrench = (11.0, 0.04, -0.03, 0.01)
    assert mixer.to_wrench(mixer.to_rotor_forces(*wrench)) == pytest.approx(wrench, abs=1e-9)
    hover = mixer.to_rotor_forces(hexa.weight_n, 0.0, 0.0, 0.0)
    assert len(hover) == 6 and sum(hover) == pytest.approx(hexa.weight_n)
    # the front camera on its boom puts the CoM 1 mm ahead of the rotor centre: the front rotors carry more
    assert max(hover) - min(hover) < 0.03 * hexa.hover_thrust_per_rotor_n
    f = mixer.to_rotor_forces(hexa.weight_n, 0.0, 0.0, 0.05)  # +yaw: the CW (even) rotors speed up
    assert min(f[1], f[3], f[5]) > max(f[0], f[2], f[4])
    # near full thrust a big yaw demand does not fit: roll is kept, yaw is reduced
    top = hexa.max_thrust_n
    forces = mixer.to_rotor_forces(0.9 * 6 * top, 0.05, 0.0, 1.0)
    got = mixer.to_wrench(forces)
    assert got[1] == pytest.approx(0.05, rel=1e-6) and 0.0 < got[3] < 1.0
    assert all(0.0 <= v <= top for v in forces)


def test_seed_controller_refuses_the_hexa():
    with pytest.raises(ConfigError, match=r"seed controller flies only the original quadrotor layout.*6 rotors"):
        Simulator(SimConfig(urdf=HEXA, controller=ControllerKind.SEED))


def test_hexa_hovers_on_its_weight(hexa):
    with Simulator(SimConfig(urdf=HEXA, z_mode=ZMode.HEIGHT)) as sim:
        assert sim.state.rotor_thrusts_n == (0.0,) * 6
        sim.send(Twist())
        state = sim.run_for(6.0)
        assert state.position_m[2] == pytest.approx(2.0, abs=0.01)
        assert len(state.rotor_thrusts_n) == 6
        assert sum(state.rotor_thrusts_n) == pytest.approx(hexa.weight_n, rel=0.005)


@pytest.mark.parametrize("metric,bound", [(m, b) for s, m, b in TARGETS if s == "square"])
def test_hexa_flies_the_square_within_the_quads_targets(metric, bound):
    value = SCENARIO_METRICS["square"](fly("square", config=SimConfig(urdf=HEXA)))[metric]
    assert value < bound, f"hexa square: {metric} = {value:.4f}, target < {bound}"


def test_hexa_recording_reflies_to_zero(tmp_path):
    with Simulator(SimConfig(urdf=HEXA, z_mode=ZMode.HEIGHT)) as sim:
        with RecordedRun(sim, OutputOptions(out=tmp_path / "hexa.mcap", cameras=()), "hexa") as run:
            sim.send(Twist())
            sim.run_for(3.0)
            sim.send(Twist(linear_x=1.0, angular_z=0.5))
            sim.run_for(2.0)
    flight = load_flight(run.path)
    assert flight.description is not None and flight.description.vehicle.name == "quadsim_hexa"
    assert flight.description.vehicle.rotor_count == 6
    assert {"quadsim_hexa.urdf", "quadsim_hexa.params.toml"} <= set(flight.attachments)
    assert all(len(s.rotor_thrusts_n) == 6 for s in flight.states)
    report = resimulate(flight, record=False)
    assert report.position.max_error == 0.0 and report.attitude.max_error == 0.0
