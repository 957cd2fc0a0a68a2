"""A run's outputs: the camera pipeline, the topic fan-out and what it feeds (the MCAP recorder,
live bridges), opened together and always finished together (normal end, Ctrl-C, SIGTERM, an exception).

They attach to the run through its OutputPort (the Simulator is one) and know it by its typed
RunDescription: they never hold the simulator. The recorder's and the cameras' modules (and so
mcap, foxglove, rosbags, cv2) are imported only when a run records or has cameras.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from quadsim.errors import QuadsimError
from quadsim.recording.fanout import TopicConsumer, TopicFanout
from quadsim.sensors.camera import CameraSpec, RendererKind, default_cameras
from quadsim.session.stopping import shielded_from_signals
from quadsim.sim.description import RunDescription
from quadsim.sim.loop import OutputPort

#: the kind of the events that say a recording started or stopped (on /rosout: "recording: started")
RECORDING_EVENT = "recording"

if TYPE_CHECKING:
    from quadsim.recording.writer import McapRecorder
    from quadsim.sensors.pipeline import CameraPipeline
    from quadsim.sim.cameras import Cameras
    from quadsim.sim.simulator import Simulator


class LiveOutput(TopicConsumer, Protocol):
    """A live bridge (Foxglove, ROS 2): fed by the fan-out for the whole run, closed with it."""

    def close(self) -> None: ...


@dataclass(frozen=True)
class OutputOptions:
    record: bool = True
    out: Path | None = None  # a .mcap file, or a folder (default: quadsim.recording.paths.default_recordings_dir())
    cameras: tuple[CameraSpec, ...] = field(default_factory=default_cameras)
    renderer: RendererKind = RendererKind.TINY
    render_workers: int = 2  # 0: render in this process
    ordered_delivery: bool = True  # headless: frames in capture order at fixed points


class RunOutputs:
    """What every run's outputs do alike, a run of one vehicle's (RecordedRun) and a fleet's
    (session.fleet_outputs): recording files that start and stop on request, each saying so on
    /rosout, and live outputs closed with the run. A subclass sets `fanout` (what the recorder and
    the live outputs consume), says where the run's clock is (`_step`), what a recording's
    description is, and when the fan-out listens to the run (`_listen`)."""

    options: OutputOptions
    label: str
    run_info: dict[str, Any]
    fanout: Any  # a TopicFanout or a FleetFanout
    recorder: McapRecorder | None
    path: Path | None
    live: list[LiveOutput]
    cameras: CameraPipeline | None = None  # the run's one camera pipeline (a fleet's are its vehicles')

    def _step(self) -> int:
        raise NotImplementedError

    def _recording_description(self) -> RunDescription:
        raise NotImplementedError

    def _listen(self, on: bool) -> None:
        raise NotImplementedError

    def _drain(self) -> None:
        """Wait for what is still being made for the recording (camera frames)."""

    def _start(self) -> None:
        """Feed the live outputs from now on, and start recording if asked to."""
        for output in self.live:
            self.fanout.add_consumer(output, self._step())
        if self.live:
            self._listen(True)
        if self.options.record:
            self.start_recording()

    @property
    def recording(self) -> bool:
        return self.recorder is not None and not self.recorder.closed

    def start_recording(self) -> Path:
        """Open a new recording file and start writing to it."""
        if self.recording:
            raise RuntimeError("already recording")
        out = self.options.out
        from quadsim.recording.writer import McapRecorder, check_writable, recording_path

        if out is not None and out.suffix == ".mcap" and self.path is not None:
            # --out FILE names the first recording; later ones (F5, a reset) FILE-2.mcap, FILE-3.mcap...
            path = next(p for n in range(2, 10**6) if not (p := out.with_name(f"{out.stem}-{n}.mcap")).exists())
        else:
            path = recording_path(out, self.label)
        check_writable(path)
        recorder = McapRecorder(path, self._recording_description())
        self.fanout.add_consumer(recorder, self._step())
        self._listen(True)
        self.recorder, self.path = recorder, path
        self.note_event(self._step(), RECORDING_EVENT, "started")
        return path

    def note_event(self, step: int, kind: str, value: str) -> None:
        """An event the recording keeps (a z-mode switch, an input device change, recording
        started or stopped) at `step`: the one way events reach /rosout."""
        self.fanout.note_event(step, kind, value)

    def stop_recording(self) -> None:
        """Finish the current file (with what is still being made for it)."""
        rec = self.recorder
        if rec is None or rec.closed:
            return
        with shielded_from_signals():  # a signal now must not cut the file short
            self._drain()
            self._finish(rec)

    def _finish(self, rec: McapRecorder) -> None:
        """Say in the file that recording stops, and close it."""
        if not rec.closed:
            self.note_event(self._step(), RECORDING_EVENT, "stopped")
        self.fanout.remove_consumer(rec)
        if not self.fanout.consumers:
            self._listen(False)
        rec.close()

    def _close_recording_and_live(self) -> None:
        try:
            if self.recorder is not None:
                self._finish(self.recorder)
        finally:
            for output in self.live:
                self.fanout.remove_consumer(output)
                output.close()
            self._listen(bool(self.fanout.consumers))


class RecordedRun(RunOutputs):
    """Cameras, topic fan-out and recorder for one run. Use as a context manager; `close` is
    idempotent.

    The fan-out (`fanout`) turns the run into the contract's messages once for every consumer;
    it listens to the loop and the cameras only while it has one. Recording can be stopped and
    started again (the window's key for it); each start makes a new file. The `live` outputs
    (bridges) consume it from the start to the end of the run, recording or not, and are closed
    with it.

    `cameras`: record the frames of a camera pipeline that is already capturing (that of
    quadsim.Cameras, SYNC or PIPELINED) instead of starting one from `options.cameras`; the
    run then leaves it running when it closes."""

    def __init__(
        self,
        port: OutputPort,
        description: RunDescription,
        options: OutputOptions,
        label: str,
        run_info: dict[str, Any] | None = None,
        cameras: CameraPipeline | None = None,
        live: Sequence[LiveOutput] = (),
    ) -> None:
        self.port = port
        self.description = description
        self.options = options
        self.label = label
        self.run_info = run_info or {}
        self.recorder: McapRecorder | None = None
        self.cameras: CameraPipeline | None = cameras
        self._own_cameras = cameras is None
        self.path: Path | None = None
        self.live: list[LiveOutput] = list(live)
        vehicle, world = description.vehicle_model, description.world_model
        if vehicle is None or world is None:
            raise QuadsimError("outputs need the description of a live run (with its vehicle and world)")
        self.camera_specs = options.cameras if cameras is None else cameras.specs
        mounts = tuple((spec, vehicle.camera_mount(spec.link_name)) for spec in self.camera_specs)
        self.fanout = TopicFanout(description.config.rates.physics_hz, mounts, vehicle, world)
        self._listening = False
        try:
            if cameras is not None:
                from quadsim.sensors.camera import ImageKind

                cameras.want(ImageKind.JPEG)
            elif options.cameras:
                from quadsim.sensors.pipeline import CameraPipeline

                self.cameras = CameraPipeline(
                    vehicle,
                    world,
                    description.config.rates.physics_hz,
                    options.cameras,
                    options.renderer,
                    options.render_workers,
                    options.ordered_delivery,
                    scene_client=port.scene_client,
                )
                port.add_tap(self.cameras.tap_interval_steps, self.cameras.capture)
            self._start()
        except BaseException:
            self.close()
            raise

    def _step(self) -> int:
        return self.port.step_count

    def _recording_description(self) -> RunDescription:
        return self.description.with_outputs(self.camera_specs, self.port.step_count, self.run_info)

    def _drain(self) -> None:
        if self.cameras is not None:
            self.cameras.drain()

    def _listen(self, on: bool) -> None:
        """The fan-out listens to the loop and the cameras only while someone consumes it."""
        if on == self._listening:
            return
        self._listening = on
        fanout = self.fanout
        if on:
            self.port.add_sink(fanout)
            if self.cameras is not None:
                self.cameras.sinks.append(fanout)
        else:
            self.port.remove_sink(fanout)
            if self.cameras is not None and fanout in self.cameras.sinks:
                self.cameras.sinks.remove(fanout)

    def close(self) -> None:
        with shielded_from_signals():  # a signal now must not cut the file short
            try:
                if self.cameras is not None:
                    if self._own_cameras:
                        self.port.remove_tap(self.cameras.capture)
                    try:
                        self.cameras.drain()  # the frames still being rendered belong in the file
                    finally:
                        if self._own_cameras:
                            self.cameras.close()
            finally:
                self._close_recording_and_live()

    def __enter__(self) -> RecordedRun:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def record(
    sim: Simulator, out: Path | str | None = None, cameras: Cameras | None = None, label: str = "api"
) -> RecordedRun:
    """Record `sim` from now on to `out` (a .mcap file or a folder; default: the recordings
    folder), with the frames of `cameras` if given (SYNC or PIPELINED alike). Close it (or use
    it as a context manager) to finish the file."""
    options = OutputOptions(out=None if out is None else Path(out), cameras=())
    return RecordedRun(sim, sim.description(), options, label, cameras=None if cameras is None else cameras.pipeline)
