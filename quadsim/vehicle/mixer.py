"""The mixer: collective thrust and body torques <-> N rotor forces, from rotor geometry."""

from __future__ import annotations

import numpy as np

from quadsim.core.kinematics import clamp
from quadsim.core.types import RotorForces
from quadsim.errors import ConfigError
from quadsim.vehicle.params import VehicleParams


class Mixer:
    """Allocation built from the rotors' positions and spins, and its (pseudo-)inverse.

    A rotor i at (x_i, y_i) relative to the centre of mass, pushing f_i along body z, gives
        thrust += f_i,  roll torque += y_i f_i,  pitch torque += -x_i f_i,
        yaw torque += -spin_i * (k_m / k_f) f_i   (a CCW rotor turns the body clockwise).
    Those rows make a 4 x N allocation matrix. It is inverted once: exactly for four rotors,
    and for more with the Moore-Penrose pseudo-inverse, which shares a wrench among the rotors
    with the least sum of squared forces. `to_rotor_forces` then costs 4 N multiplications.
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
        if allocation.shape[1] < 4 or np.linalg.matrix_rank(allocation) < 4:
            raise ConfigError(
                f"{vehicle.urdf_path.name}: rotor layout cannot produce independent roll, pitch and yaw torques"
            )
        self.allocation = allocation
        # for a square matrix the pseudo-inverse is the inverse; np.linalg.inv gives it to the last
        # bit as the quad has always used it (pinv goes through an SVD and rounds differently)
        square = allocation.shape[0] == allocation.shape[1]
        inverse = np.linalg.inv(allocation) if square else np.linalg.pinv(allocation)
        # plain tuples: the hot path below is scalar Python, faster than numpy for a few rotors
        self._rows = tuple((float(a), float(b), float(c), float(d)) for a, b, c, d in inverse)
        self.rotor_count = allocation.shape[1]
        self.max_thrust_n = vehicle.max_thrust_n

    def to_wrench(self, forces: RotorForces) -> tuple[float, float, float, float]:
        """Rotor forces (N) -> (collective thrust N, roll, pitch, yaw torque N m)."""
        if len(forces) != self.rotor_count:
            raise ValueError(f"expected {self.rotor_count} rotor forces, got {len(forces)}")
        w = self.allocation @ np.asarray(forces, dtype=float)
        return float(w[0]), float(w[1]), float(w[2]), float(w[3])

    def to_rotor_forces(self, thrust_n: float, roll_nm: float, pitch_nm: float, yaw_nm: float) -> RotorForces:
        """Rotor forces for a wanted wrench, each clipped to [0, max].

        When the wanted wrench does not fit, yaw torque is given up first (scaled down until
        the forces fit), as roll and pitch keep the vehicle upright and yaw does not.
        """
        rows, top = self._rows, self.max_thrust_n
        wanted = [a * thrust_n + b * roll_nm + c * pitch_nm + d * yaw_nm for a, b, c, d in rows]
        for g in wanted:
            if not 0.0 <= g <= top:
                break
        else:
            return tuple(wanted)  # it fits as it is (the usual case)
        forces = [a * thrust_n + b * roll_nm + c * pitch_nm for a, b, c, _ in rows]
        yaws = [d * yaw_nm for *_, d in rows]
        scale = 1.0
        for f, y in zip(forces, yaws):
            g = f + y
            if g > top and y > 0.0:
                scale = min(scale, max(0.0, (top - f) / y))
            elif g < 0.0 and y < 0.0:
                scale = min(scale, max(0.0, -f / y))
        return tuple([clamp(f + scale * y, 0.0, top) for f, y in zip(forces, yaws)])
