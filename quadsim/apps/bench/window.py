"""The teleop window, headless: frame rate and pacing, alone and beside busy processes."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from quadsim.apps.bench.figures import cpu_hogs
from quadsim.core.types import ZMode
from quadsim.sim.config import SimConfig


class _Timer:
    """Wraps a method of an object so the time spent in it is added up under a name."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    def wrap(self, obj: object, method: str, name: str) -> None:
        inner = getattr(obj, method)

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0

        setattr(obj, method, timed)


@dataclass(frozen=True)
class WindowFigures:
    frames_per_s: float
    real_time_factor: float
    frames_behind: int
    key_latency_frames: int | None  # frames from the key event to the command reaching the controller
    key_latency_ms: float | None
    camera_rates_hz: dict[str, float]
    shares: dict[str, float]


def measure_window(wall_s: float, hogs: int = 0) -> WindowFigures:
    """The teleop window (SDL dummy video, real-time pacing, 1280x720, both cameras 320x240 @ 30
    Hz, recording on) flown for `wall_s`, with `hogs` CPU-bound processes running beside it."""
    import os
    import tempfile

    os.environ["SDL_VIDEODRIVER"] = "dummy"
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    from quadsim.apps.window.teleop import TeleopApp, TeleopOptions
    from quadsim.session.outputs import OutputOptions

    with tempfile.TemporaryDirectory() as tmp:
        app = TeleopApp(SimConfig(z_mode=ZMode.HEIGHT), OutputOptions(out=Path(tmp)), TeleopOptions(input="keyboard"))
        try:
            with cpu_hogs(hogs):
                timer = _Timer()
                timer.wrap(app.session, "step", "simulation (physics, control, recording)")
                timer.wrap(app.view, "draw", "drawing")
                if app.session.outputs.cameras is not None:
                    timer.wrap(app.session.outputs.cameras, "poll", "camera hand-over")
                app.run(max_frames=30)  # warm up: take off, first frames
                timer.seconds.clear()
                frames0, steps0, t0 = app.frame_count, app.sim.step_count, time.perf_counter()
                behind = 0
                while time.perf_counter() - t0 < wall_s:
                    app.frame()
                    behind += app.pacer.lagging
                wall = time.perf_counter() - t0
                frames = app.frame_count - frames0
                sim_s = (app.sim.step_count - steps0) / app.sim.config.rates.physics_hz
                camera_rates = app.camera_rates()
                # key latency: frames from posting a key press to the command reaching the controller
                before = app.sim.gate.last_receive_step
                t_post = time.perf_counter()
                pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_UP, mod=0, unicode="", scancode=0))
                latency_frames: int | None = None
                latency_ms: float | None = None
                for k in range(120):
                    app.frame()
                    if app.sim.gate.last_receive_step != before and app.sim.gate.last_command.linear_x > 0:
                        latency_frames, latency_ms = k, (time.perf_counter() - t_post) * 1e3
                        break
                return WindowFigures(
                    frames / wall,
                    sim_s / wall,
                    behind,
                    latency_frames,
                    latency_ms,
                    camera_rates,
                    {k: v / wall for k, v in timer.seconds.items()},
                )
        finally:
            app.close()


def run_interactive_bench(out: Callable[[str], None] = print, wall_s: float = 10.0) -> None:
    """The window, on an idle machine and beside two CPU-bound processes."""
    out(
        "quadsim bench: interactive window (SDL dummy video, real-time pacing, 1280x720, "
        "both cameras 320x240@30Hz, recording on)"
    )
    for hogs in (0, 2):
        f = measure_window(wall_s, hogs)
        where = "idle machine" if not hogs else f"{hogs} CPU-bound processes beside it"
        cams = ", ".join(f"{name} {rate:.1f}" for name, rate in sorted(f.camera_rates_hz.items()))
        latency = (
            f"{f.key_latency_frames} frame(s) after the one that took the event, {f.key_latency_ms:.0f} ms"
            if f.key_latency_frames is not None
            else "no command seen within 120 frames"
        )
        out(f"  {where}:")
        out(
            f"    {f.frames_per_s:.1f} frames/s (target >= 30), sim at {f.real_time_factor:.2f}x real time, "
            f"{f.frames_behind} frames behind real time"
        )
        out(f"    key to controller: {latency} (target: within one frame)")
        out(f"    cameras delivered {cams} frames/s of 30 (frames are dropped, not waited for, when busy)")
        out(
            "    share of the wall time: "
            + ", ".join(f"{k} {v * 100:.1f}%" for k, v in sorted(f.shares.items(), key=lambda kv: -kv[1]))
        )
