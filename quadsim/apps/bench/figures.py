"""What every bench section reports: a figure as steps/s, real-time factor and a ratio to the
baseline measured in the same run, the best of several repeats; and the CPU hogs a section
measures beside, as other work on a busy machine."""

from __future__ import annotations

import math
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
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


def best_seconds(run: Callable[[], object], repeats: int = 1) -> float:
    """Wall seconds of a call of `run`, the best of `repeats` (the least disturbed by other work)."""
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - t0)
    return best


def best_of(repeats: int, steps: int, run: Callable[[int], object]) -> float:
    """Seconds per step, best of `repeats` timed runs of `steps` steps."""
    return best_seconds(lambda: run(steps), repeats) / steps


@contextmanager
def cpu_hogs(count: int) -> Iterator[None]:
    """`count` processes that spin on a core each while the block runs, as other work on a busy
    machine does."""
    busy = [
        subprocess.Popen([sys.executable, "-c", "while True: pass"], stdin=subprocess.DEVNULL) for _ in range(count)
    ]
    try:
        yield
    finally:
        for hog in busy:
            hog.kill()
            hog.wait()
