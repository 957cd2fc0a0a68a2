"""The window keeps real time on a busy machine.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_window_realtime.py."""

from __future__ import annotations

import os
import signal

from quadsim import SimConfig, Simulator, Twist, ZMode
from quadsim.sensors.camera import default_cameras
from quadsim.sensors.pipeline import CameraPipeline


def test_busy_workers_drop_frames_instead_of_making_the_flight_wait():
    """The real path: a render worker that gets no CPU at all (stopped with SIGSTOP)."""
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT)) as sim:
        pipe = CameraPipeline(sim.vehicle, sim.world, 240, default_cameras(64, 48), workers=1, ordered_delivery=False)
        try:
            sim.add_tap(pipe.tap_interval_steps, pipe.capture)
            got = []
            pipe.sinks.append(type("Sink", (), {"on_camera_frame": lambda self, f: got.append(f)})())
            sim.send(Twist())
            sim.run_for(0.5)
            pipe.drain()
            assert got, "the worker rendered nothing while it could"
            worker = pipe._procs[0]
            os.kill(worker.pid, signal.SIGSTOP)
            try:
                # 120 captures due while the worker is stopped: waiting for it would never end
                # (the pipeline would give up after a minute with an error)
                sim.run_for(2.0)
                dropped = sum(pipe.frames_dropped.values())
            finally:
                os.kill(worker.pid, signal.SIGCONT)
            assert dropped >= 100, pipe.frames_dropped  # nearly every capture was dropped
            before = len(got)
            sim.run_for(1.0)
            pipe.drain()
            assert len(got) > before  # the worker is back: frames come again
        finally:
            pipe.close()


FULL_COLLECTIONS = """
import gc, os, tempfile
from pathlib import Path
os.environ["SDL_VIDEODRIVER"] = os.environ["SDL_AUDIODRIVER"] = "dummy"
from quadsim import SimConfig, ZMode
from quadsim.session.pacing import FixedStepPacer
from quadsim.apps.window.teleop import TeleopApp, TeleopOptions
from quadsim.session.outputs import OutputOptions
from quadsim.sensors.camera import default_cameras

full = []
gc.callbacks.append(lambda phase, info: full.append(info["generation"]) if phase == "stop" else None)
with tempfile.TemporaryDirectory() as tmp:
    app = TeleopApp(SimConfig(z_mode=ZMode.HEIGHT), OutputOptions(out=Path(tmp), cameras=default_cameras(64, 48)),
                    TeleopOptions(input="keyboard"),
                    pacer=FixedStepPacer(240, 1 / 60))
    young = len(gc.get_objects(0)) + len(gc.get_objects(1))  # left for a later collection to scan
    full.clear()
    app.run(max_frames=1200)  # 20 s of flight, recorded, both cameras (small: the objects are the same)
    print(young, full.count(2), round(app.sim.time_s, 1))
    app.close()
"""


def test_the_window_leaves_no_start_up_garbage_for_a_full_collection_in_flight():
    """Start-up leaves some 120,000 objects; depending on what it allocated, Python's full
    collection of them (40-60 ms here) could come a second into the flight: a hitch in the window.
    The window collects before its first frame, so nothing young is left from start-up, and no
    full collection comes in the next 20 s of flight. (A fresh interpreter: the collector's state
    is the test's.)"""
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", FULL_COLLECTIONS], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    young, full, sim_s = done.stdout.split()
    assert int(young) < 200 and int(full) == 0 and float(sim_s) == 20.0, done.stdout
