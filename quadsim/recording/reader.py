"""Reading recordings back: commands, states and camera frames, typed.

Every chunk's CRC is verified (see `mcap_scan`). By default a damaged or cut-short file is
refused with a clear QuadsimError (what is wrong, how much is readable, `quadsim recover`);
with `allow_damage` it is read as far as it goes and `damage` says what was skipped. Files that
are not MCAP are refused, and (unless `require_topics` is off, for playing other programs'
files) so are files without the topics a quadsim recording has. A topic whose encoding or
schema is not the contract's is not decoded (`notes` says so), and neither is a message that
does not decode.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from quadsim.core.types import Twist, ZMode
from quadsim.errors import QuadsimError
from quadsim.recording import contract as rm
from quadsim.recording.mcap_scan import ChannelDef, Damage, McapFile
from quadsim.recording.writer import EVENT_METADATA_NAME, METADATA_NAME
from quadsim.sim.description import VEHICLE_NAME, DescriptionError, RunDescription

#: an event's step must be a whole number in this range
MAX_EVENT_STEP = 2**62


def _event(metadata: dict[str, str]) -> tuple[str, tuple[int, str, str]] | str:
    """(vehicle, (step, kind, value)) of an event record, or why it is malformed; the vehicle
    is empty but in a fleet's recording."""
    try:
        step_text, kind, value = metadata["step"], metadata["kind"], metadata["value"]
    except KeyError as exc:
        return f"no {exc.args[0]!r} field"
    try:
        step = int(step_text)
    except ValueError:
        return f"step {step_text[:40]!r} is not a whole number"
    if not 0 <= step <= MAX_EVENT_STEP:
        return f"step {step_text[:40]} is out of range"
    if kind == "z_mode" and value not in {z.value for z in ZMode}:
        return f"z-mode {value[:40]!r} is not one of {', '.join(z.value for z in ZMode)}"
    vehicle = metadata.get("vehicle", "")
    if vehicle and not VEHICLE_NAME.fullmatch(vehicle):
        return f"vehicle {vehicle[:40]!r} is not a vehicle's name"
    return vehicle, (step, kind, value)


def _contract_type(topic: str) -> str | None:
    """The message type the recording contract gives a topic (None: not one of its topics),
    also under a fleet vehicle's name (/alpha/quad/odom)."""
    _, name, rest = topic.partition("/")[2].partition("/")
    if rest and VEHICLE_NAME.fullmatch(name):
        own = _own_type(f"/{rest}")
        if own is not None:
            return own
    return _own_type(topic)


def _own_type(topic: str) -> str | None:
    for t in (
        rm.TWIST,
        rm.JOY,
        *rm.STATE_TOPICS,
        rm.WIND,
        rm.RANGE,
        rm.SCAN,
        rm.POINTS,
        rm.TF_STATIC,
        rm.ROBOT_DESCRIPTION,
        rm.ROBOT_MARKERS,
        rm.WORLD_MARKERS,
        rm.ROSOUT,
        rm.SEGMENTATION_LABELS,
    ):
        if t.name == topic:
            return t.type_name
    return next((type_name for suffix, type_name, _ in rm.CAMERA_TOPICS.values() if topic.endswith(suffix)), None)


def _decodable_as(channel: ChannelDef) -> str | None:
    """The ROS 2 type a channel's messages decode as, if it is CDR with a known ros2msg schema."""
    s = channel.schema
    if channel.message_encoding != "cdr" or s is None or s.encoding != "ros2msg" or s.name not in rm.typestore().types:
        return None
    return s.name


class RecordingReader:
    def __init__(self, path: Path | str, require_topics: bool = True, allow_damage: bool = False) -> None:
        self.path = Path(path)
        self.file = McapFile(self.path)
        try:
            self._open(require_topics, allow_damage)
        except BaseException:
            self.file.close()
            raise

    def _open(self, require_topics: bool, allow_damage: bool) -> None:
        """What the file holds: topics and their types, notes on what is not read, the run's
        record and description, and its events."""
        f = self.file
        if f.damage and not allow_damage:
            raise QuadsimError(f.damage_report())
        #: what is wrong with the file and what was skipped (empty for a sound file)
        self.damage: list[Damage] = list(f.damage)
        #: what was not read though the file is sound there (foreign topics, bad events...)
        self.notes: list[str] = list(f.notes)
        self.profile, self.library = f.profile, f.library
        #: topic -> type name (its schema's name, "?" without one)
        self.topics: dict[str, str] = {}
        for ch in f.channels:
            self.topics.setdefault(ch.topic, ch.schema.name if ch.schema else "?")
        ours = [m for m in f.metadata if m.name == METADATA_NAME]
        # quadsim's own files are known by their record: a topic that got no message (no command
        # was ever sent) has no channel in the file
        missing = [t for t in rm.CORE_TOPICS if t not in self.topics]
        if missing and require_topics and not ours:
            raise QuadsimError(f"{self.path}: not a quadsim recording: missing topics {', '.join(missing)}")
        for ch in f.channels:
            expected = _contract_type(ch.topic)
            if expected is not None and f.counts.get(ch.key) and _decodable_as(ch) != expected:
                schema = f"{ch.schema.encoding or '?'} schema {ch.schema.name!r}" if ch.schema else "no schema"
                self.notes.append(
                    f"{ch.topic} is {ch.message_encoding or 'unencoded'} with {schema}, not the contract's cdr with "
                    f"ros2msg schema {expected!r}: its messages are not read"
                )
        records = f.metadata
        if len(ours) > 1:
            self.notes.append(f"{len(ours)} '{METADATA_NAME}' metadata records: the first is used")
        #: the run's record: version, wall-clock start, parameters (JSON); empty for other programs' files
        self.quadsim_metadata: dict[str, str] = dict(ours[0].metadata) if ours else {}
        #: the run's typed description; None for other programs' files or when unreadable (then
        #: `description_error` says why)
        self.description: RunDescription | None = None
        self.description_error: str | None = None
        self._read_description(bool(ours))
        self._read_events(records)
        self.notes += [f"{e}; it is ignored" for e in self.bad_events]
        #: topic -> messages that could not be decoded (skipped)
        self.undecodable: dict[str, int] = {}

    def _read_events(self, records: Any) -> None:
        #: (step, kind, value) of what happened besides the commands (z-mode switches); in a
        #: fleet's recording, those of the whole run (recording started)
        self.events: list[tuple[int, str, str]] = []
        #: in a fleet's recording: vehicle name -> its events
        self.vehicle_events: dict[str, list[tuple[int, str, str]]] = {}
        #: why each malformed event record was left out
        self.bad_events: list[str] = []
        for m in records:
            if m.name == EVENT_METADATA_NAME:
                event = _event(m.metadata)
                if isinstance(event, str):
                    self.bad_events.append(f"the event record at byte {m.offset}: {event}")
                elif event[0]:
                    self.vehicle_events.setdefault(event[0], []).append(event[1])
                else:
                    self.events.append(event[1])
        self.events.sort()
        for events in self.vehicle_events.values():
            events.sort()

    def _read_description(self, has_record: bool) -> None:
        """The run's typed description from its record's parameters, or why there is none."""
        params = self.quadsim_metadata.get("parameters")
        if params is not None:
            try:
                self.description = RunDescription.from_parameters(json.loads(params))
            except (ValueError, RecursionError) as exc:  # json's errors are ValueErrors
                self.description_error = f"{self.path}: the run parameters are not valid JSON ({exc})"
            except DescriptionError as exc:
                self.description_error = f"{self.path}: {exc}"
        elif has_record:
            self.description_error = f"{self.path}: the '{METADATA_NAME}' metadata has no run parameters"

    # --- statistics -------------------------------------------------------------------------

    def topic_counts(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for ch in self.file.channels:
            out[ch.topic] = out.get(ch.topic, 0) + self.file.counts.get(ch.key, 0)
        return out

    # --- contents ---------------------------------------------------------------------------

    def attachments(self) -> dict[str, bytes]:
        """name -> data of each readable attachment (the first of a name)."""
        out: dict[str, bytes] = {}
        for a in self.file.attachments:
            out.setdefault(a.name, self.file.attachment_data(a))
        return out

    def raw_messages(self, topics: list[str]) -> Iterator[tuple[str, int, Any]]:
        """(topic, log time ns, decoded message) of several topics, in log-time order. Only
        channels with the contract's type for the topic are decoded (any known ROS 2 type for
        topics outside the contract); a message that does not decode is skipped and counted in
        `undecodable`."""
        types: dict[int, str] = {}
        for ch in self.file.channels:
            if ch.topic not in topics:
                continue
            type_name = _decodable_as(ch)
            expected = _contract_type(ch.topic)
            if type_name is not None and (expected is None or type_name == expected):
                types[ch.key] = type_name
        store = rm.typestore()
        for m in self.file.messages(set(types)):
            try:
                msg = store.deserialize_cdr(m.data, types[m.channel.key])
            except Exception:  # rosbags raises many kinds on bytes that are not its type
                self.undecodable[m.channel.topic] = self.undecodable.get(m.channel.topic, 0) + 1
                continue
            yield m.channel.topic, m.log_time, msg

    def messages(self, topic: str) -> Iterator[tuple[int, Any]]:
        """(log time ns, decoded message) of one topic, in log-time order."""
        for _, ns, msg in self.raw_messages([topic]):
            yield ns, msg

    def commands(self, vehicle: str = "") -> Iterator[tuple[int, Twist]]:
        """The commands (of a fleet's `vehicle`), as the controller took them."""
        for ns, m in self.messages(rm.Names(vehicle).topic(rm.TWIST).name):
            yield ns, rm.twist_from_msg(m)

    def poses(
        self, vehicle: str = ""
    ) -> Iterator[tuple[int, tuple[float, float, float], tuple[float, float, float, float]]]:
        """(log time, position, orientation xyzw) of the vehicle (of a fleet's `vehicle`)."""
        for ns, m in self.messages(rm.Names(vehicle).topic(rm.POSE).name):
            p, q = m.pose.position, m.pose.orientation
            yield ns, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)

    def images(self, camera: str) -> Iterator[tuple[int, bytes]]:
        for ns, m in self.messages(f"/quad/{camera}_camera/image_raw/compressed"):
            yield ns, bytes(m.data)

    def close(self) -> None:
        self.file.close()

    def __enter__(self) -> RecordingReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
