"""The rotors' motors: a first-order lag from commanded to produced thrust, clipped to [0, max]."""

from __future__ import annotations

import math

from quadsim.core.types import RotorForces


class MotorBank:
    """N motors sharing one time constant, advanced once per physics step.

    Discretised exactly for a constant command over the step: f += (1 - exp(-dt/tau)) (u - f).
    Every call takes and gives one force per motor; a tuple of another length is refused.
    """

    def __init__(self, motor_count: int, time_constant_s: float, max_thrust_n: float, dt_s: float) -> None:
        if motor_count < 1:
            raise ValueError(f"a motor bank needs at least one motor, got {motor_count}")
        self.motor_count = motor_count
        self._alpha = 1.0 if time_constant_s <= 0.0 else 1.0 - math.exp(-dt_s / time_constant_s)
        self._max = max_thrust_n
        self.thrusts_n: RotorForces = (0.0,) * motor_count

    def _wrong_count(self, forces: RotorForces) -> ValueError:
        return ValueError(f"expected {self.motor_count} rotor forces, got {len(forces)}")

    def reset(self, thrusts_n: RotorForces | None = None) -> None:
        """Set the produced thrusts (default: all stopped)."""
        if thrusts_n is None:
            thrusts_n = (0.0,) * self.motor_count
        if len(thrusts_n) != self.motor_count:
            raise self._wrong_count(thrusts_n)
        self.thrusts_n = tuple(thrusts_n)

    def advance(self, command_n: RotorForces) -> RotorForces:
        """Move the produced thrusts one step toward the command and return them."""
        if len(command_n) != self.motor_count:
            raise self._wrong_count(command_n)
        a, top = self._alpha, self._max
        # clip the command first: a motor cannot be asked for more than it has
        self.thrusts_n = tuple(
            [f + a * ((0.0 if u < 0.0 else (top if u > top else u)) - f) for f, u in zip(self.thrusts_n, command_n)]
        )
        return self.thrusts_n
