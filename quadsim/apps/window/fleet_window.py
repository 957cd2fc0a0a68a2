"""What the teleop window needs of a fleet (`fly --fleet FILE.toml`): the fleet built with the
window's input driver flying one vehicle (the first whose input is the keyboard or a gamepad; with
none, the window watches the first vehicle), a second person's device flying the vehicle that
takes the other one (a keyboard vehicle and a gamepad vehicle: two people in one window), every
other vehicle driven by its own input, one
recording of them all, every vehicle's track for the map, and which vehicle's cameras are shown
(C cycles through the vehicles that have cameras)."""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping, Sequence
from typing import Any

from quadsim.core.types import VehicleState
from quadsim.drivers import InputDriver
from quadsim.sensors.camera import CameraSpec
from quadsim.sensors.pipeline import CameraPipeline
from quadsim.session.fleet_outputs import FleetRecordedRun
from quadsim.session.outputs import LiveOutput, OutputOptions
from quadsim.sim.config import SimConfig
from quadsim.sim.fleet import Fleet
from quadsim.sim.fleet_file import FleetFile


class Track:
    """A sink keeping the flown path for the map, at 10 Hz."""

    def __init__(self) -> None:
        self.points: deque[tuple[float, float]] = deque(maxlen=20000)

    def on_command(self, step: int, twist: object) -> None:
        pass

    def on_state(self, state: VehicleState) -> None:
        if state.step % 24 == 0:
            self.points.append(state.position_m[:2])


class WindowFleet:
    """The fleet of a fleet file, with `held` (the window's input driver) flying the first vehicle
    whose input is the keyboard or a gamepad, `second_hand` the vehicle that takes the other
    device (if one does); `drivers` give the others theirs."""

    def __init__(
        self,
        fleet_file: FleetFile,
        config: SimConfig,
        held: InputDriver,
        drivers: Mapping[str, InputDriver | None],
        flight_settings: dict[str, Any],
        second_hand: InputDriver | None = None,
    ) -> None:
        hands = fleet_file.held
        hand = hands[0] if hands else None
        #: the vehicle the window flies (or, with no keyboard or gamepad vehicle, watches)
        self.flown = hand.name if hand is not None else fleet_file.vehicles[0].name
        self.by_hand = hand is not None
        #: what flies each vehicle, as the fleet file says it ("script square", "ros2", "idle", ...)
        self.inputs = {v.name: v.input_text for v in fleet_file.vehicles}
        #: the vehicle the other device flies (the gamepad's, when the keyboard's is flown), or None
        self.second = hands[1].name if len(hands) > 1 and second_hand is not None else None
        by_hand: dict[str, InputDriver | None] = {self.flown: held} if hand is not None else {}
        if self.second is not None:
            by_hand[self.second] = second_hand
        self.fleet = Fleet(fleet_file.fleet_vehicles({**drivers, **by_hand}), config, **flight_settings)
        self.tracks = {name: Track() for name in self.fleet}
        for name, track in self.tracks.items():
            self.fleet[name].add_sink(track)
        self.cameras: dict[str, tuple[CameraSpec, ...]] = {}
        self.shown: str | None = None
        self.session: FleetRecordedRun | None = None

    def open_session(
        self,
        outputs: OutputOptions,
        label: str,
        run_info: dict[str, Any],
        live: Sequence[LiveOutput],
        cameras: Mapping[str, tuple[CameraSpec, ...]],
    ) -> FleetRecordedRun:
        self.cameras = {name: specs for name, specs in cameras.items() if specs}
        self.session = FleetRecordedRun(self.fleet, outputs, label, run_info, live=live, cameras=self.cameras)
        if self.cameras:
            self.shown = self.flown if self.flown in self.cameras else next(iter(self.cameras))
        return self.session

    @property
    def pipelines(self) -> dict[str, CameraPipeline]:
        return self.session.pipelines if self.session is not None else {}

    def show(self, name: str | None, sink: Any) -> None:
        """Hand `name`'s camera frames to `sink` (the window), and no other vehicle's."""
        for owner, pipeline in self.pipelines.items():
            if sink in pipeline.sinks:
                pipeline.sinks.remove(sink)
            if owner == name:
                pipeline.sinks.append(sink)
        self.shown = name

    def next_cameras(self) -> str | None:
        """The next vehicle with cameras after the one shown, in the fleet's order."""
        owners = list(self.cameras)
        if not owners:
            return None
        return owners[(owners.index(self.shown) + 1) % len(owners)] if self.shown in owners else owners[0]

    def camera_names(self) -> frozenset[str]:
        """The cameras of the vehicle whose cameras are shown."""
        return frozenset(spec.name for spec in self.cameras.get(self.shown or "", ()))

    def others(self) -> list[tuple[str, tuple[float, float], float, list[tuple[float, float]]]]:
        """(name, position, yaw, track) of every vehicle but the flown one, for the map."""
        return [
            (name, self.fleet[name].state.position_m[:2], self.fleet[name].state.yaw_rad(), list(track.points))
            for name, track in self.tracks.items()
            if name != self.flown
        ]

    def close(self) -> None:
        try:
            if self.session is not None:
                self.session.close()
        finally:
            self.fleet.close()
