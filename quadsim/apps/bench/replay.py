"""Playback and re-simulation of a recorded flight."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from quadsim.apps.bench.figures import best_seconds
from quadsim.apps.bench.flight import full_loop
from quadsim.core.types import ZMode
from quadsim.sim.config import SimConfig


def run_replay_bench(out: Callable[[str], None] = print, flight_s: float = 20.0) -> None:
    """Headless playback read speed (recording with both cameras), and re-simulation speed
    (recording without cameras) against the flight core measured in the same run."""
    import tempfile

    from quadsim.apps.replay_export import summary_lines
    from quadsim.drivers.scripted import ScriptedDriver, load_script
    from quadsim.recording.flight import load_flight
    from quadsim.sensors.camera import default_cameras
    from quadsim.session.outputs import OutputOptions
    from quadsim.session.plan import RunPlan
    from quadsim.session.resim import resimulate
    from quadsim.session.run import fly

    out("quadsim bench: replay")
    script = load_script("square")
    with tempfile.TemporaryDirectory() as tmp:
        paths = {}
        for name, cams in (("cams", default_cameras()), ("nocams", ())):
            paths[name] = Path(tmp) / f"{name}.mcap"
            outputs = OutputOptions(out=paths[name], cameras=cams)
            config = SimConfig(z_mode=ZMode.HEIGHT)
            fly(RunPlan.alone(config, ScriptedDriver(script), duration_s=flight_s, outputs=outputs, label=name))
        best = best_seconds(lambda: summary_lines(load_flight(paths["cams"])), 3)
        flight = load_flight(paths["cams"])
        size = paths["cams"].stat().st_size / 1e6
        out(
            f"  headless playback of {flight_s:.0f} s with both cameras ({size:.1f} MB, "
            f"{sum(flight.topics.values())} messages): {best:.2f} s, {flight_s / best:.0f}x real time (target >= 50x)"
        )
        core = full_loop().figure(12000, 3)
        flight = load_flight(paths["nocams"])
        best, best_stepping = float("inf"), float("inf")
        for _ in range(3):
            t0 = time.perf_counter()
            report = resimulate(flight, record=False)
            best = min(best, time.perf_counter() - t0)
            best_stepping = min(best_stepping, report.stepping_wall_s)
        out(
            f"  re-simulation of {flight_s:.0f} s without cameras: flying {report.sim_time_s / best_stepping:.0f}x real "
            f"time (flight core {core.real_time_factor:.0f}x in the same run); {flight_s / best:.0f}x including "
            f"loading, building the world and comparing; max position error {report.position.max_error:g} m"
        )
