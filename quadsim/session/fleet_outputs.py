"""A fleet's outputs: one fan-out per vehicle, each with the vehicle's name in front of its topics
(/alpha/quad/odom, TF frame alpha/base_link), joined into one (`FleetFanout`) that feeds one
recording and the live bridges; the latched messages the vehicles share go out once. Opened
together and always finished together, as a run of one vehicle's (`RecordedRun`).

Cameras are per vehicle (`cameras`: name -> its camera specs; a vehicle left out has none). They
render in this process, in the fleet's one PyBullet world at the moment of capture, so each
vehicle's cameras see the others where they are; what they cost is what the vehicles that have
them render.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from quadsim.errors import ConfigError
from quadsim.recording.contract import Names
from quadsim.recording.fanout import FleetFanout, TopicFanout
from quadsim.session.outputs import LiveOutput, OutputOptions, RunOutputs
from quadsim.session.stopping import shielded_from_signals

if TYPE_CHECKING:
    from quadsim.recording.writer import McapRecorder
    from quadsim.sensors.camera import CameraSpec
    from quadsim.sensors.pipeline import CameraPipeline
    from quadsim.sim.description import RunDescription
    from quadsim.sim.fleet import Fleet


class FleetRecordedRun(RunOutputs):
    """The topic fan-out of every vehicle of `fleet`, a recorder and live outputs, for one run.
    Use as a context manager; `close` is idempotent."""

    def __init__(
        self,
        fleet: Fleet,
        options: OutputOptions,
        label: str,
        run_info: dict[str, Any] | None = None,
        live: Sequence[LiveOutput] = (),
        cameras: Mapping[str, tuple[CameraSpec, ...]] | None = None,
    ) -> None:
        if options.cameras:
            raise ConfigError(
                "a fleet's cameras are each vehicle's: give them as cameras={name: specs}, with OutputOptions(cameras=())"
            )
        cameras = {name: specs for name, specs in (cameras or {}).items() if specs}
        unknown = sorted(set(cameras) - set(fleet.vehicles))
        if unknown:
            raise ConfigError(f"cameras for {unknown[0]!r}: no vehicle of that name in the fleet")
        self.fleet = fleet
        self.options = options
        self.label = label
        self.run_info = run_info or {}
        whole = fleet.description()
        members = tuple((name, replace(d, cameras=cameras.get(name, ()))) for name, d in whole.fleet)
        self.description = replace(whole, fleet=members)
        self.pipelines: dict[str, CameraPipeline] = {}
        self.recorder: McapRecorder | None = None
        self.path: Path | None = None
        self.live: list[LiveOutput] = list(live)
        hz = fleet.config.rates.physics_hz
        fanouts = []
        for name, sim in fleet.vehicles.items():
            mounts = tuple((spec, sim.vehicle.camera_mount(spec.link_name)) for spec in cameras.get(name, ()))
            fanouts.append(TopicFanout(hz, mounts, sim.vehicle, None, Names(name)))
        self.fanout = FleetFanout(fanouts, fleet.client.world)
        self._listening = False
        try:
            for name, specs in cameras.items():
                self._start_cameras(name, specs)
            self._start()
        except BaseException:
            self.close()
            raise

    def _start_cameras(self, name: str, specs: tuple[CameraSpec, ...]) -> None:
        """`name`'s cameras, rendered in the fleet's world when its taps capture."""
        from quadsim.sensors.camera import ImageKind, RendererKind
        from quadsim.sensors.pipeline import CameraPipeline, Companions

        sim = self.fleet[name]
        others = [other for other_name, other in self.fleet.vehicles.items() if other_name != name]
        worlds = tuple(other.physics for other in others)

        def poses() -> tuple:
            return tuple(world.pose for world in worlds)

        pipeline = CameraPipeline(
            sim.vehicle,
            self.fleet.client.world,
            self.fleet.config.rates.physics_hz,
            specs,
            RendererKind.TINY,  # EGL would draw in a client of its own, without the other vehicles
            workers=self.options.render_workers,
            ordered_delivery=self.options.ordered_delivery,
            scene_client=self.fleet.client.cid,
            companions=Companions(tuple(other.vehicle for other in others), poses),
        )
        pipeline.want(ImageKind.JPEG)
        self.pipelines[name] = pipeline
        sim.add_tap(pipeline.tap_interval_steps, pipeline.capture)

    def _drain(self) -> None:
        for pipeline in self.pipelines.values():
            pipeline.drain()

    def _step(self) -> int:
        return self.fleet.step_count

    def _recording_description(self) -> RunDescription:
        return self.description.with_outputs((), self.fleet.step_count, self.run_info)

    def _listen(self, on: bool) -> None:
        """Each vehicle's fan-out listens to its loop only while someone consumes them."""
        if on == self._listening:
            return
        self._listening = on
        for (name, sim), member in zip(self.fleet.vehicles.items(), self.fanout.members):
            pipeline = self.pipelines.get(name)
            if on:
                sim.add_sink(member)
                if pipeline is not None:
                    pipeline.sinks.append(member)
            else:
                sim.remove_sink(member)
                if pipeline is not None and member in pipeline.sinks:
                    pipeline.sinks.remove(member)

    def close(self) -> None:
        with shielded_from_signals():  # a signal now must not cut the file short
            try:
                for name, pipeline in self.pipelines.items():
                    self.fleet[name].remove_tap(pipeline.capture)
                    try:
                        pipeline.drain()
                    finally:
                        pipeline.close()
            finally:
                self._close_recording_and_live()

    def __enter__(self) -> FleetRecordedRun:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
