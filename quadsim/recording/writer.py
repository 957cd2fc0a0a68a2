"""The recorder: writes a run to MCAP following the recording contract (docs/recordings.md).

A consumer of the topic fan-out (`quadsim.recording.fanout`): it writes the messages it is given
and decides nothing about them. Profile `ros2`, `ros2msg` schemas, CDR messages, zstd chunks,
written by foxglove-sdk's MCAP writer (Rust). Log time = publish time = header.stamp =
simulation time in ns from 0. A chunk is closed and handed to the OS at every simulated second,
and at least once a second of wall time (a run with cameras is slower than real time): a process
killed outright loses the last second or so, the open chunk and what waits for the camera frames
of its time (see _LogTimeOrder); the file is fsynced at most once per wall second. If writing fails
(the disk is full), recording stops, what was written stays readable (`quadsim recover` indexes
it), and the flight goes on.
"""

from __future__ import annotations

import datetime as dt
import errno
import heapq
import json
import logging
import os
import re
import shutil
import time
from collections.abc import Callable, Mapping, Sequence
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

from quadsim import __version__
from quadsim.core.invocation import program
from quadsim.errors import QuadsimError
from quadsim.recording.contract import Names, Topic, frame_topics, schema_text
from quadsim.recording.paths import default_recordings_dir
from quadsim.sim.description import RunDescription

if TYPE_CHECKING:
    from quadsim.recording.fanout import Message

log = logging.getLogger(__name__)

#: refuse to start recording with less free space than this
MIN_FREE_BYTES = 200_000_000
METADATA_NAME = "quadsim"
EVENT_METADATA_NAME = "quadsim_event"  # one record per event, written when it happens


def recording_path(out: Path | None, label: str, now: dt.datetime | None = None) -> Path:
    """Where a run lands: `--out FILE.mcap`, or a dated name in `--out DIR` (default:
    `default_recordings_dir()`)."""
    if out is not None and out.suffix == ".mcap":
        return out
    folder = out if out is not None else default_recordings_dir()
    stamp = (now or dt.datetime.now()).strftime("%Y-%m-%d_%H-%M-%S")
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "-", label).strip("-") or "run"
    if len(safe) > 200:  # a long script or fleet file name: within a file name's 255 bytes, the end kept
        safe = f"{safe[:140]}-{safe[-59:]}"
    path = folder / f"{stamp}_{safe}.mcap"
    n = 2
    while path.exists():  # two recordings in the same second
        path = folder / f"{stamp}_{safe}_{n}.mcap"
        n += 1
    return path


def check_writable(path: Path, min_free_bytes: int = MIN_FREE_BYTES) -> None:
    """Refuse early, with a clear message, when a recording could not be written."""
    folder = path.parent
    if len(path.name.encode()) > 255:
        raise QuadsimError(f"the recording's file name is too long ({len(path.name.encode())} bytes; at most 255)")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:  # (mkdir's "File exists" for a file of that name)
        raise QuadsimError(f"cannot write recordings to {folder}: it is a file, not a folder") from None
    except OSError as exc:
        raise QuadsimError(f"cannot create the recording folder {folder}: {exc.strerror}") from None
    if not folder.is_dir():
        raise QuadsimError(f"cannot write recordings to {folder}: not a folder")
    if path.exists():
        raise QuadsimError(
            f"{path} already exists; record to another file or folder (out=...; nothing is overwritten)",
            f"{path} already exists; choose another --out (nothing is overwritten)",
        )
    if not os.access(folder, os.W_OK):
        problem = f"cannot write recordings to {folder}: permission denied"
        raise QuadsimError(
            f"{problem} (record to another folder: out=DIR)", f"{problem} (use --out DIR or --no-record)"
        )
    free = shutil.disk_usage(folder).free
    if free < min_free_bytes:
        problem = f"only {free / 1e6:.0f} MB free in {folder}; recording needs at least {min_free_bytes / 1e6:.0f} MB"
        raise QuadsimError(
            f"{problem} (free some space, or record elsewhere: out=DIR)",
            f"{problem} (free some space, use --out elsewhere, or --no-record)",
        )


def ros2_channel_log(topic: Topic, context: Any) -> Callable[..., None]:
    """A foxglove-sdk channel for `topic` in `context` as the contract has it: CDR messages, its
    `ros2msg` schema, its QoS in `offered_qos_profiles` (the recorder's file and the live
    Foxglove server use the same). What is kept of it is its log(data, log_time, sink_id=None):
    the typed core of Channel.log, without its checks for JSON and str messages."""
    import foxglove

    schema = foxglove.Schema(name=topic.type_name, encoding="ros2msg", data=schema_text(topic.type_name).encode())
    channel = foxglove.Channel(
        topic.name,
        schema=schema,
        message_encoding="cdr",
        context=context,
        metadata={"offered_qos_profiles": topic.qos},
    )
    return channel.base.log


class _GuardedStream:
    """A caller's stream under the MCAP writer: it remembers the first write error, which the
    Rust writer would report only as "I/O error", and from then on it is a null device (writes
    are counted, not written), so the writer goes on without complaint while the recorder stops.

    Its methods are Python code that the writer calls from Rust, so a signal handler's exception
    (Ctrl-C) may land in them; recordings to a path do not use it: the writer then calls the C
    methods of a plain file, where no Python handler runs."""

    def __init__(self, raw: BinaryIO) -> None:
        self.raw = raw
        self.error: OSError | None = None
        self._position = 0  # where the writer believes it is (the file may be shorter after an error)
        self._end = 0

    def _raw(self, method: Callable[..., Any], *args: Any) -> Any:
        """`method` of the stream called until a write error (kept); None once there is one."""
        if self.error is None:
            try:
                return method(*args)
            except OSError as exc:
                self.error = exc
        return None

    def write(self, data: bytes | bytearray) -> int:
        self._raw(self.raw.write, data)
        self._position += len(data)
        self._end = max(self._end, self._position)
        return len(data)

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        at = self._raw(self.raw.seek, offset, whence)
        if at is None:
            at = {os.SEEK_SET: 0, os.SEEK_CUR: self._position, os.SEEK_END: self._end}[whence] + offset
        self._position = at
        return at

    def flush(self) -> None:
        self._raw(self.raw.flush)


def _flush_error(stream: BinaryIO) -> str | None:
    try:
        stream.flush()
    except OSError as exc:
        return exc.strerror or str(exc)
    except ValueError:  # closed
        pass
    return None


def _no_space_left(folder: Path) -> bool:
    try:
        st = os.statvfs(folder)
    except (OSError, AttributeError):  # no statvfs on Windows
        return False
    return st.f_bavail == 0 or st.f_bfree == 0


#: how long (simulated time) the recorder holds messages back for camera frames at most: headless
#: runs hand frames on within sensors.pipeline.ORDERED_LAG_S; the window hands them on when they
#: are ready, and one later than this is left out of the file (it is stale, and would break the
#: log-time order)
MAX_FRAME_WAIT_NS = 500_000_000


class _LogTimeOrder:
    """Puts messages from producers that run at different delays back in log-time order.

    Each vehicle's frames come in capture order, from its render workers, a few camera periods
    after the states of their time; a fleet's vehicles each at their own pace. Everything else is
    held until every vehicle's frames have come at least as far, or until `max_hold_ns` of newer
    messages have piled up (frames stop: a window dropping them on a busy machine); a frame older
    than what was written by then is left out and counted in `late`. Frames from before
    `start_ns` (rendered before recording began) are left out.

    `camera_topics`: the topics of frames, each with the vehicle whose pipeline delivers it. One
    vehicle's frames once let everything up to them be written, so a fleet's second vehicle with
    cameras found its frames already passed: nearly all left out.
    """

    def __init__(self, camera_topics: Mapping[str, str], start_ns: int, max_hold_ns: int = MAX_FRAME_WAIT_NS) -> None:
        self._producer = dict(camera_topics)
        self._start_ns = start_ns
        self._max_hold_ns = max_hold_ns
        self._held: list[tuple[int, int, Message]] = []  # heap of (log time, arrival, message)
        self._arrivals = 0
        #: how far each vehicle's frames have come: every one of its frames up to this log time is in
        self._frames_up_to = dict.fromkeys(self._producer.values(), -1)
        self._newest = 0
        self._released_to = -1  # every message up to this log time has been handed on
        self.late = 0  # frames that came after their time was written: left out

    def push(self, messages: Sequence[Message]) -> list[Message]:
        for message in messages:
            topic, ns, _ = message
            producer = self._producer.get(topic.name)
            if producer is not None:
                if ns < self._start_ns:
                    continue
                if ns < self._released_to:
                    self.late += 1
                    continue
                if ns > self._frames_up_to[producer]:
                    self._frames_up_to[producer] = ns
            heapq.heappush(self._held, (ns, self._arrivals, message))
            self._arrivals += 1
            if ns > self._newest:
                self._newest = ns
        release_to = max(min(self._frames_up_to.values()), self._newest - self._max_hold_ns)
        out = []
        held = self._held
        while held and held[0][0] <= release_to:
            out.append(heapq.heappop(held)[2])
        if out:
            self._released_to = max(self._released_to, out[-1][1])
        return out

    def drain(self) -> list[Message]:
        out = [item[2] for item in sorted(self._held)]
        self._held.clear()
        return out


#: where foxglove-sdk reports a message its MCAP writer could not write (once per message logged)
SDK_WRITE_LOGGER = "foxglove.log_sink_set"


def _not_a_per_message_write_error(record: logging.LogRecord) -> bool:
    """Keeps the SDK's per-message write errors off the user's screen: after a write fails
    (the disk is full), the writer reports every message logged until the recorder's next flush,
    which meets the error itself and says it once. Only those records are dropped."""
    return not record.getMessage().startswith("error logging message: McapError")


@cache
def route_sdk_logs_through_python() -> None:
    """foxglove-sdk prints its Rust log records straight to stderr unless they are routed to
    Python's logging (its set_log_level); route them once, and filter the per-message write
    errors there. set_log_level would call logging.basicConfig where the program has no handler
    (a script using quadsim.record): a NullHandler stands in while it is called."""
    import foxglove

    logging.getLogger(SDK_WRITE_LOGGER).addFilter(_not_a_per_message_write_error)
    root = logging.getLogger()
    stand_in = logging.NullHandler() if not root.handlers else None
    if stand_in is not None:
        root.addHandler(stand_in)
    try:
        foxglove.set_log_level("WARNING")  # FOXGLOVE_LOG_LEVEL, where set, wins
    finally:
        if stand_in is not None:
            root.removeHandler(stand_in)


def _camera_topics(description: RunDescription) -> dict[str, str]:
    """The topics of the run's camera frames, depth and segmentation included (of each fleet
    vehicle's, under its name), each with the name of the vehicle whose cameras they are."""
    runs = description.fleet or (("", description),)
    return {
        Names(name).topic(topic).name: name
        for name, d in runs
        for spec in d.cameras
        for topic in frame_topics(spec).values()
    }


def _attachments(description: RunDescription) -> dict[str, tuple[bytes, str]]:
    """The files a re-flight rebuilds the run from, by name: every vehicle's URDF and parameter
    file (each once, in a fleet) and the world file."""
    world = description.world_model
    runs = [d for _, d in description.fleet] or [description]
    models = [d.vehicle_model for d in runs if d.vehicle_model is not None]
    if world is None or len(models) < len(runs):
        raise QuadsimError("a recording needs the description of a live run (with its vehicle and world)")
    files: dict[str, tuple[bytes, str]] = {}
    paths = [
        (path, media)
        for m in models
        for path, media in ((m.urdf_path, "application/xml"), (m.params_path, "application/toml"))
    ]
    for path, media in [*paths, (world.path, "application/toml")]:
        data = path.read_bytes()
        if files.setdefault(path.name, (data, media))[0] != data:
            raise QuadsimError(
                f"two different files are named {path.name} ({path}): a recording keeps the run's files by name; "
                "rename one"
            )
    return files


class McapRecorder:
    """A consumer of the topic fan-out that writes one MCAP file: the run's metadata and
    attachments when it opens, then every message it is given.

    Chunks are closed here, at every simulated second, once `flush_every_wall_s` of wall time has
    passed since the last one, and whenever `chunk_size` bytes of messages have gathered, not by
    the writer while it logs a message: so a write error surfaces here, as an exception, and
    recording stops (one that hits the few bytes the writer puts down when it opens a chunk is
    logged by foxglove and surfaces at the next flush). Where chunks end depends on the wall clock
    (`clock`); the messages, their order and their times do not."""

    def __init__(
        self,
        path: Path,
        description: RunDescription,
        stream: BinaryIO | None = None,
        chunk_size: int = 4 * 1024 * 1024,
        flush_every_wall_s: float = 1.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        import foxglove
        from foxglove.mcap import MCAPCompression, MCAPWriteOptions

        route_sdk_logs_through_python()
        self.path = path
        self._own_stream = stream is None
        if stream is None:
            try:
                stream = open(path, "xb")
            except OSError as exc:
                raise QuadsimError(f"cannot create {path}: {exc.strerror}") from None
        self._stream = stream
        self._guard = None if self._own_stream else _GuardedStream(stream)
        self.message_count = 0
        self.error: str | None = None
        self.closed = False
        self.last_log_time_ns = 0
        self._flush_every_ns = 1_000_000_000
        self._next_flush_ns = self._flush_every_ns
        self._chunk_size = chunk_size
        self._chunk_bytes = 0
        # a camera run may take several wall seconds per simulated second: a kill -9 lost them all
        self._clock, self._flush_every_wall_s, self._last_flush_wall = clock, flush_every_wall_s, clock()
        self._last_fsync_wall = time.monotonic()
        self._context = foxglove.Context()  # this file's channels, apart from any other sink's
        self._log: dict[str, Callable[..., None]] = {}  # topic -> its channel's log(data, log_time)
        self._writer: Any = None
        # camera frames are rendered elsewhere and come late: hold the rest until the frames of
        # their time are in, so the file is in log-time order (readers and `mcap doctor` expect it)
        camera_topics = _camera_topics(description)
        start_ns = description.start_step * 1_000_000_000 // description.config.rates.physics_hz
        self._reorder = _LogTimeOrder(camera_topics, start_ns) if camera_topics else None
        options = MCAPWriteOptions(
            profile="ros2",
            compression=MCAPCompression.Zstd,
            # without cameras, zstd's fastest level: closing a chunk takes half the time, for about
            # the same size; with cameras, JPEGs are most of the bytes, zstd's default makes the
            # file ~9 % smaller, and rendering dwarfs the time it takes
            compression_level=0 if camera_topics else 1,
            chunk_size=None,  # chunks end where this class says (see above)
            compression_threads=0,  # compress in this thread: the other core renders cameras
        )
        try:
            self._writer = foxglove.open_mcap(self._guard or stream, context=self._context, writer_options=options)
            self._write_metadata(description)
        except RuntimeError as exc:  # foxglove's errors
            self._fail(f"the file could not be written ({exc})")

    def _write_metadata(self, description: RunDescription) -> None:
        params = description.to_parameters()
        self._writer.write_metadata(
            METADATA_NAME,
            {
                "quadsim_version": __version__,
                "wall_clock_start_utc": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
                "time_base": "simulation time, ns from 0 (log_time = publish_time = header.stamp)",
                "parameters": json.dumps(params, sort_keys=True),
            },
        )
        for name, (data, media) in _attachments(description).items():
            self._writer.attach(log_time=0, create_time=0, name=name, media_type=media, data=data)

    # --- what the fan-out calls -----------------------------------------------------------------

    def add_topic(self, topic: Topic) -> None:
        """A channel for `topic` (one schema per type: the writer shares equal schemas)."""
        if topic.name not in self._log:
            self._log[topic.name] = ros2_channel_log(topic, self._context)

    def on_messages(self, messages: Sequence[Message]) -> None:
        if self.error is not None or self.closed or not messages:
            return
        ready = messages if self._reorder is None else self._reorder.push(messages)
        if ready:
            self._write(ready)

    def _write(self, messages: Sequence[Message]) -> None:
        log_to, size = self._log, self._chunk_bytes
        for topic, ns, data in messages:
            log_to[topic.name](data, ns)  # publish time = log time; sequence counts from 1 per channel
            size += len(data)
        self._chunk_bytes = size
        self.message_count += len(messages)
        if ns > self.last_log_time_ns:
            self.last_log_time_ns = ns
        if ns >= self._next_flush_ns or size >= self._chunk_size:
            if ns >= self._next_flush_ns:
                self._next_flush_ns = (ns // self._flush_every_ns + 1) * self._flush_every_ns
            self._flush()
        elif self._clock() - self._last_flush_wall >= self._flush_every_wall_s:
            self._flush()

    def on_event(self, step: int, kind: str, value: str, vehicle: str = "") -> None:
        """Kept as metadata too, where re-simulation reads it (a z-mode switch); in a fleet, with
        the name of the vehicle it happened to."""
        if self.error is None and not self.closed:
            record = {"step": str(step), "kind": kind, "value": value}
            if vehicle:
                record["vehicle"] = vehicle
            self._call(self._writer.write_metadata, EVENT_METADATA_NAME, record)

    # --- writing ----------------------------------------------------------------------------

    def _call(self, method: Any, *args: Any) -> bool:
        """Call a writer method that may write to the file; False (and recording stopped) if it failed."""
        try:
            method(*args)
        except RuntimeError as exc:  # foxglove's errors: the file could not be written
            self._fail(f"the file could not be written ({exc})")
            return False
        if self._guard is not None and self._guard.error is not None:
            self._fail(str(self._guard.error))
            return False
        return True

    def _flush(self) -> None:
        """Close the chunk and hand it to the OS; fsync at most once per wall second."""
        self._chunk_bytes = 0
        self._last_flush_wall = self._clock()
        if not self._call(self._writer.flush):
            return
        now = time.monotonic()
        if now - self._last_fsync_wall >= 1.0 and hasattr(self._stream, "fileno"):
            self._last_fsync_wall = now
            try:
                os.fsync(self._stream.fileno())
            except (OSError, ValueError):
                pass

    def _fail(self, reason: str) -> None:
        if self.error is not None:
            return
        if self._guard is not None and self._guard.error is not None:
            reason = self._guard.error.strerror or reason
        elif self._own_stream and (os_error := _flush_error(self._stream)) is not None:
            reason = os_error  # what the writer's failed write left in the file's buffer says why
        elif _no_space_left(self.path.parent):
            reason = os.strerror(errno.ENOSPC)
        self.error = (
            f"recording stopped at sim time {self.last_log_time_ns / 1e9:.2f} s: {reason}. "
            f"What was written is kept; run '{program()} recover {self.path}' to index it"
        )
        log.error("%s", self.error)
        if self._writer is not None:
            try:
                self._writer.close()  # it has failed: this only lets it go
            except RuntimeError:
                pass
        if self._own_stream:
            try:
                self._stream.close()
            except OSError:
                pass

    def close(self) -> None:
        """Finish the file (summary, index, footer). Safe to call more than once."""
        if self.closed:
            return
        if self._reorder is not None and self.error is None:
            rest = self._reorder.drain()
            if rest:
                self._write(rest)
            if self._reorder.late:
                log.warning(
                    "%d camera frames came more than %.1f s of simulated time after their moment (the machine "
                    "was busy) and were left out of %s",
                    self._reorder.late,
                    MAX_FRAME_WAIT_NS / 1e9,
                    self.path,
                )
        self.closed = True
        if self.error is not None or not self._call(self._writer.close):
            return
        try:
            if self._own_stream:
                self._stream.flush()
                os.fsync(self._stream.fileno())
                self._stream.close()
        except OSError as exc:
            self._fail(exc.strerror or str(exc))
