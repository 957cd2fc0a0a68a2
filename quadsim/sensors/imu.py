"""The IMU's noise: white noise and a bias random walk on the gyro and the accelerometer.

Sampled once per published state, from its own random stream, whether or not anyone listens,
so a run's noise depends on its seed and step count alone. Only `/quad/imu` carries it: the
state's true values stay untouched for the controllers, odometry and pose.

Discrete form of the continuous densities (parameter file [imu]) at sample period dt:
white noise std = density / sqrt(dt); bias += random_walk * sqrt(dt) * N(0, 1).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from quadsim.core.compiled import jit, python_of
from quadsim.core.types import ImuReading, VehicleState
from quadsim.vehicle.params import ImuNoiseParams

#: samples drawn from the generator at a time (the stream is the same whatever the block)
_BLOCK = 256


@jit
def walked(
    sample: Any, gyro_bias: tuple[float, float, float], accel_bias: tuple[float, float, float]
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The biases after one more `sample` (a row of the block: its bias steps are columns 3-5
    and 9-11). One walk for every reader: ImuNoise.measure, and the compiled steps that take
    samples unread (quadsim.sim.clear_flight)."""
    gyro = (gyro_bias[0] + sample[3], gyro_bias[1] + sample[4], gyro_bias[2] + sample[5])
    accel = (accel_bias[0] + sample[9], accel_bias[1] + sample[10], accel_bias[2] + sample[11])
    return gyro, accel


#: the same walk run as Python, from Python: a call into compiled code costs 13-25 us to dispatch,
#: its arithmetic well under one
_walked_in_python = python_of(walked)


class ImuNoise:
    """Adds an MEMS IMU's noise to the true body rates and specific force."""

    def __init__(self, params: ImuNoiseParams, rate_hz: int, seed: np.random.SeedSequence) -> None:
        self.params = params
        self._seed = seed
        root_hz = math.sqrt(rate_hz)
        root_dt = 1.0 / root_hz
        # per sample: gyro white, gyro bias step, accel white, accel bias step (3 axes each)
        self._scales = np.repeat(
            [
                params.gyro_noise_density_radps_per_rthz * root_hz,
                params.gyro_bias_random_walk_radps2_per_rthz * root_dt,
                params.accel_noise_density_mps2_per_rthz * root_hz,
                params.accel_bias_random_walk_mps3_per_rthz * root_dt,
            ],
            3,
        )
        self.reset()

    def reseed(self, seed: np.random.SeedSequence) -> None:
        """The noise's random stream from `seed` from the next reset on."""
        self._seed = seed

    def reset(self) -> None:
        """Back to the start of the stream, biases zero."""
        self._rng = np.random.Generator(np.random.PCG64(self._seed))
        #: the block of samples being used, as an array and as lists (faster to index from Python)
        self._block = np.zeros((0, 12))
        self._samples: list[list[float]] = []
        self._next = 0
        self.gyro_bias_radps = (0.0, 0.0, 0.0)
        self.accel_bias_mps2 = (0.0, 0.0, 0.0)

    def measure(self, state: VehicleState) -> VehicleState:
        """The state with its `imu` reading: true values plus bias plus white noise."""
        self.refill()
        if len(self._samples) != len(self._block):  # a new block: its rows as lists, once (faster to index)
            self._samples = self._block.tolist()
        n = self._samples[self._next]
        gb, ab = _walked_in_python(n, self.gyro_bias_radps, self.accel_bias_mps2)
        self._next += 1
        self.gyro_bias_radps, self.accel_bias_mps2 = gb, ab
        w, f = state.angular_velocity_body_rps, state.specific_force_body_mps2
        reading = ImuReading(
            (w[0] + gb[0] + n[0], w[1] + gb[1] + n[1], w[2] + gb[2] + n[2]),
            (f[0] + ab[0] + n[6], f[1] + ab[1] + n[7], f[2] + ab[2] + n[8]),
        )
        return state._replace(imu=reading)

    def refill(self) -> None:
        """The next block of samples drawn, if this one is used up."""
        if self._next >= len(self._block):
            self._block = self._rng.standard_normal((_BLOCK, 12)) * self._scales
            self._samples = []  # its rows as lists, made when `measure` reads them
            self._next = 0

    @property
    def walk(self) -> tuple[np.ndarray, int, tuple[float, float, float], tuple[float, float, float]]:
        """Where the noise stands, for compiled steps that take its samples without a reading
        (quadsim.sim.clear_flight): the block of samples, the next one's index in it, the gyro's
        and the accelerometer's biases."""
        return self._block, self._next, self.gyro_bias_radps, self.accel_bias_mps2

    def walked(
        self, next_sample: int, gyro_bias: tuple[float, float, float], accel_bias: tuple[float, float, float]
    ) -> None:
        """The samples up to `next_sample` of the block taken, and the biases they walked to."""
        self._next = next_sample
        self.gyro_bias_radps, self.accel_bias_mps2 = gyro_bias, accel_bias
