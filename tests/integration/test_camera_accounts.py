"""Frames honest under load: in a real-time run a camera frame is handed on as soon as it is in,
or its capture is dropped when every render worker is busy (never queued behind another), and
the run says what each camera delivered: the summary, /rosout (once when frames start to drop,
then the counts) and the window's HUD. A run that is not real-time keeps every frame."""

from __future__ import annotations

import subprocess
import sys

from quadsim import SimConfig, Simulator, Twist
from quadsim.recording.reader import RecordingReader
from quadsim.sensors.camera import CameraSpec
from quadsim.sensors.pipeline import CameraPipeline
from tests.helpers import ROOT

#: cameras no render worker keeps up with: 640x480 at 60 Hz, two of them, one worker
STARVED = ("--camera-size", "640x480", "--camera-hz", "60", "--render-workers", "1")


def test_a_capture_finding_its_worker_busy_is_dropped_and_counted():
    """Unordered (real time), one job a worker: captures coming faster than it renders are
    dropped, each counted to its camera; what is delivered plus what is dropped is what was asked."""
    spec = CameraSpec("front", "front_camera_link", 640, 480, rate_hz=60)
    with Simulator(SimConfig()) as sim:
        sim.send(Twist(linear_z=1.0))
        pipeline = CameraPipeline(sim.vehicle, sim.world, 240, (spec,), workers=1, ordered_delivery=False)
        try:
            for _ in range(50):  # back to back: far faster than a 640x480 render
                sim.step(4)
                pipeline.capture(sim.state)
            pipeline.drain()
        finally:
            pipeline.close()
    account = pipeline.accounts["front"]
    assert account.delivered + account.dropped == 50 and account.dropped > 25, vars(account)
    assert pipeline.frames_dropped == {"front": account.dropped}


def test_an_ordered_pipeline_drops_nothing_and_waits_for_nothing_to_poll():
    spec = CameraSpec("front", "front_camera_link", 64, 48, rate_hz=60)
    with Simulator(SimConfig()) as sim:
        pipeline = CameraPipeline(sim.vehicle, sim.world, 240, (spec,), workers=1, ordered_delivery=True)
        try:
            for _ in range(20):
                sim.step(4)
                pipeline.capture(sim.state)
                pipeline.poll()  # ordered: frames come at their fixed points, never early
            pipeline.drain()
        finally:
            pipeline.close()
    assert pipeline.accounts["front"].delivered == 20 and not pipeline.frames_dropped


def test_a_starved_real_time_run_says_what_its_cameras_delivered(tmp_path):
    """Real time with cameras no worker keeps up with: the flight keeps real time, the summary
    says each camera's delivered rate and the captures dropped, /rosout says so once while it
    flies and gives the counts as the recording ends."""
    out = tmp_path / "starved.mcap"
    done = subprocess.run(
        [
            sys.executable,
            str(ROOT / "main.py"),
            "run",
            "--script",
            "hover",
            "--duration",
            "2",
            "--realtime",
            *STARVED,
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    line = next(line for line in done.stdout.splitlines() if line.startswith("cameras "))
    assert "front " in line and "of 60 Hz" in line and " dropped, " in line and "after their capture (median)" in line
    dropped = int(line.split("; ")[1].split(" dropped")[0])
    assert dropped > 0, line
    with RecordingReader(out) as reader:
        said = [value for _, kind, value in reader.events if kind == "cameras"]
        frames = sum(1 for _ in reader.images("front"))
    assert said[0].startswith("dropping frames: the render workers cannot keep up")
    counts = said[-1].split(", ")[:2]  # "front N delivered", "M dropped": every capture of 2 s at 60 Hz
    delivered, dropped_front = int(counts[0].split()[1]), int(counts[1].split()[0])
    assert delivered + dropped_front == 120 and 0 < frames <= delivered, said[-1]


def test_a_run_that_is_not_real_time_keeps_every_frame(tmp_path):
    out = tmp_path / "all.mcap"
    done = subprocess.run(
        [
            sys.executable,
            str(ROOT / "main.py"),
            "run",
            "--script",
            "hover",
            "--duration",
            "0.5",
            *STARVED,
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "cameras         front 60.0 of 60 Hz, floor 60.0 of 60 Hz" in done.stdout
    with RecordingReader(out) as reader:
        assert sum(1 for _ in reader.images("front")) == 30 and not [e for e in reader.events if e[1] == "cameras"]
