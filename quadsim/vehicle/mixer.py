"""The mixer: collective thrust and body torques <-> four rotor forces, from rotor geometry."""

from __future__ import annotations

import numpy as np

from quadsim.core.types import RotorForces
from quadsim.errors import ConfigError
from quadsim.vehicle.params import VehicleParams


class Mixer:
    """Allocation built from the rotors' positions and spins, and its inverse.

    A rotor i at (x_i, y_i) relative to the centre of mass, pushing f_i along body z, gives
        thrust += f_i,  roll torque += y_i f_i,  pitch torque += -x_i f_i,
        yaw torque += -spin_i * (k_m / k_f) f_i   (a CCW rotor turns the body clockwise).
    The matrix of those rows is inverted once; `to_rotor_forces` then costs 16 multiplications.
    """

    def __init__(self, vehicle: VehicleParams) -> None:
        c = vehicle.yaw_torque_per_thrust_m
        rows = [
            [1.0 for _ in vehicle.rotors],
            [r.position_m[1] for r in vehicle.rotors],
            [-r.position_m[0] for r in vehicle.rotors],
            [-r.spin.sign * c for r in vehicle.rotors],
        ]
        allocation = np.array(rows, dtype=float)
        if allocation.shape != (4, 4) or abs(np.linalg.det(allocation)) < 1e-12:
            raise ConfigError(
                f"{vehicle.urdf_path.name}: rotor layout cannot produce independent roll, pitch and yaw torques"
            )
        self.allocation = allocation
        inverse = np.linalg.inv(allocation)
        # plain tuples: the hot path below is scalar Python, faster than numpy for 4x4
        self._inv = tuple(tuple(float(v) for v in row) for row in inverse)
        self.max_thrust_n = vehicle.max_thrust_n

    def to_wrench(self, forces: RotorForces) -> tuple[float, float, float, float]:
        """Rotor forces (N) -> (collective thrust N, roll, pitch, yaw torque N m)."""
        w = self.allocation @ np.asarray(forces, dtype=float)
        return float(w[0]), float(w[1]), float(w[2]), float(w[3])

    def to_rotor_forces(self, thrust_n: float, roll_nm: float, pitch_nm: float, yaw_nm: float) -> RotorForces:
        """Rotor forces for a wanted wrench, each clipped to [0, max].

        When the wanted wrench does not fit, yaw torque is given up first (scaled down until
        the forces fit), as roll and pitch keep the vehicle upright and yaw does not.
        """
        (a0, a1, a2, a3), (b0, b1, b2, b3), (c0, c1, c2, c3), (d0, d1, d2, d3) = self._inv
        f0 = a0 * thrust_n + a1 * roll_nm + a2 * pitch_nm
        f1 = b0 * thrust_n + b1 * roll_nm + b2 * pitch_nm
        f2 = c0 * thrust_n + c1 * roll_nm + c2 * pitch_nm
        f3 = d0 * thrust_n + d1 * roll_nm + d2 * pitch_nm
        y0, y1, y2, y3 = a3 * yaw_nm, b3 * yaw_nm, c3 * yaw_nm, d3 * yaw_nm
        top = self.max_thrust_n
        scale = 1.0
        for f, y in ((f0, y0), (f1, y1), (f2, y2), (f3, y3)):
            g = f + y
            if g > top and y > 0.0:
                scale = min(scale, max(0.0, (top - f) / y))
            elif g < 0.0 and y < 0.0:
                scale = min(scale, max(0.0, -f / y))
        f0 += scale * y0
        f1 += scale * y1
        f2 += scale * y2
        f3 += scale * y3
        return (
            0.0 if f0 < 0.0 else (top if f0 > top else f0),
            0.0 if f1 < 0.0 else (top if f1 > top else f1),
            0.0 if f2 < 0.0 else (top if f2 > top else f2),
            0.0 if f3 < 0.0 else (top if f3 > top else f3),
        )
