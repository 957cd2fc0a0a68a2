"""Pacing: how much simulation time each window frame advances. The real-time pacer is the
only place in quadsim that reads the wall clock to decide how far to step."""

from __future__ import annotations

import time


class RealTimePacer:
    """Keeps sim time in step with the wall clock. When the machine cannot keep up, it does not
    skip physics steps: it advances at most `max_frame_s` of sim time per frame and lets sim
    time fall behind (the slowdown is visible, and `lagging` says so)."""

    def __init__(
        self, physics_hz: int, max_frame_s: float = 0.1, clock=time.perf_counter, lag_hold_s: float = 1.0
    ) -> None:
        self.physics_hz = physics_hz
        self.max_steps = max(1, round(max_frame_s * physics_hz))
        self._clock = clock
        self._origin_wall = clock()
        self._origin_steps = 0
        self._lag_hold_s = lag_hold_s
        self._last_behind_wall = -float("inf")
        self.lagging = False  # behind real time now, or within `lag_hold_s` of it (no flicker)
        self.speed = 1.0  # sim seconds per wall second over the recent frames

    def rebase(self, steps_done: int) -> None:
        """Restart the correspondence (after a pause or reset)."""
        self._origin_wall = self._clock()
        self._origin_steps = steps_done
        self._last_behind_wall = -float("inf")
        self.lagging = False

    def steps_for_frame(self, steps_done: int) -> int:
        target = self._origin_steps + int((self._clock() - self._origin_wall) * self.physics_hz)
        wanted = target - steps_done
        now = self._clock()
        if wanted > self.max_steps:
            self.lagging = True
            self._last_behind_wall = now
            self._origin_wall = now  # give up on the backlog: slow down instead
            self._origin_steps = steps_done + self.max_steps
            return self.max_steps
        self.lagging = now - self._last_behind_wall < self._lag_hold_s
        if wanted <= 0:
            return 0
        return wanted


class FixedStepPacer:
    """Advances the same sim time every frame, whatever the wall clock says (tests, benchmark)."""

    def __init__(self, physics_hz: int, frame_s: float = 1.0 / 30.0) -> None:
        self.steps = max(1, round(frame_s * physics_hz))
        self.lagging = False

    def rebase(self, steps_done: int) -> None:
        pass

    def steps_for_frame(self, steps_done: int) -> int:
        return self.steps
