"""The mixer is built from geometry, inverts exactly, clips, and gives up yaw first."""

import pytest

from quadsim.vehicle.mixer import Mixer
from quadsim.vehicle.motors import MotorBank


def test_round_trip(vehicle):
    mixer = Mixer(vehicle)
    wrench = (10.0, 0.05, -0.03, 0.01)
    forces = mixer.to_rotor_forces(*wrench)
    assert mixer.to_wrench(forces) == pytest.approx(wrench, abs=1e-9)


def test_hover_splits_weight_evenly(vehicle):
    forces = Mixer(vehicle).to_rotor_forces(vehicle.weight_n, 0.0, 0.0, 0.0)
    # the CoM sits 0.5 mm forward of the rotor centre, so the front rotors carry a little more
    assert sum(forces) == pytest.approx(vehicle.weight_n)
    assert max(forces) - min(forces) < 0.02 * vehicle.hover_thrust_per_rotor_n


def test_torque_signs_follow_rep103(vehicle):
    mixer = Mixer(vehicle)
    hover = vehicle.weight_n
    f1, f2, f3, f4 = mixer.to_rotor_forces(hover, 0.1, 0.0, 0.0)  # +roll: left side (+y) pushes up
    assert f1 > f4 and f2 > f3
    f1, f2, f3, f4 = mixer.to_rotor_forces(hover, 0.0, 0.1, 0.0)  # +pitch (nose down): rear pushes up
    assert f2 > f1 and f3 > f4
    f1, f2, f3, f4 = mixer.to_rotor_forces(hover, 0.0, 0.0, 0.05)  # +yaw: the CW rotors speed up
    assert f2 > f1 and f4 > f3


def test_clipping_and_yaw_given_up_first(vehicle):
    mixer = Mixer(vehicle)
    top = vehicle.max_thrust_n
    forces = mixer.to_rotor_forces(100.0, 0.0, 0.0, 0.0)
    assert forces == (top, top, top, top)
    assert mixer.to_rotor_forces(-5.0, 0.0, 0.0, 0.0) == (0.0, 0.0, 0.0, 0.0)
    # near full thrust a big yaw demand does not fit: roll is kept, yaw is reduced
    thrust, roll = 0.9 * 4 * top, 0.05
    forces = mixer.to_rotor_forces(thrust, roll, 0.0, 1.0)
    got = mixer.to_wrench(forces)
    assert got[1] == pytest.approx(roll, rel=1e-6)
    assert 0.0 < got[3] < 1.0
    assert all(0.0 <= f <= top for f in forces)


def test_motor_lag_is_first_order():
    motors = MotorBank(motor_count=4, time_constant_s=0.02, max_thrust_n=6.0, dt_s=1 / 240)
    for _ in range(5):  # 5 steps of 1/240 s = one time constant (0.0208 s)
        motors.advance((2.0, 2.0, 2.0, 2.0))
    assert motors.thrusts_n[0] == pytest.approx(2.0 * (1 - 2.718281828 ** (-5 / 240 / 0.02)), rel=1e-9)
    for _ in range(200):
        motors.advance((9.0, -1.0, 3.0, 3.0))
    assert motors.thrusts_n == pytest.approx((6.0, 0.0, 3.0, 3.0))


def test_motor_bank_takes_one_force_per_motor():
    motors = MotorBank(motor_count=6, time_constant_s=0.0, max_thrust_n=6.0, dt_s=1 / 240)
    assert motors.thrusts_n == (0.0,) * 6
    assert motors.advance((1.0, 2.0, 3.0, 4.0, 5.0, 7.0)) == (1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    with pytest.raises(ValueError, match="expected 6 rotor forces, got 4"):
        motors.advance((1.0, 1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match="expected 6 rotor forces"):
        motors.reset((0.0,) * 5)


def test_quad_mixer_uses_the_exact_inverse(vehicle):
    # four rotors: the allocation is square and its exact inverse is used, to the last bit
    import numpy as np

    mixer = Mixer(vehicle)
    inverse = np.linalg.inv(mixer.allocation)
    thrust, roll, pitch, yaw = 9.0, 0.02, -0.01, 0.003
    expected = [a * thrust + b * roll + c * pitch + d * yaw for a, b, c, d in inverse.tolist()]
    assert mixer.to_rotor_forces(thrust, roll, pitch, yaw) == tuple(expected)
