"""The mixer: collective thrust and body torques <-> N rotor forces, from rotor geometry."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from quadsim.core.compiled import COMPILED, Floats, MutableFloats, floats, jit, table
from quadsim.core.exact import pseudo_inverse
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
        # in exact arithmetic, rounded once: the same bits on every machine (LAPACK's depend on
        # the kernels OpenBLAS picks for the CPU; quadsim.core.exact)
        inverse = pseudo_inverse(allocation.tolist())
        #: the inverse's rows (one per rotor: thrust, roll, pitch, yaw), as `mix` takes them
        self.rows = table(inverse)
        self.rotor_count = allocation.shape[1]
        self.max_thrust_n = vehicle.max_thrust_n

    def to_wrench(self, forces: RotorForces) -> tuple[float, float, float, float]:
        """Rotor forces (N) -> (collective thrust N, roll, pitch, yaw torque N m)."""
        if len(forces) != self.rotor_count:
            raise ValueError(f"expected {self.rotor_count} rotor forces, got {len(forces)}")
        thrust, roll, pitch, yaw = (
            float(sum(a * float(f) for a, f in zip(row, forces))) for row in self.allocation.tolist()
        )
        return thrust, roll, pitch, yaw

    def to_rotor_forces(self, thrust_n: float, roll_nm: float, pitch_nm: float, yaw_nm: float) -> RotorForces:
        """Rotor forces for a wanted wrench, each clipped to [0, max].

        When the wanted wrench does not fit, yaw torque is given up first (scaled down until
        the forces fit), as roll and pitch keep the vehicle upright and yaw does not.
        """
        out = floats([0.0] * self.rotor_count)
        mix(self.rows, self.max_thrust_n, thrust_n, roll_nm, pitch_nm, yaw_nm, out)
        return tuple(out.tolist()) if COMPILED else tuple(out)


@jit
def mix(rows: Sequence[Floats], top: float, thrust: float, tx: float, ty: float, tz: float, out: MutableFloats) -> None:
    """The rotor forces for a wanted wrench (thrust, body torques tx, ty, tz) into `out`, each
    clipped to [0, top], from the allocation's inverse `rows`; when the wrench does not fit, yaw
    torque is scaled down until it does (see `Mixer.to_rotor_forces`)."""
    n = len(out)
    fits = True
    for i in range(n):
        row = rows[i]
        g = row[0] * thrust + row[1] * tx + row[2] * ty + row[3] * tz
        out[i] = g
        if not 0.0 <= g <= top:
            fits = False
    if fits:  # the usual case
        return
    scale = 1.0
    for i in range(n):
        row = rows[i]
        f = row[0] * thrust + row[1] * tx + row[2] * ty
        y = row[3] * tz
        g = f + y
        if g > top and y > 0.0:
            scale = min(scale, max(0.0, (top - f) / y))
        elif g < 0.0 and y < 0.0:
            scale = min(scale, max(0.0, -f / y))
    for i in range(n):
        row = rows[i]
        f = row[0] * thrust + row[1] * tx + row[2] * ty + scale * (row[3] * tz)
        out[i] = 0.0 if f < 0.0 else (top if f > top else f)
