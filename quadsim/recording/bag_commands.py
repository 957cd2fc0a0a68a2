"""The /quad_cmd_twist commands of any MCAP file, for `run --commands-from`: a bag another program
recorded (`ros2 bag record` in MCAP storage, CDR `geometry_msgs/msg/Twist`) or a quadsim
recording. Whatever is wrong with the file is one QuadsimError line saying what it is.

The commands are streamed from the file as the flight reaches them, never held all at once: a bag
of ten million commands flies in the memory of a short one.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from quadsim.core.types import Twist, ZMode
from quadsim.errors import QuadsimError
from quadsim.recording import cdr
from quadsim.recording.contract import TWIST
from quadsim.recording.mcap_scan import McapFile, bag_file
from quadsim.recording.reader import RecordingReader

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class BagCommands:
    path: Path
    #: how many commands, and the log times of the first and the last (ns, the file's clock)
    count: int
    first_ns: int
    last_ns: int
    #: the z-mode a quadsim recording was flown in (None for other programs' files)
    z_mode: ZMode | None
    channel_keys: frozenset[int]
    #: a quadsim recording's z-mode switches (the steps of its z_mode events), which a run from
    #: its commands does not make (replay --resim does)
    z_switch_steps: tuple[int, ...] = ()

    @property
    def span_ns(self) -> int:
        return self.last_ns - self.first_ns

    def commands(self) -> Iterator[tuple[int, Twist]]:
        """(log time in ns from the first command, the command), in log-time order, read from
        the file as they are asked for."""
        with McapFile(self.path) as f:
            for m in f.messages(set(self.channel_keys)):
                lx, ly, lz, ax, ay, az = cdr.twist_fields(m.data)
                yield m.log_time - self.first_ns, Twist(lx, ly, lz, ax, ay, az)


def read_bag_commands(path: Path) -> BagCommands:
    """Check that `path` (a file, or a bag's folder holding one) has /quad_cmd_twist commands to
    fly, all of them decodable (one pass over that channel, in constant memory), and say how many
    there are and when (the counts and times the file's opening pass found)."""
    path = bag_file(path)
    with RecordingReader(path, require_topics=False) as reader:
        channels = [ch for ch in reader.file.channels if ch.topic == TWIST.name]
        if not channels:
            have = ", ".join(sorted(reader.topics)) or "none"
            raise QuadsimError(f"{path}: no {TWIST.name} channel to fly (its topics: {have})")
        for ch in channels:
            schema = ch.schema
            type_name = schema.name if schema is not None else "no schema"
            if type_name.replace("/msg/", "/") != TWIST.type_name.replace("/msg/", "/"):
                raise QuadsimError(f"{path}: {TWIST.name} carries {type_name}, not {TWIST.type_name}")
            if ch.message_encoding != "cdr" or schema is None or schema.encoding != "ros2msg":
                schema_encoding = schema.encoding if schema is not None else "no"
                encoding = f"{ch.message_encoding or 'unencoded'} messages with a {schema_encoding or '?'} schema"
                raise QuadsimError(
                    f"{path}: {TWIST.name} has {encoding}, not ROS 2's cdr with a ros2msg schema "
                    f"(a ROS 1 bag? convert it with rosbags-convert)"
                )
        keys = frozenset(ch.key for ch in channels)
        f = reader.file  # its opening pass counted the messages and saw their first and last times
        count = sum(f.counts.get(k, 0) for k in keys)
        if not count:
            raise QuadsimError(f"{path}: {TWIST.name} has no messages")
        undecodable = 0
        for m in f.messages(set(keys), log_time_order=False):
            try:
                cdr.twist_fields(m.data)
            except ValueError:
                undecodable += 1
        if undecodable:
            raise QuadsimError(
                f"{path}: {undecodable} of the {count} messages on {TWIST.name} do not decode as {TWIST.type_name}"
            )
        first_ns = min(f.first_ns[k] for k in keys if k in f.first_ns)
        last_ns = max(f.last_ns[k] for k in keys if k in f.last_ns)
        z_mode = reader.description.z_mode if reader.description is not None else None
        switches = tuple(step for step, kind, _ in reader.events if kind == "z_mode")
    return BagCommands(path, count, first_ns, last_ns, z_mode, keys, switches)


def command_steps(commands: Iterator[tuple[int, Twist]], physics_hz: int) -> Iterator[tuple[int, Twist]]:
    """The commands at the physics steps nearest their log times (ns from the first), in order;
    the driver takes the last of several at one step (a bag written at more than the physics rate)."""
    for ns, twist in commands:
        yield (ns * physics_hz + NS_PER_S // 2) // NS_PER_S, twist
