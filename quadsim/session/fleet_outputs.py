"""A fleet's outputs: one fan-out per vehicle, each with the vehicle's name in front of its topics
(/alpha/quad/odom, TF frame alpha/base_link), joined into one (`FleetFanout`) that feeds one
recording and the live bridges; the latched messages the vehicles share go out once. Opened
together and always finished together, as a run of one vehicle's (`RecordedRun`).

A fleet's vehicles record no camera images yet: its runs are state-only.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from quadsim.errors import ConfigError
from quadsim.recording.contract import Names
from quadsim.recording.fanout import FleetFanout, TopicFanout
from quadsim.session.outputs import LiveOutput, OutputOptions, RunOutputs
from quadsim.session.stopping import shielded_from_signals

if TYPE_CHECKING:
    from quadsim.recording.writer import McapRecorder
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
    ) -> None:
        if options.cameras:
            raise ConfigError("a fleet's runs record no camera images yet: give OutputOptions(cameras=())")
        self.fleet = fleet
        self.options = options
        self.label = label
        self.run_info = run_info or {}
        self.description = fleet.description()
        self.recorder: McapRecorder | None = None
        self.path: Path | None = None
        self.live: list[LiveOutput] = list(live)
        hz = fleet.config.rates.physics_hz
        members = []
        for name, sim in fleet.vehicles.items():
            members.append(TopicFanout(hz, (), sim.vehicle, None, Names(name)))
        self.fanout = FleetFanout(members, fleet.client.world)
        self._listening = False
        try:
            self._start()
        except BaseException:
            self.close()
            raise

    def _step(self) -> int:
        return self.fleet.step_count

    def _recording_description(self) -> RunDescription:
        return self.description.with_outputs((), self.fleet.step_count, self.run_info)

    def _listen(self, on: bool) -> None:
        """Each vehicle's fan-out listens to its loop only while someone consumes them."""
        if on == self._listening:
            return
        self._listening = on
        for sim, member in zip(self.fleet.vehicles.values(), self.fanout.members):
            if on:
                sim.add_sink(member)
            else:
                sim.remove_sink(member)

    def close(self) -> None:
        with shielded_from_signals():  # a signal now must not cut the file short
            self._close_recording_and_live()

    def __enter__(self) -> FleetRecordedRun:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
