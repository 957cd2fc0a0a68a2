"""A recording is in log-time order, camera frames included (they are rendered elsewhere and
come late), and one started mid-run begins when it began."""

from __future__ import annotations

import itertools

from mcap.reader import make_reader

from quadsim import SimConfig, Simulator, Twist, ZMode
from quadsim.recording.info import read_info
from quadsim.sensors.camera import default_cameras
from quadsim.session.outputs import OutputOptions, RecordedRun


def _raw_log_times(path) -> list[tuple[str, int]]:
    """(topic, log time) in the order the messages sit in the file."""
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        return [(channel.topic, message.log_time) for _, channel, message in reader.iter_messages(log_time_order=False)]


def test_messages_are_written_in_log_time_order_with_render_workers(tmp_path):
    path = tmp_path / "ordered.mcap"
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT)) as sim:
        options = OutputOptions(out=path, cameras=default_cameras(64, 48, 30), render_workers=2)
        with RecordedRun(sim, options, "ordered"):
            sim.send(Twist(linear_x=0.5))
            sim.run_for(3.0)
    found = _raw_log_times(path)
    times = [ns for _, ns in found]
    late = sum(1 for a, b in itertools.pairwise(times) if b < a)
    assert late == 0, f"{late} messages written after later-stamped ones"
    assert sum(1 for topic, _ in found if topic.endswith("/image_raw/compressed")) == 2 * 90


def test_a_recording_started_mid_run_begins_when_it_began(tmp_path):
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT)) as sim:
        options = OutputOptions(record=False, out=tmp_path, cameras=default_cameras(64, 48, 30), render_workers=2)
        with RecordedRun(sim, options, "late") as run:
            sim.send(Twist())
            sim.run_for(5.0)  # frames are in flight when recording starts
            path = run.start_recording()
            sim.run_for(2.0)
    info = read_info(path)
    assert info.start_s >= 5.0 - 1e-9 and info.end_s <= 7.0 + 1e-9, (info.start_s, info.end_s)
    assert 1.9 < info.duration_s <= 2.0
    times = [ns for _, ns in _raw_log_times(path)]
    assert min(times) >= 5_000_000_000 and times == sorted(times)
    camera = next(t for t in info.topics if t.name == "/quad/front_camera/image_raw/compressed")
    assert 55 <= camera.count <= 61 and abs(camera.rate_hz - 30.0) < 1.0


class _Delivered:
    """A frame sink that notes at which loop step each frame was handed on."""

    def __init__(self) -> None:
        self.now = 0
        self.lags: list[int] = []  # steps from a frame's capture to its delivery

    def on_camera_frame(self, frame) -> None:
        self.lags.append(self.now - frame.step)


def test_ordered_frames_come_within_the_ordered_lag_whatever_the_camera_rate():
    """Headless runs hand a frame on a fixed number of captures after its own: at most
    ORDERED_LAG_S of simulated time, which bounds how long the recorder holds the rest back (what
    a killed run loses). A 2 Hz camera's frame comes at its own capture (it waited 2 s before)."""
    from quadsim.sensors.camera import CameraSpec
    from quadsim.sensors.pipeline import ORDERED_LAG_S, CameraPipeline

    lag_steps = ORDERED_LAG_S * 240
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT)) as sim:
        for rate_hz, captures_behind in ((30, 4), (10, 2), (2, 0)):
            spec = CameraSpec("front", "front_camera_link", width_px=32, height_px=24, rate_hz=rate_hz)
            pipe = CameraPipeline(sim.vehicle, sim.world, 240, (spec,), workers=2)
            sink = _Delivered()
            pipe.sinks.append(sink)
            try:
                state = sim.state
                for step in range(0, 240 * 3, pipe.tap_interval_steps):
                    sink.now = step
                    pipe.capture(state._replace(step=step))
            finally:
                pipe.close()
            every = 240 // rate_hz
            assert sink.lags and set(sink.lags) == {captures_behind * every}, (rate_hz, set(sink.lags))
            assert max(sink.lags) <= lag_steps
