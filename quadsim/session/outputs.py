"""A run's outputs: each vehicle's camera pipeline, the run's topic fan-out and what it feeds (the
MCAP recorder, live bridges), opened together and always finished together (normal end, Ctrl-C,
SIGTERM, an exception).

A run is a fleet (a run of one vehicle is a fleet of one): each vehicle's producer attaches to
that vehicle through its sinks and taps, under the vehicle's names
(/alpha/quad/odom; a vehicle flying alone has the contract's own), and the outputs know the run by
its typed RunDescription. Cameras are per vehicle; in a fleet they render the others where they
are. The recorder's and the cameras' modules (and so mcap, foxglove, rosbags, cv2) are imported
only when a run records or has cameras.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from quadsim.errors import ConfigError
from quadsim.recording.contract import Names
from quadsim.recording.fanout import TopicConsumer, TopicFanout, VehicleTopics
from quadsim.sensors.camera import CameraSpec, ImageKind, RendererKind, default_cameras
from quadsim.session.stopping import shielded_from_signals
from quadsim.sim.description import RunDescription
from quadsim.sim.fleet import Fleet

#: the kind of the events that say a recording started or stopped (on /rosout: "recording: started")
RECORDING_EVENT = "recording"

if TYPE_CHECKING:
    from quadsim.recording.writer import McapRecorder
    from quadsim.sensors.pipeline import CameraPipeline
    from quadsim.sim.cameras import Cameras
    from quadsim.sim.drone import Drone


class LiveOutput(TopicConsumer, Protocol):
    """A live bridge (Foxglove, ROS 2): fed by the fan-out for the whole run, closed with it."""

    def close(self) -> None: ...


@dataclass(frozen=True)
class OutputOptions:
    record: bool = True
    out: Path | None = None  # a .mcap file, or a folder (default: quadsim.recording.paths.default_recordings_dir())
    #: the cameras of a run of one vehicle (a fleet's are each vehicle's: RecordedRun's `cameras`)
    cameras: tuple[CameraSpec, ...] = field(default_factory=default_cameras)
    renderer: RendererKind = RendererKind.TINY
    render_workers: int = 2  # 0: render in this process
    ordered_delivery: bool = True  # headless: frames in capture order at fixed points


class RecordedRun:
    """Each vehicle's cameras and topics, the run's fan-out, its recorder and live outputs, for one
    run (of one vehicle or a fleet). Use as a context manager; `close` is idempotent.

    The fan-out (`fanout`) turns the run into the contract's messages once for every consumer;
    the vehicles' producers listen to their vehicles and cameras only while it has one. Recording
    can be stopped and started again (the window's key for it); each start makes a new file. The
    `live` outputs (bridges) consume it from the start to the end of the run, recording or not,
    and are closed with it.

    `cameras`: each vehicle's camera specs by name (a vehicle left out has none); None: a run of
    one vehicle has `options.cameras`. `pipeline`: record the frames of a camera pipeline that is
    already capturing the one vehicle (that of quadsim.Cameras, SYNC or PIPELINED) instead; the
    run then leaves it running when it closes."""

    def __init__(
        self,
        fleet: Fleet,
        options: OutputOptions,
        label: str,
        run_info: dict[str, Any] | None = None,
        live: Sequence[LiveOutput] = (),
        cameras: Mapping[str, tuple[CameraSpec, ...]] | None = None,
        pipeline: CameraPipeline | None = None,
    ) -> None:
        self.fleet = fleet
        self.options = options
        self.label = label
        self.run_info = run_info or {}
        self.recorder: McapRecorder | None = None
        self.path: Path | None = None
        self.live: list[LiveOutput] = list(live)
        specs = self._camera_specs(cameras, pipeline)
        self.description = _with_cameras(fleet.description(), specs)
        hz = fleet.config.rates.physics_hz
        self.fanout = TopicFanout(hz, fleet.world)
        #: each vehicle's producer, by name
        self.topics: dict[str, VehicleTopics] = {}
        for drone in fleet.members:
            mounts = tuple((spec, drone.vehicle.camera_mount(spec.link_name)) for spec in specs.get(drone.name, ()))
            self.topics[drone.name] = self.fanout.add_vehicle(
                Names(drone.name),
                mounts,
                drone.vehicle,
                None
                if (r := drone.range_finder) is None
                else replace(drone.vehicle.range_finder, noise_std_m=r.noise_std_m),
                drone.config.lidar,
            )
        #: each vehicle's camera pipeline, by name (those with cameras)
        self.pipelines: dict[str, CameraPipeline] = {}
        self._said_dropping: set[str] = set()  # the vehicles whose dropped frames /rosout has heard of
        self._own_pipelines = pipeline is None
        self._listening = False
        try:
            if pipeline is not None:
                self.pipelines[fleet.members[0].name] = pipeline
            for name, own in specs.items():
                if own and pipeline is None:
                    self._start_cameras(fleet[name], own)
            for started in self.pipelines.values():
                started.want(ImageKind.JPEG)
            self._start()
        except BaseException:
            self.close()
            raise

    def _camera_specs(
        self, cameras: Mapping[str, tuple[CameraSpec, ...]] | None, pipeline: CameraPipeline | None
    ) -> dict[str, tuple[CameraSpec, ...]]:
        """Each vehicle's cameras, checked: by name, or the one vehicle's from the options."""
        fleet, options = self.fleet, self.options
        if pipeline is not None or cameras is None:
            if len(fleet) > 1 and (pipeline is not None or options.cameras):
                raise ConfigError(
                    "a fleet's cameras are each vehicle's: give them as cameras={name: specs}, with OutputOptions(cameras=())"
                )
            specs = pipeline.specs if pipeline is not None else options.cameras
            return {fleet.members[0].name: specs} if specs else {}
        if options.cameras:
            raise ConfigError("cameras={name: specs} are each vehicle's: give OutputOptions(cameras=()) with them")
        unknown = sorted(set(cameras) - set(fleet.vehicles))
        if unknown:
            raise ConfigError(f"cameras for {unknown[0]!r}: no vehicle of that name in the fleet")
        if len(fleet) > 1 and options.renderer is not RendererKind.TINY and any(cameras.values()):
            raise ConfigError(
                f"renderer {options.renderer.value}: a fleet's cameras render in its one world (tiny), "
                "where they see the other vehicles"
            )
        return {name: specs for name, specs in cameras.items() if specs}

    def _start_cameras(self, drone: Drone, specs: tuple[CameraSpec, ...]) -> None:
        """`drone`'s cameras, rendered in the run's world when its taps capture (in a fleet, the
        other vehicles drawn where they are)."""
        from quadsim.sensors.pipeline import CameraPipeline, Companions

        fleet, options = self.fleet, self.options
        others = [other for other in fleet.members if other is not drone]
        bodies = tuple(other.physics for other in others)

        def poses() -> tuple:
            return tuple(body.pose for body in bodies)

        pipeline = CameraPipeline(
            drone.vehicle,
            fleet.world,
            fleet.config.rates.physics_hz,
            specs,
            options.renderer,
            workers=options.render_workers,
            ordered_delivery=options.ordered_delivery,
            scene_client=fleet.scene_client,
            companions=Companions(tuple(other.vehicle for other in others), poses, fleet.members.index(drone))
            if others
            else None,
        )
        self.pipelines[drone.name] = pipeline
        drone.add_tap(pipeline.tap_interval_steps, pipeline.capture)

    @property
    def cameras(self) -> CameraPipeline | None:
        """The camera pipeline of a run of one vehicle (None: it has no cameras; a fleet's are
        `pipelines`, by vehicle)."""
        return next(iter(self.pipelines.values()), None) if len(self.fleet) == 1 else None

    def _start(self) -> None:
        """Feed the live outputs from now on, and start recording if asked to."""
        for output in self.live:
            self.fanout.add_consumer(output, self.fleet.step_count)
        if self.live:
            self._listen(True)
        if self.options.record:
            self.start_recording()

    def _listen(self, on: bool) -> None:
        """Each vehicle's producer listens to its vehicle and cameras only while someone consumes the fan-out."""
        if on == self._listening:
            return
        self._listening = on
        for drone in self.fleet.members:
            topics, pipeline = self.topics[drone.name], self.pipelines.get(drone.name)
            sources = (
                (drone.loop, topics),
                (pipeline, topics),
                (drone.range_finder, topics.on_range),
                (drone.lidar, topics.on_scan),
            )
            for source, sink in sources:
                sinks: list[Any] = [] if source is None else source.sinks
                if on:
                    sinks.append(sink)
                elif sink in sinks:
                    sinks.remove(sink)

    # --- recording ------------------------------------------------------------------------------

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
        step = self.fleet.step_count
        recorder = McapRecorder(path, self.description.with_outputs(self.description.cameras, step, self.run_info))
        self.fanout.add_consumer(recorder, step)
        self._listen(True)
        self.recorder, self.path = recorder, path
        self.note_event(step, RECORDING_EVENT, "started")
        return path

    def note_event(self, step: int, kind: str, value: str, vehicle: str = "") -> None:
        """An event the recording keeps (a z-mode switch, an input device change, recording
        started or stopped) at `step`: the one way events reach /rosout. `vehicle`: the vehicle
        it is about (a z-mode switch, which a re-flight replays on that vehicle), else the run's."""
        if vehicle:
            self.topics[vehicle].note_event(step, kind, value)
        else:
            self.fanout.note_event(step, kind, value)

    def stop_recording(self) -> None:
        """Finish the current file (with what is still being made for it)."""
        rec = self.recorder
        if rec is None or rec.closed:
            return
        with shielded_from_signals():  # a signal now must not cut the file short
            self.drain()
            self._finish(rec)

    def poll(self) -> None:
        """Hand on the camera frames that are ready (real-time runs: as soon as they are in), and
        say on /rosout, once for each vehicle, that its cameras drop frames."""
        for name, pipeline in self.pipelines.items():
            pipeline.poll()
            if name not in self._said_dropping and any(a.dropped for a in pipeline.accounts.values()):
                self._said_dropping.add(name)
                self.note_event(
                    self.fleet.step_count,
                    "cameras",
                    "dropping frames: the render workers cannot keep up with the cameras' rate (a busy "
                    "machine, or too many pixels); the run's summary counts them",
                    vehicle=name,
                )

    def _say_camera_counts(self) -> None:
        """What each vehicle's cameras delivered, on /rosout, as a recording ends, where some
        dropped or were late (a headless run that is not real-time keeps every frame: nothing to say)."""
        for name, pipeline in self.pipelines.items():
            if not any(a.dropped or a.late for a in pipeline.accounts.values()):
                continue
            counts = ", ".join(
                f"{camera} {a.delivered} delivered, {a.dropped} dropped, {a.late} late"
                for camera, a in pipeline.accounts.items()
            )
            self.note_event(self.fleet.step_count, "cameras", counts, vehicle=name)

    def drain(self) -> None:
        """Wait for what is still being made for the recording (camera frames)."""
        for pipeline in self.pipelines.values():
            pipeline.drain()

    def _finish(self, rec: McapRecorder) -> None:
        """Say in the file what the cameras delivered (where they fell short) and that recording
        stops, and close it."""
        if not rec.closed:
            self._say_camera_counts()
            self.note_event(self.fleet.step_count, RECORDING_EVENT, "stopped")
        self.fanout.remove_consumer(rec)
        if not self.fanout.consumers:
            self._listen(False)
        rec.close()

    # --- lifetime -------------------------------------------------------------------------------

    def close(self) -> None:
        with shielded_from_signals():  # a signal now must not cut the file short
            try:
                for name, pipeline in self.pipelines.items():
                    if self._own_pipelines:
                        self.fleet[name].remove_tap(pipeline.capture)
                    try:
                        pipeline.drain()  # the frames still being rendered belong in the file
                    finally:
                        if self._own_pipelines:
                            pipeline.close()
            finally:
                try:
                    if self.recorder is not None:
                        self._finish(self.recorder)
                finally:
                    for output in self.live:
                        self.fanout.remove_consumer(output)
                        output.close()
                    self._listen(bool(self.fanout.consumers))

    def __enter__(self) -> RecordedRun:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _with_cameras(description: RunDescription, cameras: Mapping[str, tuple[CameraSpec, ...]]) -> RunDescription:
    """The run's description with each vehicle's cameras (a fleet's in its vehicles' parts)."""
    if not description.fleet:
        return replace(description, cameras=next(iter(cameras.values()), ()))
    members = tuple((name, replace(d, cameras=cameras.get(name, ()))) for name, d in description.fleet)
    return replace(description, fleet=members)


def record(
    sim: Fleet, out: Path | str | None = None, cameras: Cameras | None = None, label: str = "api"
) -> RecordedRun:
    """Record `sim` (a Simulator, or a Fleet) from now on to `out` (a .mcap file or a folder;
    default: the recordings folder), with the frames of `cameras` if given (SYNC or PIPELINED
    alike). Close it (or use it as a context manager) to finish the file."""
    options = OutputOptions(out=None if out is None else Path(out), cameras=())
    return RecordedRun(sim, options, label, pipeline=None if cameras is None else cameras.pipeline)
