"""Reading recordings back: commands, states and camera frames, typed.

Refuses, with a clear QuadsimError, files that are not MCAP, are damaged or cut short (see
`quadsim recover`), or (unless `require_topics` is off, for playing other programs' files)
lack the topics a quadsim recording has.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from quadsim.core.types import Twist
from quadsim.errors import QuadsimError
from quadsim.recording import contract as rm
from quadsim.recording.salvage import check_is_mcap, damage_report
from quadsim.recording.writer import EVENT_METADATA_NAME, METADATA_NAME
from quadsim.sim.description import DescriptionError, RunDescription


def _event(metadata: dict[str, str]) -> tuple[int, str, str] | None:
    """(step, kind, value) of an event record; None for a malformed one."""
    try:
        return int(metadata["step"]), str(metadata["kind"]), str(metadata["value"])
    except (KeyError, ValueError, TypeError):
        return None


class RecordingReader:
    def __init__(self, path: Path | str, require_topics: bool = True) -> None:
        self.path = Path(path)
        check_is_mcap(self.path)
        self._fh = open(self.path, "rb")
        try:
            self._reader = make_reader(self._fh)
            self.header = self._reader.get_header()
            summary = self._reader.get_summary()
        except Exception:
            summary = None
        if summary is None:
            self._fh.close()
            raise QuadsimError(damage_report(self.path))
        self.summary = summary
        self.topics = {
            ch.topic: summary.schemas[ch.schema_id].name
            for ch in summary.channels.values()
            if ch.schema_id in summary.schemas
        }
        records = list(self._reader.iter_metadata())
        #: the run's record: version, wall-clock start, parameters (JSON); empty for other programs' files
        self.quadsim_metadata: dict[str, str] = next((dict(m.metadata) for m in records if m.name == METADATA_NAME), {})
        # quadsim's own files are known by their record: a topic that got no message (no command
        # was ever sent) has no channel in the file
        missing = [t for t in rm.CORE_TOPICS if t not in self.topics]
        if missing and require_topics and not self.quadsim_metadata:
            self._fh.close()
            raise QuadsimError(f"{self.path}: not a quadsim recording: missing topics {', '.join(missing)}")
        #: the run's typed description; None for other programs' files or when unreadable (then
        #: `description_error` says why)
        self.description: RunDescription | None = None
        self.description_error: str | None = None
        params = self.quadsim_metadata.get("parameters")
        if params is not None:
            try:
                self.description = RunDescription.from_parameters(json.loads(params))
            except (ValueError, RecursionError) as exc:  # json's errors are ValueErrors
                self.description_error = f"{self.path}: the run parameters are not valid JSON ({exc})"
            except DescriptionError as exc:
                self.description_error = f"{self.path}: {exc}"
        #: (step, kind, value) of what happened besides the commands (z-mode switches)
        found = (_event(m.metadata) for m in records if m.name == EVENT_METADATA_NAME)
        self.events = sorted(e for e in found if e is not None)

    def attachments(self) -> dict[str, bytes]:
        return {a.name: a.data for a in self._reader.iter_attachments()}

    def raw_messages(self, topics: list[str]) -> Iterator[tuple[str, int, Any]]:
        """(topic, log time ns, decoded message) of several topics, in log-time order."""
        deserialize = rm.typestore().deserialize_cdr
        for _, channel, message in self._reader.iter_messages(topics=topics, log_time_order=True):
            yield channel.topic, message.log_time, deserialize(message.data, self.topics[channel.topic])

    def messages(self, topic: str) -> Iterator[tuple[int, Any]]:
        """(log time ns, decoded message) of one topic, in log-time order."""
        type_name = self.topics.get(topic)
        if type_name is None:
            return
        deserialize = rm.typestore().deserialize_cdr
        for _, _, message in self._reader.iter_messages(topics=[topic], log_time_order=True):
            yield message.log_time, deserialize(message.data, type_name)

    def commands(self) -> Iterator[tuple[int, Twist]]:
        for ns, m in self.messages(rm.TWIST.name):
            yield ns, Twist(m.linear.x, m.linear.y, m.linear.z, m.angular.x, m.angular.y, m.angular.z)

    def poses(self) -> Iterator[tuple[int, tuple[float, float, float], tuple[float, float, float, float]]]:
        for ns, m in self.messages(rm.POSE.name):
            p, q = m.pose.position, m.pose.orientation
            yield ns, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)

    def images(self, camera: str) -> Iterator[tuple[int, bytes]]:
        for ns, m in self.messages(f"/quad/{camera}_camera/image_raw/compressed"):
            yield ns, bytes(m.data)

    def close(self) -> None:
        self._fh.close()

    def __enter__(self) -> RecordingReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
