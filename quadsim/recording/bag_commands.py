"""The /quad_cmd_twist commands of any MCAP file, for `run --commands-from`: a bag another program
recorded (`ros2 bag record` in MCAP storage, CDR `geometry_msgs/msg/Twist`) or a quadsim
recording. Whatever is wrong with the file is one QuadsimError line saying what it is."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from quadsim.core.types import Twist, ZMode
from quadsim.errors import QuadsimError
from quadsim.recording.contract import TWIST
from quadsim.recording.reader import RecordingReader


@dataclass(frozen=True)
class BagCommands:
    path: Path
    #: (log time in ns from the first command, the command), in log-time order
    commands: tuple[tuple[int, Twist], ...]
    #: the z-mode a quadsim recording was flown in (None for other programs' files)
    z_mode: ZMode | None

    @property
    def span_ns(self) -> int:
        return self.commands[-1][0]


def read_bag_commands(path: Path) -> BagCommands:
    """Every /quad_cmd_twist message of `path`, with its log time relative to the first one."""
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
        timed = list(reader.commands())
        total = sum(reader.file.counts.get(ch.key, 0) for ch in channels)
        if reader.undecodable.get(TWIST.name):
            raise QuadsimError(
                f"{path}: {reader.undecodable[TWIST.name]} of the {total} messages on {TWIST.name} "
                f"do not decode as {TWIST.type_name}"
            )
        if not timed:
            raise QuadsimError(f"{path}: {TWIST.name} has no messages")
        z_mode = reader.description.z_mode if reader.description is not None else None
    first = timed[0][0]
    return BagCommands(path, tuple((ns - first, twist) for ns, twist in timed), z_mode)


def command_steps(commands: BagCommands, physics_hz: int) -> list[tuple[int, Twist]]:
    """The commands at the physics steps nearest their log times; of two at one step, the later
    (a bag written at more than the physics rate)."""
    at: dict[int, Twist] = {}
    for ns, twist in commands.commands:
        at[round(ns * physics_hz / 1_000_000_000)] = twist
    return sorted(at.items())
