"""The window keeps real time on a busy machine: cameras drop frames instead of making the
flight wait; the HUD's rates are measured over wall time, never negative, and the SLOW warning
neither flickers nor shows while paused."""

from __future__ import annotations

import time
from pathlib import Path

import pygame
import pytest

from quadsim import SimConfig, ZMode
from quadsim.apps.window.teleop import TeleopApp, TeleopOptions
from quadsim.session.outputs import OutputOptions
from quadsim.session.pacing import FixedStepPacer, RealTimePacer


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_slow_warning_does_not_flicker_near_its_threshold():
    clock = FakeClock()
    pacer = RealTimePacer(240, max_frame_s=0.1, clock=clock, lag_hold_s=1.0)
    seen = []
    steps = 0
    for i in range(20):  # alternately just behind and just on time, 60 ms frames
        clock.now += 0.12 if i % 2 == 0 else 0.02
        steps += pacer.steps_for_frame(steps)
        seen.append(pacer.lagging)
    assert all(seen), seen  # on, and it stays on: no flicker
    for _ in range(30):  # then on time for 1.5 s
        clock.now += 0.05
        steps += pacer.steps_for_frame(steps)
    assert not pacer.lagging


def test_slow_warning_is_off_after_a_rebase():
    clock = FakeClock()
    pacer = RealTimePacer(240, clock=clock)
    clock.now += 1.0
    pacer.steps_for_frame(0)
    assert pacer.lagging
    pacer.rebase(0)  # resume after a pause, or a reset
    assert not pacer.lagging


@pytest.fixture
def app(tmp_path: Path):
    app = TeleopApp(
        SimConfig(z_mode=ZMode.HEIGHT),
        OutputOptions(out=tmp_path, cameras=(), render_workers=0),
        TeleopOptions(input="keyboard", window_size=(640, 360)),
        pacer=FixedStepPacer(240, 1 / 30),
    )
    yield app
    app.close()


def test_no_negative_real_time_factor_after_a_reset(app):
    app.run(max_frames=20)
    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_BACKSPACE, mod=0, unicode="", scancode=0))
    for _ in range(5):
        app.frame()
        assert app._model().real_time_factor >= 0.0


def test_rates_are_averaged_over_wall_time_not_frames(app):
    """Two frames a second for the last 10 s, as on a starved machine: the HUD says 2 fps, not
    the average of the last 60 frames (half a minute)."""
    now = time.perf_counter()
    app._frame_walls.clear()
    app._frame_walls.extend((now - 10.0 + 0.5 * i, app.sim.step_count) for i in range(20))  # up to now - 0.5
    app.frame()  # one more frame, now: the window keeps the last second
    fps, rtf = app._rates()
    assert fps == pytest.approx(2.0, rel=0.1)
    assert rtf >= 0.0


def test_paused_hides_the_slow_warning(app):
    app.pacer = RealTimePacer(240, clock=FakeClock())
    app.pacer.lagging = True
    app.paused = True
    assert not app._model().lagging
