"""Who flies what in the teleop window, for a run of one vehicle or a fleet (`fly --fleet`): the
vehicle the window flies (a fleet's first whose input is the keyboard or a gamepad; with none,
the window watches the first vehicle), the vehicle a second person's device flies (a keyboard
vehicle and a gamepad vehicle: two people in one window), what flies the others, every vehicle's
track for the map, and whose cameras are shown (C cycles through the vehicles that have some)."""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping

from quadsim.core.types import VehicleState
from quadsim.sensors.camera import CameraSpec
from quadsim.sensors.pipeline import CameraPipeline, FrameSink
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


class WindowVehicles:
    """The window's vehicles: the one flown by hand (`flown`; "" for a run of one vehicle), the
    second person's (`second`), what flies each (`inputs`), their tracks and cameras."""

    def __init__(self, fleet_file: FleetFile | None, second_hand: bool) -> None:
        hands = fleet_file.held if fleet_file is not None else ()
        first = fleet_file.vehicles[0].name if fleet_file is not None else ""
        #: the vehicle the window flies (or, with no keyboard or gamepad vehicle in a fleet, watches)
        self.flown = hands[0].name if hands else first
        self.by_hand = fleet_file is None or bool(hands)
        #: what flies each vehicle of a fleet, as its file says ("script square", "ros2", "idle", ...)
        self.inputs = {v.name: v.input_text for v in fleet_file.vehicles} if fleet_file is not None else {}
        #: the vehicle the other device flies (the gamepad's, when the keyboard's is flown), or None
        self.second = hands[1].name if len(hands) > 1 and second_hand else None
        self.is_fleet = fleet_file is not None
        self.tracks: dict[str, Track] = {}
        self.cameras: dict[str, tuple[CameraSpec, ...]] = {}
        self.pipelines: dict[str, CameraPipeline] = {}
        self.shown: str | None = None
        self._fleet: Fleet | None = None

    def attach(self, fleet: Fleet, pipelines: Mapping[str, CameraPipeline]) -> None:
        """Follow `fleet`'s vehicles (a track each) and their camera pipelines; show the flown
        vehicle's cameras (else the first vehicle's that has some)."""
        self._fleet = fleet
        self.tracks = {name: Track() for name in fleet}
        for name, track in self.tracks.items():
            fleet[name].add_sink(track)
        self.pipelines = dict(pipelines)
        self.cameras = {name: pipeline.specs for name, pipeline in self.pipelines.items() if pipeline.specs}
        if self.cameras:
            self.shown = self.flown if self.flown in self.cameras else next(iter(self.cameras))

    def show(self, name: str | None, sink: FrameSink) -> None:
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
        fleet = self._fleet
        if fleet is None:
            return []
        return [
            (name, fleet[name].state.position_m[:2], fleet[name].state.yaw_rad(), list(track.points))
            for name, track in self.tracks.items()
            if name != self.flown
        ]
