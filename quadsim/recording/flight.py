"""A recording loaded whole for playback and re-simulation: states, commands, camera frames,
the run's parameters, events and attachments.

Foreign files load too (playback shows what is there), and so do damaged ones: what could not be
read is listed in `damage` and `notes`, and `lost_for_resim` says whether the flight can still be
flown again faithfully.
"""

from __future__ import annotations

import math
import struct
from bisect import bisect_right
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from quadsim.core.kinematics import matrix_from_quaternion, rotate
from quadsim.core.types import Twist, VehicleState, ZMode
from quadsim.errors import QuadsimError
from quadsim.recording import contract as rm
from quadsim.recording.mcap_scan import Damage
from quadsim.recording.reader import RecordingReader
from quadsim.sim.description import RunDescription

NS = 1_000_000_000


@dataclass
class RecordedFlight:
    """Filled once by `load_flight`; its lookups index the loaded lists on first use."""

    path: Path
    description: RunDescription | None  # None: not a quadsim recording, or its parameters are unreadable
    physics_hz: int
    states: list[VehicleState] = field(default_factory=list)
    state_ns: list[int] = field(default_factory=list)
    body_velocities: list[tuple[float, float, float]] = field(default_factory=list)  # as /quad/odom has them
    commands: list[tuple[int, Twist]] = field(default_factory=list)  # (log time ns, twist)
    #: camera -> (ns, jpeg); with `load_flights(depth=True)`, also CAMERA_depth: its depth images
    #: colour-mapped (quadsim.sensors.images.depth_colour_mapped), as JPEG
    frames: dict[str, list[tuple[int, bytes]]] = field(default_factory=dict)
    #: the range finder's and the LiDAR's readings by contract topic (/quad/range, /quad/scan,
    #: /quad/points, whatever the vehicle's name): (log time ns, its message's ranges as float32 or,
    #: for points, its bytes)
    ranging: dict[str, list[tuple[int, bytes]]] = field(default_factory=dict)
    events: list[tuple[int, str, str]] = field(default_factory=list)  # (step, kind, value)
    attachments: dict[str, bytes] = field(default_factory=dict)
    topics: dict[str, int] = field(default_factory=dict)  # topic -> message count
    start_ns: int = 0  # the first message's log time (later than 0: recorded from part-way, F5)
    end_ns: int = 0
    description_error: str | None = None  # why the run's parameters could not be read, if so
    damage: list[Damage] = field(default_factory=list)  # what is wrong with the file (chunks skipped...)
    damage_report: str = ""  # the damage in one line, as `info` says it: what is readable, what to run
    notes: list[str] = field(default_factory=list)  # what was not read though the file is sound there
    bad_events: list[str] = field(default_factory=list)  # event records that are malformed
    undecodable: dict[str, int] = field(default_factory=dict)  # topic -> messages that did not decode
    vehicle: str = ""  # in a fleet's recording, the vehicle's name (its topics have it in front)
    fleet: RunDescription | None = None  # in a fleet's recording, the whole run's description

    @property
    def duration_s(self) -> float:
        return self.end_ns / NS

    def step_of(self, ns: int) -> int:
        """The physics step a log time was stamped at (stamps are floor(step * 1e9 / hz))."""
        return round(ns * self.physics_hz / NS)

    def command_steps(self) -> list[tuple[int, Twist]]:
        return [(self.step_of(ns), t) for ns, t in self.commands]

    def state_at(self, ns: int) -> VehicleState | None:
        i = bisect_right(self.state_ns, ns) - 1
        return self.states[i] if i >= 0 else None

    @cached_property
    def _command_ns(self) -> list[int]:
        return [c[0] for c in self.commands]

    @cached_property
    def _frame_ns(self) -> dict[str, list[int]]:
        return {cam: [f[0] for f in frames] for cam, frames in self.frames.items()}

    def command_at(self, ns: int) -> Twist | None:
        i = bisect_right(self._command_ns, ns) - 1
        return self.commands[i][1] if i >= 0 else None

    def warnings(self) -> list[str]:
        """What a person replaying the file should know: damage and what was skipped."""
        out = [d.describe() for d in self.damage] + list(self.notes)
        out += [f"{n} messages on {topic} do not decode: skipped" for topic, n in sorted(self.undecodable.items())]
        return out

    def _needed_topics(self) -> set[str]:
        """What a re-flight reads: the commands and the states (under the vehicle's name in a fleet)."""
        names = rm.Names(self.vehicle)
        return {names.topic(t).name for t in (rm.TWIST, *rm.STATE_TOPICS)}

    def lost_for_resim(self) -> str | None:
        """The damage that cost recorded commands or states, if any: then the flight cannot be
        flown again faithfully (a damaged chunk of camera images alone does not matter)."""
        needed = self._needed_topics()
        for d in self.damage:
            if d.loses == "messages" and (d.topics is None or needed & set(d.topics)):
                return d.describe()
        return None

    def unreadable_for_resim(self) -> str | None:
        """Commands, states or events present but unreadable, if any (a crafted or foreign file)."""
        needed = self._needed_topics()
        for topic in sorted(needed & self.undecodable.keys()):
            return f"{self.undecodable[topic]} messages on {topic} do not decode"
        if self.bad_events:
            return self.bad_events[0]
        return None

    def frame_at(self, camera: str, ns: int) -> tuple[int, bytes] | None:
        i = bisect_right(self._frame_ns.get(camera, []), ns) - 1
        return self.frames[camera][i] if i >= 0 else None

    def z_mode_at(self, ns: int) -> ZMode | None:
        """The z-mode in effect at log time `ns`: the run's, then each recorded switch, from the
        log time of its step on (floor(step * 1e9 / physics_hz), as every message of that step)."""
        mode = self.description.z_mode if self.description is not None else None
        for step, kind, value in self.events:
            if kind == "z_mode" and step * NS // self.physics_hz <= ns:
                try:
                    mode = ZMode(value)
                except ValueError:
                    continue  # a foreign or damaged event: keep what was in effect
        return mode


def load_flight(path: Path | str, vehicle: str | None = None, depth: bool = False) -> RecordedFlight:
    """Everything readable in a recording (of a fleet's: that of `vehicle`, by default the first
    vehicle). Damaged chunks are skipped (listed in `damage`); QuadsimError only for what is not
    an MCAP file at all, or a vehicle the recording does not have. `depth`: as load_flights."""
    flights = load_flights(path, depth)
    if vehicle is None:
        return next(iter(flights.values()))
    if vehicle not in flights:
        have = ", ".join(n for n in flights if n) or "one vehicle, unnamed"
        raise QuadsimError(f"{path}: no vehicle named {vehicle!r} in this recording (it has {have})")
    return flights[vehicle]


def load_flights(path: Path | str, depth: bool = False) -> dict[str, RecordedFlight]:
    """Every vehicle's flight in a recording, read in one pass, by name: a fleet's vehicles in
    the fleet's order, or "" alone for a run of one vehicle (and for other programs' files).
    `depth`: also each camera's depth images, colour-mapped, as frames of CAMERA_depth (costs
    a millisecond or two per image)."""
    with RecordingReader(path, require_topics=False, allow_damage=True) as reader:
        description = reader.description
        members = description.fleet if description is not None and description.fleet else (("", description),)
        flights: dict[str, RecordedFlight] = {}
        wanted: dict[str, tuple[RecordedFlight, str]] = {}  # topic -> (its flight, what it is)
        parts: dict[str, dict[str, dict[int, Any]]] = {}
        for name, own in members:
            hz = own.config.rates.physics_hz if own is not None else 240
            flight = RecordedFlight(
                reader.path,
                own,
                hz,
                description_error=reader.description_error,
                vehicle=name,
                fleet=description if name else None,
            )
            flight.events = reader.vehicle_events.get(name, []) if name else reader.events
            flight.bad_events = reader.bad_events
            flight.damage, flight.notes = reader.damage, reader.notes
            flight.damage_report = reader.file.damage_report() if reader.damage else ""
            flight.attachments = reader.attachments()
            flight.topics = reader.topic_counts()
            flight.start_ns, flight.end_ns = reader.file.span_ns
            flights[name] = flight
            parts[name] = _wanted(flight, reader.topics, wanted, depth)
        for topic, ns, msg in reader.raw_messages(list(wanted)):
            flight, what = wanted[topic]
            if what == _COMMAND:
                flight.commands.append((ns, rm.twist_from_msg(msg)))
            elif what.startswith(_FRAME):
                flight.frames.setdefault(what.removeprefix(_FRAME), []).append((ns, bytes(msg.data)))
            elif what.startswith(_DEPTH):
                jpeg = _depth_jpeg(msg)
                if jpeg is None:
                    reader.undecodable[topic] = reader.undecodable.get(topic, 0) + 1
                else:
                    flight.frames.setdefault(what.removeprefix(_DEPTH) + DEPTH_SUFFIX, []).append((ns, jpeg))
            elif what in _RANGING:
                flight.ranging.setdefault(what, []).append((ns, _readings(what, msg)))
            elif _finite(what, msg):
                parts[flight.vehicle][what][ns] = msg
            else:
                reader.undecodable[topic] = reader.undecodable.get(topic, 0) + 1
        for flight in flights.values():
            flight.undecodable = dict(reader.undecodable)
    for name, flight in flights.items():
        _assemble_states(flight, parts[name])
    return flights


_COMMAND = "command"
#: the ranging sensors' topics, as the contract names them for a vehicle alone
_RANGING = (rm.RANGE.name, rm.SCAN.name, rm.POINTS.name)


def _readings(topic: str, msg: Any) -> bytes:
    """A ranging message's readings as bytes to compare: the range or the scan's ranges (float32),
    the cloud's points."""
    if topic == rm.RANGE.name:
        return struct.pack("<f", msg.range)
    if topic == rm.SCAN.name:
        return struct.pack(f"<{len(msg.ranges)}f", *msg.ranges)
    return bytes(msg.data)


IMAGE_TYPE = "sensor_msgs/msg/CompressedImage"
_FRAME = "frame:"
_DEPTH = "depth:"
#: what a camera's depth images are called among the frames (front_depth)
DEPTH_SUFFIX = "_depth"
DEPTH_TYPE = "sensor_msgs/msg/Image"


def _depth_jpeg(msg: Any) -> bytes | None:
    """A depth image message colour-mapped as JPEG; None for one that does not add up."""
    from quadsim.sensors.images import depth_colormap_jpeg, image_pixels

    try:
        pixels = image_pixels(msg.encoding, msg.height, msg.width, msg.step, bool(msg.is_bigendian), bytes(msg.data))
    except ValueError:
        return None
    if msg.encoding not in ("32FC1", "16UC1"):
        return None
    return depth_colormap_jpeg(pixels, msg.encoding, 90)


def _wanted(
    flight: RecordedFlight, types: dict[str, str], wanted: dict[str, tuple[RecordedFlight, str]], depth: bool = False
) -> dict[str, dict[int, Any]]:
    """Adds `flight`'s topics to `wanted` (topic -> what it is: a state part by its contract name,
    the command, a camera's frames, with `depth` its depth images); the state parts' message
    tables, empty."""
    names = rm.Names(flight.vehicle)
    parts: dict[str, dict[int, Any]] = {t.name: {} for t in (rm.POSE, rm.ODOM, rm.IMU, rm.ROTOR_THRUSTS)}
    for part in parts:
        wanted[names.topic(rm.Topic(part, "")).name] = (flight, part)
    wanted[names.topic(rm.TWIST).name] = (flight, _COMMAND)
    for ranging in (rm.RANGE, rm.SCAN, rm.POINTS):
        wanted[names.topic(ranging).name] = (flight, ranging.name)
    prefix = f"/{flight.vehicle}/" if flight.vehicle else "/"
    for t in types:
        if t.startswith(prefix) and t.endswith("/image_raw/compressed") and types[t] == IMAGE_TYPE:
            wanted[t] = (flight, _FRAME + t.split("/")[-3].removesuffix("_camera"))
        if depth and t.startswith(prefix) and t.endswith("/depth/image_raw") and types[t] == DEPTH_TYPE:
            wanted[t] = (flight, _DEPTH + t.split("/")[-3].removesuffix("_camera"))
    for topic in [t for t, (f, _) in wanted.items() if f is flight and t not in types]:
        del wanted[topic]
    return parts


def _assemble_states(flight: RecordedFlight, parts: dict[str, dict[int, Any]]) -> None:
    for ns in sorted(parts[rm.POSE.name]):
        state, body_velocity = _state(flight.step_of(ns), parts, ns)
        flight.state_ns.append(ns)
        flight.states.append(state)
        flight.body_velocities.append(body_velocity)


def _finite(topic: str, msg: Any) -> bool:
    """A pose must hold finite numbers to be a state (NaN would poison every figure)."""
    if topic != rm.POSE.name:
        return True
    p, q = msg.pose.position, msg.pose.orientation
    return all(math.isfinite(v) for v in (p.x, p.y, p.z, q.x, q.y, q.z, q.w))


def _state(step: int, parts: dict[str, dict[int, Any]], ns: int) -> tuple[VehicleState, tuple[float, float, float]]:
    """The state at `ns` from its messages, and its velocity in base_link as /quad/odom has it."""
    pose = parts[rm.POSE.name][ns].pose
    q = (pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w)
    odom = parts[rm.ODOM.name].get(ns)
    imu = parts[rm.IMU.name].get(ns)
    thrusts = parts[rm.ROTOR_THRUSTS.name].get(ns)
    body = velocity = rates = (0.0, 0.0, 0.0)
    if odom is not None:
        b, a = odom.twist.twist.linear, odom.twist.twist.angular
        body, rates = (b.x, b.y, b.z), (a.x, a.y, a.z)
        velocity = rotate(matrix_from_quaternion(q), body)
    force = (
        (imu.linear_acceleration.x, imu.linear_acceleration.y, imu.linear_acceleration.z) if imu else (0.0, 0.0, 0.0)
    )
    rotor = tuple(float(v) for v in thrusts.data) if thrusts is not None else ()
    position = (pose.position.x, pose.position.y, pose.position.z)
    return VehicleState(step, position, q, velocity, rates, rotor, force), body
