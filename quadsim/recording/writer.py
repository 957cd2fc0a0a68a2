"""The recorder: writes a run to MCAP following the recording contract of DESIGN.md.

Profile `ros2`, `ros2msg` schemas, CDR messages, zstd chunks. Log time = publish time =
header.stamp = simulation time in ns from 0. A chunk is closed and the file flushed every
simulated second, so a crash loses about a second; the file is fsynced at most once per wall
second. If writing fails (the disk is full), recording stops, what was written stays readable
(`quadsim recover` indexes it), and the flight goes on.
"""

from __future__ import annotations

import datetime as dt
import json
import logging
import os
import re
import shutil
import time
from pathlib import Path
from typing import BinaryIO, TypeVar

from mcap.writer import CompressionType, Writer

from quadsim import __version__
from quadsim.core.types import Twist, VehicleState
from quadsim.errors import QuadsimError
from quadsim.recording import contract as rm
from quadsim.recording.paths import default_recordings_dir
from quadsim.sensors.camera import CameraFrame
from quadsim.sim.description import RunDescription

log = logging.getLogger(__name__)

T = TypeVar("T")

#: refuse to start recording with less free space than this
MIN_FREE_BYTES = 200 * 1024 * 1024
METADATA_NAME = "quadsim"
EVENT_METADATA_NAME = "quadsim_event"  # one record per event, written when it happens


def recording_path(out: Path | None, label: str, now: dt.datetime | None = None) -> Path:
    """Where a run lands: `--out FILE.mcap`, or a dated name in `--out DIR` (default: `default_recordings_dir()`)."""
    if out is not None and out.suffix == ".mcap":
        return out
    folder = out if out is not None else default_recordings_dir()
    stamp = (now or dt.datetime.now()).strftime("%Y-%m-%d_%H-%M-%S")
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "-", label).strip("-") or "run"
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
    except OSError as exc:
        raise QuadsimError(f"cannot create the recording folder {folder}: {exc.strerror}") from None
    if not folder.is_dir():
        raise QuadsimError(f"cannot write recordings to {folder}: not a folder")
    if path.exists():
        raise QuadsimError(f"{path} already exists; choose another --out (nothing is overwritten)")
    if not os.access(folder, os.W_OK):
        raise QuadsimError(f"cannot write recordings to {folder}: permission denied (use --out DIR or --no-record)")
    free = shutil.disk_usage(folder).free
    if free < min_free_bytes:
        raise QuadsimError(
            f"only {free / 1e6:.0f} MB free in {folder}; recording needs at least "
            f"{min_free_bytes / 1e6:.0f} MB (free some space, use --out elsewhere, or --no-record)"
        )


def _live_model(model: T | None) -> T:
    if model is None:
        raise QuadsimError("a recording needs the description of a live run (with its vehicle and world)")
    return model


class McapRecorder:
    """A loop sink (commands, states) and a camera-frame sink that writes one MCAP file."""

    def __init__(
        self,
        path: Path,
        description: RunDescription,
        stream: BinaryIO | None = None,
        chunk_size: int = 4 * 1024 * 1024,
    ) -> None:
        self.path = path
        cameras = description.cameras
        self._hz = description.config.rates.physics_hz
        self._cameras = {c.name: c for c in cameras}
        self._own_stream = stream is None
        if stream is None:
            try:
                stream = open(path, "xb")
            except OSError as exc:
                raise QuadsimError(f"cannot create {path}: {exc.strerror}") from None
        self._stream = stream
        self._writer = Writer(stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self.counts: dict[str, int] = {}
        self.error: str | None = None
        self.closed = False
        self._flush_every_ns = 1_000_000_000
        self._next_flush_ns = self._flush_every_ns
        self._last_fsync_wall = time.monotonic()
        self._channels: dict[str, int] = {}
        self.last_log_time_ns = 0
        try:
            self._writer.start(profile="ros2", library=f"quadsim {__version__}")
            topics = [rm.TWIST, *rm.STATE_TOPICS, rm.TF_STATIC]
            for spec in cameras:
                topics += [rm.image_topic(spec), rm.camera_info_topic(spec)]
            for topic in topics:
                self._register(topic)
            self._write_metadata(description)
            vehicle = _live_model(description.vehicle_model)
            mounts = tuple((spec, vehicle.camera_mount(spec.link_name)) for spec in cameras)
            self._write(rm.TF_STATIC, 0, rm.tf_static_msg(mounts))
        except OSError as exc:
            self._fail(exc)

    # --- set-up -----------------------------------------------------------------------------

    def _register(self, topic: rm.Topic) -> int:
        schema = self._writer.register_schema(topic.type_name, "ros2msg", rm.schema_text(topic.type_name).encode())
        cid = self._writer.register_channel(topic.name, "cdr", schema, {"offered_qos_profiles": topic.qos})
        self._channels[topic.name] = cid
        self.counts[topic.name] = 0
        return cid

    def add_joy_topic(self) -> None:
        """Add /joy (done only when a joystick drives)."""
        if rm.JOY.name not in self._channels and self.error is None:
            self._register(rm.JOY)

    def _write_metadata(self, description: RunDescription) -> None:
        params = description.to_parameters()
        self._writer.add_metadata(
            METADATA_NAME,
            {
                "quadsim_version": __version__,
                "wall_clock_start_utc": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
                "time_base": "simulation time, ns from 0 (log_time = publish_time = header.stamp)",
                "parameters": json.dumps(params, sort_keys=True),
            },
        )
        v, world = _live_model(description.vehicle_model), _live_model(description.world_model)
        for path, media in (
            (v.urdf_path, "application/xml"),
            (v.params_path, "application/toml"),
            (world.path, "application/toml"),
        ):
            self._writer.add_attachment(0, 0, path.name, media, path.read_bytes())

    # --- sinks ------------------------------------------------------------------------------

    def ns(self, step: int) -> int:
        return step * 1_000_000_000 // self._hz

    def on_command(self, step: int, twist: Twist) -> None:
        self._write(rm.TWIST, self.ns(step), rm.twist_msg(twist))

    def on_state(self, state: VehicleState) -> None:
        ns = self.ns(state.step)
        self._write(rm.POSE, ns, rm.pose_msg(state, ns))
        self._write(rm.ODOM, ns, rm.odom_msg(state, ns))
        self._write(rm.IMU, ns, rm.imu_msg(state, ns))
        self._write(rm.ROTOR_THRUSTS, ns, rm.rotor_thrusts_msg(state))
        self._write(rm.TF, ns, rm.tf_msg(state, ns))

    def on_camera_frame(self, frame: CameraFrame) -> None:
        spec = self._cameras.get(frame.camera)
        if spec is None:
            return
        ns = self.ns(frame.step)
        self._write(rm.image_topic(spec), ns, rm.compressed_image_msg(frame, spec, ns))
        self._write(rm.camera_info_topic(spec), ns, rm.camera_info_msg(spec, ns))

    def note_event(self, step: int, kind: str, value: str) -> None:
        """Something a re-simulation must know besides the commands (a z-mode switch)."""
        if self.error is not None or self.closed:
            return
        try:
            self._writer.add_metadata(EVENT_METADATA_NAME, {"step": str(step), "kind": kind, "value": value})
        except OSError as exc:
            self._fail(exc)

    def on_joy(self, step: int, axes: tuple[float, ...], buttons: tuple[int, ...]) -> None:
        ns = self.ns(step)
        self._write(rm.JOY, ns, rm.joy_msg(axes, buttons, ns))

    # --- writing ----------------------------------------------------------------------------

    def _write(self, topic: rm.Topic, ns: int, msg: object) -> None:
        if self.error is not None or self.closed:
            return
        try:
            count = self.counts[topic.name]
            self._writer.add_message(
                self._channels[topic.name], log_time=ns, data=rm.serialize(msg), publish_time=ns, sequence=count
            )
            self.counts[topic.name] = count + 1
            if ns > self.last_log_time_ns:
                self.last_log_time_ns = ns
            if ns >= self._next_flush_ns:
                self._next_flush_ns = (ns // self._flush_every_ns + 1) * self._flush_every_ns
                self._writer.flush()
                self._maybe_fsync()
        except OSError as exc:
            self._fail(exc)

    def _maybe_fsync(self) -> None:
        now = time.monotonic()
        if now - self._last_fsync_wall >= 1.0 and hasattr(self._stream, "fileno"):
            self._last_fsync_wall = now
            try:
                os.fsync(self._stream.fileno())
            except (OSError, ValueError):
                pass

    def _fail(self, exc: OSError) -> None:
        reason = exc.strerror or str(exc)
        self.error = (
            f"recording stopped at sim time {self.last_log_time_ns / 1e9:.2f} s: {reason}. "
            f"What was written is kept; run 'quadsim recover {self.path}' to index it"
        )
        log.error("%s", self.error)
        try:
            self._stream.close() if self._own_stream else None
        except OSError:
            pass

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())

    def close(self) -> None:
        """Finish the file (summary, index, footer). Safe to call more than once."""
        if self.closed:
            return
        self.closed = True
        if self.error is not None:
            return
        try:
            self._writer.finish()
            if self._own_stream:
                self._stream.flush()
                os.fsync(self._stream.fileno())
                self._stream.close()
        except OSError as exc:
            self._fail(exc)
