"""Pacing: how far a run (or a playback) steps for the wall time that passed. The real-time pacer
is the only code in quadsim that reads the wall clock to decide how far to step: the teleop
window, headless real-time and live runs, and replay playback (window or live) all use it.

A pacer counts ticks at a rate: a run's physics steps (its physics rate), or a playback's
nanoseconds of recorded time (1e9 a second). `steps_for_frame(done)` says how many ticks to
advance now; `wait(done, due)` sleeps until `due` ticks are due (or a stop is asked for). A window's frames
are capped to a rate by a FrameCap.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable

#: the longest sleep between two looks at a stop request (a signal is answered this fast)
_LONGEST_SLEEP_S = 0.05
#: a wait this close to its end is over
_CLOSE_ENOUGH_S = 1e-6


class RealTimePacer:
    """Keeps ticks in step with the wall clock, `speed` times as fast. It never skips ticks. When
    the machine cannot keep up, a window's pacer (`max_frame_s`) advances at most that much wall
    time's worth per frame and lets the run fall behind (the slowdown is visible, and `lagging`
    says so); a headless run's (`max_frame_s` None) steps whatever is due, catching up."""

    def __init__(
        self,
        rate_hz: int,
        max_frame_s: float | None = 0.1,
        clock: Callable[[], float] = time.perf_counter,
        lag_hold_s: float = 1.0,
        speed: float = 1.0,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.rate_hz = rate_hz
        self.speed = speed
        self.max_steps = None if max_frame_s is None else max(1, round(max_frame_s * rate_hz * speed))
        self._clock = clock
        self._sleep = sleep
        self._origin_wall = clock()
        self._origin_steps = 0
        self._lag_hold_s = lag_hold_s
        self._last_behind_wall = -float("inf")
        #: behind real time now, or within `lag_hold_s` of it (no flicker)
        self.lagging = False

    def rebase(self, steps_done: int, speed: float | None = None) -> None:
        """Restart the correspondence from now (after a pause, a reset or a seek; at a new speed)."""
        if speed is not None:
            self.speed = speed
        self._origin_wall = self._clock()
        self._origin_steps = steps_done
        self._last_behind_wall = -float("inf")
        self.lagging = False

    def _due(self, now: float) -> int:
        return self._origin_steps + int((now - self._origin_wall) * self.rate_hz * self.speed)

    def steps_for_frame(self, steps_done: int) -> int:
        """Ticks to advance now, with `steps_done` done: what the wall clock says is due, at
        most `max_steps` (a backlog beyond it is given up: the run slows down instead) where
        there is such a cap."""
        now = self._clock()
        wanted = self._due(now) - steps_done
        if self.max_steps is not None and wanted > self.max_steps:
            self.lagging = True
            self._last_behind_wall = now
            self._origin_wall = now  # give up on the backlog: slow down instead
            self._origin_steps = steps_done + self.max_steps
            return self.max_steps
        self.lagging = now - self._last_behind_wall < self._lag_hold_s
        return max(0, wanted)

    def behind_s(self, steps_done: int) -> float:
        """How far behind the wall clock the run is, in wall seconds (0 when it keeps up)."""
        return max(0.0, (self._due(self._clock()) - steps_done) / (self.rate_hz * self.speed))

    def wait(self, due_steps: int, stop: Callable[[], bool] = lambda: False) -> None:
        """Sleep until `due_steps` ticks are due by the wall clock, or `stop()` says so (asked
        at least every 50 ms)."""
        rate = self.rate_hz * self.speed
        while not stop():
            ahead = (due_steps - self._origin_steps) / rate - (self._clock() - self._origin_wall)
            if ahead <= _CLOSE_ENOUGH_S:  # (not 0: rounding can leave an instant no clock tick passes)
                return
            self._sleep(min(ahead, _LONGEST_SLEEP_S))


class FixedStepPacer:
    """Advances the same number of ticks every frame, whatever the wall clock says (tests, the
    benchmark, a re-flight): `frame_s` of time at `rate_hz`."""

    def __init__(self, rate_hz: int, frame_s: float = 1.0 / 30.0) -> None:
        self.steps = max(1, round(frame_s * rate_hz))
        self.speed = 1.0
        self.lagging = False

    def rebase(self, steps_done: int, speed: float | None = None) -> None:
        if speed is not None:
            self.speed = speed

    def steps_for_frame(self, steps_done: int) -> int:
        return round(self.steps * self.speed)

    def wait(self, due_steps: int, stop: Callable[[], bool] = lambda: False) -> None:
        """Nothing to wait for: every frame's ticks are due at once."""


Pacer = RealTimePacer | FixedStepPacer


class FrameCap:
    """At most `fps` frames a second: `wait()`, at the end of each frame, sleeps what is left of
    the frame's 1/fps since the last one ended (a window that draws faster than a screen shows
    would burn a core for nothing). A frame that took longer is not made up for."""

    def __init__(
        self, fps: float, clock: Callable[[], float] = time.perf_counter, sleep: Callable[[float], None] = time.sleep
    ) -> None:
        self.frame_s = 1.0 / fps
        self._clock = clock
        self._sleep = sleep
        self._last: float | None = None

    def wait(self) -> None:
        now = self._clock()
        left = -1.0 if self._last is None else self._last + self.frame_s - now
        if left > _CLOSE_ENOUGH_S:
            self._sleep(left)
            now = self._clock()
        self._last = now


def collect_start_up_garbage() -> None:
    """Collect the garbage of start-up now, before real time begins.

    Starting a run (importing PyBullet, numpy, pygame and numba, loading the world, opening the
    window and the recording) leaves about 120,000 young objects. Python's first full collection
    of them came about a second into the flight and took 40-60 ms on a 2-core machine: a hitch
    in the window, and a Twist held that long. Done here it costs the same at a moment nobody
    waits on, and what a run allocates afterwards seldom adds up to another full collection."""
    gc.collect()
