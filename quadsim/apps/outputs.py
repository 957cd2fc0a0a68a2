"""A run's outputs around a Simulator: the camera pipeline, the topic fan-out and the MCAP
recorder it feeds, opened together and always finished together (normal end, Ctrl-C, SIGTERM,
an exception).

The recorder's and the cameras' modules (and so mcap, foxglove, rosbags, cv2) are imported only
when a run records or has cameras.
"""

from __future__ import annotations

import signal
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from quadsim.recording.fanout import TopicFanout
from quadsim.sensors.camera import CameraSpec, RendererKind, default_cameras
from quadsim.sim.simulator import Simulator

if TYPE_CHECKING:
    from quadsim.recording.writer import McapRecorder
    from quadsim.sensors.pipeline import CameraPipeline


@dataclass(frozen=True)
class OutputOptions:
    record: bool = True
    out: Path | None = None  # a .mcap file, or a folder (default recordings/)
    cameras: tuple[CameraSpec, ...] = field(default_factory=default_cameras)
    renderer: RendererKind = RendererKind.TINY
    render_workers: int = 2  # 0: render in this process
    ordered_delivery: bool = True  # headless: frames in capture order at fixed points


class Terminated(KeyboardInterrupt):
    """SIGTERM, turned into an exception so the run unwinds and finishes its recording."""


def raise_on_sigterm() -> None:
    def handler(signum: int, frame: object) -> None:
        raise Terminated()

    signal.signal(signal.SIGTERM, handler)


class RecordedRun:
    """Cameras, topic fan-out and recorder for one simulator. Use as a context manager; `close`
    is idempotent.

    The fan-out (`fanout`) turns the run into the contract's messages once for every consumer;
    it listens to the loop and the cameras only while it has one. Recording can be stopped and
    started again (the window's key for it); each start makes a new file."""

    def __init__(
        self, sim: Simulator, options: OutputOptions, label: str, run_info: dict[str, Any] | None = None
    ) -> None:
        self.sim = sim
        self.options = options
        self.label = label
        self.run_info = run_info or {}
        self.recorder: McapRecorder | None = None
        self.cameras: CameraPipeline | None = None
        self.path: Path | None = None
        mounts = tuple((spec, sim.vehicle.camera_mount(spec.link_name)) for spec in options.cameras)
        self.fanout = TopicFanout(sim.config.rates.physics_hz, mounts)
        try:
            if options.cameras:
                from quadsim.sensors.pipeline import CameraPipeline

                self.cameras = CameraPipeline(
                    sim, options.cameras, options.renderer, options.render_workers, options.ordered_delivery
                )
            if options.record:
                self.start_recording()
        except BaseException:
            self.close()
            raise

    @property
    def recording(self) -> bool:
        return self.recorder is not None and not self.recorder.closed

    def start_recording(self) -> Path:
        """Open a new recording file and start writing to it."""
        if self.recording:
            raise RuntimeError("already recording")
        out = self.options.out
        if out is not None and out.suffix == ".mcap" and self.path is not None:
            out = out.parent  # --out FILE names the first recording; later ones go beside it
        from quadsim.recording.writer import McapRecorder, check_writable, recording_path

        path = recording_path(out, self.label)
        check_writable(path)
        info = {**self.run_info, "start_step": self.sim.step_count}
        recorder = McapRecorder(path, self.sim, self.options.cameras, info)
        self.fanout.add_consumer(recorder)
        self._listen(True)
        self.recorder, self.path = recorder, path
        return path

    def _listen(self, on: bool) -> None:
        """The fan-out listens to the loop and the cameras only while someone consumes it."""
        fanout, sinks = self.fanout, self.sim.loop.sinks
        camera_sinks = self.cameras.sinks if self.cameras is not None else []
        if on and fanout not in sinks:
            self.sim.add_sink(fanout)
            if self.cameras is not None:
                camera_sinks.append(fanout)
        elif not on:
            if fanout in sinks:
                sinks.remove(fanout)
            if fanout in camera_sinks:
                camera_sinks.remove(fanout)

    def note_event(self, step: int, kind: str, value: str) -> None:
        """An event the recording keeps (a z-mode switch) at `step`."""
        self.fanout.note_event(step, kind, value)

    def stop_recording(self) -> None:
        """Finish the current file (with the frames still being rendered)."""
        rec = self.recorder
        if rec is None or rec.closed:
            return
        if self.cameras is not None:
            self.cameras.drain()
        self.fanout.remove_consumer(rec)
        if not self.fanout.consumers:
            self._listen(False)
        rec.close()

    def close(self) -> None:
        try:
            if self.cameras is not None:
                try:
                    self.cameras.drain()  # the frames still being rendered belong in the file
                finally:
                    self.cameras.close()
        finally:
            if self.recorder is not None:
                self.fanout.remove_consumer(self.recorder)
                if not self.fanout.consumers:
                    self._listen(False)
                self.recorder.close()

    def __enter__(self) -> RecordedRun:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
