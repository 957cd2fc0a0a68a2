"""IMU noise: MPU-6000 class white noise and bias random walk on /quad/imu only; ground truth
untouched for the controllers, /quad/odom and /quad/pose; seeded."""

import math

import numpy as np
import pytest

from quadsim import SimConfig, Simulator, StateLog, Twist


def _resting(seconds: float, **config) -> StateLog:
    """A vehicle on the ground, rotors idle (nothing moves: the true rates are zero)."""
    log = StateLog()
    with Simulator(SimConfig(**config)) as sim:
        sim.add_sink(log)
        sim.run_for(seconds)
    return log


def test_imu_noise_has_the_datasheet_density_and_truth_is_untouched(vehicle):
    states = _resting(31.0, seed=5).states[60:]  # after the first second: settled on its skids
    gyro = np.array([s.imu.angular_velocity_body_rps for s in states])
    accel = np.array([s.imu.specific_force_body_mps2 for s in states])
    truth_rates = np.array([s.angular_velocity_body_rps for s in states])
    truth_force = np.array([s.specific_force_body_mps2 for s in states])
    assert np.abs(truth_rates).max() < 1e-4  # at rest: the true rates, which odometry publishes
    noise = vehicle.imu_noise
    rate_hz = 60
    # white noise of std density * sqrt(rate), on a bias that has wandered a little (random walk)
    gyro_white = np.diff(gyro - truth_rates, axis=0).std(axis=0) / math.sqrt(2.0)
    accel_white = np.diff(accel - truth_force, axis=0).std(axis=0) / math.sqrt(2.0)
    assert gyro_white == pytest.approx([noise.gyro_noise_density_radps_per_rthz * math.sqrt(rate_hz)] * 3, rel=0.1)
    assert accel_white == pytest.approx([noise.accel_noise_density_mps2_per_rthz * math.sqrt(rate_hz)] * 3, rel=0.1)
    # the bias walks: over 31 s of a random walk its spread is random_walk * sqrt(31 s)
    bias_end = (gyro - truth_rates)[-600:].mean(axis=0)
    walk = noise.gyro_bias_random_walk_radps2_per_rthz * math.sqrt(31.0)
    assert np.abs(bias_end).max() < 6 * walk and np.abs(bias_end).max() > 0.01 * walk


def test_noise_off_publishes_the_true_values_and_the_flight_is_the_same_either_way():
    quiet = _resting(2.0, sensor_noise=False)
    assert all(s.imu is None for s in quiet.states)
    flights = []
    for noise in (True, False):
        log = StateLog()
        with Simulator(SimConfig(sensor_noise=noise)) as sim:
            sim.add_sink(log)
            sim.send(Twist(linear_z=1.0, linear_x=0.5))
            sim.run_for(3.0)
        flights.append([s._replace(imu=None) for s in log.states])
    assert flights[0] == flights[1]  # controllers fly the true state: the noise changes nothing else


def test_the_seed_decides_the_noise():
    first, again, other = (_resting(1.0, seed=seed) for seed in (1, 1, 2))
    assert [s.imu for s in first.states] == [s.imu for s in again.states]
    assert [s.imu for s in first.states] != [s.imu for s in other.states]
