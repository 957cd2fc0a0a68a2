"""Aerodynamics: body drag (linear + quadratic) at the centre of mass, rotor drag proportional to
airspeed, Cheeseman-Bennett ground effect, measured through the physics."""

import math

import pytest

from quadsim import SimConfig, Simulator, Twist
from quadsim.apps.flight_quality import ground_effect_thrust_ratio, terminal_velocity_mps
from quadsim.core.types import StartPose, ZMode
from quadsim.physics.wind import WindSettings
from quadsim.vehicle import aero
from quadsim.vehicle.params import SHIPPED_VEHICLES, load_vehicle


def test_a_level_fall_with_motors_off_ends_at_the_speed_of_a_real_1kg_frame(vehicle):
    vt = terminal_velocity_mps()
    assert 13.0 < vt < 18.0  # issue 11: a ~1 kg frame falls at 13-18 m/s (was 49.5 m/s)
    # the physics reaches what the parameter file's drag says
    assert vt == pytest.approx(aero.terminal_velocity_mps(vehicle.aero, vehicle.mass_kg, 9.81), rel=2e-3)


def test_drag_acts_at_the_centre_of_mass_and_does_not_pitch_a_falling_vehicle(vehicle):
    # the CoM sits 1.8 mm above the base origin: drag there would pitch the vehicle in a side wind
    assert vehicle.com_m[2] > 1e-3
    with Simulator(SimConfig(wind=WindSettings(10.0, 90.0), sensor_noise=False)) as sim:
        sim.physics.place((0.0, 0.0, 2000.0))
        state = sim.run_for(8.0)
    roll, pitch = state.roll_pitch_rad()
    assert state.linear_velocity_mps[0] < -5.0  # carried along by the wind (toward -x: from the east)
    assert abs(roll) < 1e-6 and abs(pitch) < 1e-6
    assert max(abs(w) for w in state.angular_velocity_body_rps) < 1e-6


def test_rotor_drag_grows_in_proportion_to_airspeed_and_rotor_speed(vehicle):
    params = vehicle.aero
    in_plane, axial = params.rotor_drag_ns_per_m_rad, params.rotor_axial_drag_ns_per_m_rad
    no_body = aero.AeroParams((0.0,) * 3, (0.0,) * 3, in_plane, axial, 0.1, False, 1.0)
    one = aero.drag_force_body_n(no_body, (1.0, -0.5, 2.0), 1500.0)
    two = aero.drag_force_body_n(no_body, (2.0, -1.0, 4.0), 1500.0)
    assert two == pytest.approx(tuple(2 * f for f in one))
    assert one[0] == pytest.approx(-in_plane * 1500.0)
    assert one[2] == pytest.approx(-axial * 1500.0 * 2.0)  # along the rotor axis, its own coefficient
    assert 0.0 < axial < in_plane
    assert aero.drag_force_body_n(no_body, (1.0, 0.0, 1.0), 0.0) == (0.0, 0.0, 0.0)  # stopped rotors


def test_in_forward_flight_the_drag_balances_the_tilt(vehicle):
    # at a steady 4 m/s the tilt's horizontal thrust is what body plus rotor drag take away
    # (heading north-east, between the world's landmarks)
    with Simulator(SimConfig(sensor_noise=False, start=StartPose(yaw_rad=math.pi / 4))) as sim:
        sim.send(Twist(linear_z=1.0))
        sim.run_for(2.0)
        sim.send(Twist(linear_x=4.0))
        state = sim.run_for(8.0)
    omega = sum(aero.rotor_speed_radps(t, vehicle.thrust_coefficient_n_per_rad2s2) for t in state.rotor_thrusts_n)
    expected = -aero.drag_force_body_n(vehicle.aero, (4.0, 0.0, 0.0), omega)[0]
    thrust = sum(state.rotor_thrusts_n)
    _, pitch = state.roll_pitch_rad()
    assert math.hypot(*state.linear_velocity_mps[:2]) == pytest.approx(4.0, abs=0.02)
    assert thrust * math.sin(pitch) == pytest.approx(expected, rel=0.05)
    assert 1.0 < expected < 2.5  # N: mostly rotor drag, some body drag


def test_ground_effect_thrust_ratio_at_half_a_rotor_diameter_is_cheeseman_bennetts():
    assert ground_effect_thrust_ratio(0.5) == pytest.approx(1.0 / (1.0 - (1.0 / 4.0) ** 2), rel=1e-5)  # 1.067
    assert ground_effect_thrust_ratio(5.0) == pytest.approx(1.0, abs=1e-3)


def _hover_thrust_n(altitude_m: float, urdf=None) -> float:
    """Total rotor thrust the cascade settles on holding base_link `altitude_m` up (height z-mode,
    taking off from the ground)."""
    from quadsim.core.types import HEIGHT_MODE_BASE_M

    with Simulator(SimConfig(urdf=urdf, z_mode=ZMode.HEIGHT, sensor_noise=False)) as sim:
        sim.send(Twist(linear_z=altitude_m - HEIGHT_MODE_BASE_M))
        sim.run_for(8.0)
        assert sim.state.position_m[2] == pytest.approx(altitude_m, abs=0.01)
        return sum(sim.state.rotor_thrusts_n)


def test_hover_thrust_falls_near_the_ground():
    # the lowest altitude the landing layer holds (0.3 m) keeps the rotors about 1.3 diameters up:
    # T_ige / T_oge = 1 / (1 - (R / 4z)^2), so the motors' thrust is (1 - (R / 4z)^2) of far up
    urdf = SHIPPED_VEHICLES["quad"]
    v = load_vehicle(urdf)
    radius, low = v.aero.rotor_radius_m, v.limits.min_altitude_m + 0.05
    hub_z = sum(v.com_m[2] + r.position_m[2] for r in v.rotors) / v.rotor_count
    rotor_height = low + hub_z
    near, far = _hover_thrust_n(low, urdf), _hover_thrust_n(1.5, urdf)
    assert near / far == pytest.approx(1.0 - (radius / (4.0 * rotor_height)) ** 2, abs=1e-3)
    assert near / far < 0.999  # measurably less thrust near the ground
