"""The rotors' motors: a first-order lag from commanded to produced thrust, clipped to [0, max]."""

from __future__ import annotations

import math

from quadsim.core.types import RotorForces


class MotorBank:
    """Four motors sharing one time constant, advanced once per physics step.

    Discretised exactly for a constant command over the step: f += (1 - exp(-dt/tau)) (u - f).
    """

    def __init__(self, time_constant_s: float, max_thrust_n: float, dt_s: float) -> None:
        self._alpha = 1.0 if time_constant_s <= 0.0 else 1.0 - math.exp(-dt_s / time_constant_s)
        self._max = max_thrust_n
        self.thrusts_n: RotorForces = (0.0, 0.0, 0.0, 0.0)

    def reset(self, thrusts_n: RotorForces = (0.0, 0.0, 0.0, 0.0)) -> None:
        self.thrusts_n = thrusts_n

    def advance(self, command_n: RotorForces) -> RotorForces:
        """Move the produced thrusts one step toward the command and return them."""
        a, top = self._alpha, self._max
        f0, f1, f2, f3 = self.thrusts_n
        u0, u1, u2, u3 = command_n
        # clip the command first: a motor cannot be asked for more than it has
        u0 = 0.0 if u0 < 0.0 else (top if u0 > top else u0)
        u1 = 0.0 if u1 < 0.0 else (top if u1 > top else u1)
        u2 = 0.0 if u2 < 0.0 else (top if u2 > top else u2)
        u3 = 0.0 if u3 < 0.0 else (top if u3 > top else u3)
        self.thrusts_n = (f0 + a * (u0 - f0), f1 + a * (u1 - f1), f2 + a * (u2 - f2), f3 + a * (u3 - f3))
        return self.thrusts_n
