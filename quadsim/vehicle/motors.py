"""The rotors' motors: a first-order lag from commanded to produced thrust, clipped to [0, max]."""

from __future__ import annotations

import math

from quadsim.core.compiled import COMPILED, Floats, MutableFloats, float_tuple, floats, jit
from quadsim.core.types import RotorForces


@jit
def advance_motors(thrusts: MutableFloats, command: Floats, alpha: float, top: float) -> None:
    """Move the produced `thrusts` (in place) one step toward `command`, clipped to [0, top]
    first: a motor cannot be asked for more than it has."""
    for i in range(len(thrusts)):
        u = command[i]
        f = thrusts[i]
        thrusts[i] = f + alpha * ((0.0 if u < 0.0 else (top if u > top else u)) - f)


class MotorBank:
    """N motors sharing one time constant, advanced once per physics step.

    Discretised exactly for a constant command over the step: f += (1 - exp(-dt/tau)) (u - f).
    Every call takes and gives one force per motor; a tuple of another length is refused.
    """

    def __init__(self, motor_count: int, time_constant_s: float, max_thrust_n: float, dt_s: float) -> None:
        if motor_count < 1:
            raise ValueError(f"a motor bank needs at least one motor, got {motor_count}")
        self.motor_count = motor_count
        self.alpha = 1.0 if time_constant_s <= 0.0 else 1.0 - math.exp(-dt_s / time_constant_s)
        self.max_thrust_n = max_thrust_n
        #: the produced thrusts, as `advance_motors` moves them (quadsim.core.compiled.floats)
        self.thrusts = floats([0.0] * motor_count)

    @property
    def thrusts_n(self) -> RotorForces:
        """The thrusts the motors produce now (N)."""
        return tuple(self.thrusts.tolist()) if COMPILED else tuple(self.thrusts)

    def check_count(self, forces: RotorForces) -> None:
        """Refuse a tuple of forces that is not one per motor."""
        if len(forces) != self.motor_count:
            raise ValueError(f"expected {self.motor_count} rotor forces, got {len(forces)}")

    def reset(self, thrusts_n: RotorForces | None = None) -> None:
        """Set the produced thrusts (default: all stopped)."""
        if thrusts_n is None:
            thrusts_n = (0.0,) * self.motor_count
        self.check_count(thrusts_n)
        for i, f in enumerate(thrusts_n):
            self.thrusts[i] = float(f)

    def advance(self, command_n: RotorForces) -> RotorForces:
        """Move the produced thrusts one step toward the command and return them."""
        self.check_count(command_n)
        advance_motors(self.thrusts, float_tuple(command_n), self.alpha, self.max_thrust_n)
        return self.thrusts_n
