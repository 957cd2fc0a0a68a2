"""What every bench section reports: a figure as steps/s, real-time factor and a ratio to the
baseline measured in the same run, the best of several repeats."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class Figure:
    """One measured figure: seconds a step, and what that is as a rate and a real-time factor."""

    name: str
    seconds_per_step: float
    physics_hz: int

    @property
    def steps_per_s(self) -> float:
        return 1.0 / self.seconds_per_step

    @property
    def real_time_factor(self) -> float:
        return self.steps_per_s / self.physics_hz


def best_of(repeats: int, steps: int, run: Callable[[int], object]) -> float:
    """Seconds per step, best of `repeats` timed runs of `steps` steps."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        run(steps)
        best = min(best, (time.perf_counter() - t0) / steps)
    return best
