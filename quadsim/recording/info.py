"""`quadsim info`: what a recording holds (duration, topics, rates, the run's parameters), and,
for a damaged file, what is wrong and how much of it is readable."""

from __future__ import annotations

import datetime
import math
from dataclasses import dataclass
from pathlib import Path

from quadsim.core.types import LidarMode
from quadsim.recording.contract import CORE_TOPICS
from quadsim.recording.mcap_scan import Damage
from quadsim.recording.reader import RecordingReader
from quadsim.sim.description import RunDescription

#: log times between these read as a wall clock (another program's bag), shown as a date
_EPOCH_2000_S = 946_684_800.0
_EPOCH_2200_S = 7_258_118_400.0


@dataclass(frozen=True)
class TopicInfo:
    name: str
    type_name: str
    count: int
    rate_hz: float


@dataclass(frozen=True)
class RecordingInfo:
    path: Path
    size_bytes: int
    profile: str
    library: str
    start_s: float
    end_s: float
    topics: tuple[TopicInfo, ...]
    description: RunDescription | None
    description_error: str | None
    metadata: dict[str, str]
    attachments: tuple[str, ...]
    damage: tuple[Damage, ...] = ()
    notes: tuple[str, ...] = ()
    damage_report: str = ""  # one paragraph on the damage, when there is some

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    def missing_topics(self) -> list[str]:
        """Core topics a foreign file lacks (in quadsim's own, a topic with no message has no channel)."""
        if "quadsim_version" in self.metadata:
            return []
        have = {t.name for t in self.topics}
        return [t for t in CORE_TOPICS if t not in have]

    def _span(self) -> str:
        """quadsim's clock is simulation time from 0; another program's log time is its own
        (`ros2 bag record`'s is the wall clock: shown as a UTC date when it reads as one)."""
        if "quadsim_version" in self.metadata:
            return f"simulation time ({self.start_s:.2f} .. {self.end_s:.2f} s)"
        if _EPOCH_2000_S <= self.start_s < _EPOCH_2200_S:
            start = datetime.datetime.fromtimestamp(self.start_s, datetime.timezone.utc)
            return f"log time (from {start:%Y-%m-%d %H:%M:%S} UTC)"
        return f"log time ({self.start_s:.2f} .. {self.end_s:.2f} s)"

    def lines(self) -> list[str]:
        writer = self.library or "?"
        if "quadsim_version" in self.metadata and not writer.startswith("quadsim"):  # through foxglove-sdk
            writer = f"quadsim {self.metadata['quadsim_version']} ({writer})"
        out = [
            f"file        {self.path} ({self.size_bytes / 1e6:.2f} MB)",
            f"written by  {writer} (profile {self.profile or 'none'})",
            f"duration    {self.duration_s:.2f} s of {self._span()}",
        ]
        if "wall_clock_start_utc" in self.metadata:
            out.append(f"recorded    {self.metadata['wall_clock_start_utc']} (wall clock)")
        out.append("topics:")
        width = max((len(t.name) for t in self.topics), default=10)
        for t in self.topics:
            out.append(f"  {t.name:<{width}}  {t.type_name:<34} {t.count:7d} msgs  {t.rate_hz:6.1f} Hz")
        if self.attachments:
            out.append(f"attachments {', '.join(self.attachments)}")
        d = self.description
        if d is not None:
            out += _parameter_lines(d)
        elif self.description_error:
            out.append(f"run parameters: unreadable ({self.description_error})")
        else:
            out.append("run parameters: none (not recorded by quadsim)")
        if self.damage:
            out.append("damage:")
            out += [f"  {d.describe()}" for d in self.damage]
        if self.notes:
            out.append("notes:")
            out += [f"  {n}" for n in self.notes]
        return out


def _parameter_lines(d: RunDescription) -> list[str]:
    """What a recording's run description says: its vehicles, rates, wind, sensors and cameras."""
    out: list[str] = []
    cfg = d.config
    out.append("run parameters:")
    if d.fleet:
        out.append(f"  a fleet of {len(d.fleet)} vehicles:")
        out += [f"    {name}: {_vehicle_line(own)}" for name, own in d.fleet]
    else:
        out.append(f"  controller {d.controller.name}, z-mode {d.z_mode.value}, {_driver(d)}")
    out.append("  rates " + ", ".join(f"{k.replace('_hz', '')} {v} Hz" for k, v in cfg.rates.to_dict().items()))
    timeout = "off" if cfg.command_timeout_s is None else f"{cfg.command_timeout_s} s"
    if d.fleet:
        out.append(f"  command timeout {timeout}")
    else:
        out.append(
            f"  vehicle {d.vehicle.name} ({d.vehicle.rotor_count} rotors), mass {d.vehicle.mass_kg:.3f} kg, "
            f"command timeout {timeout}"
        )
    noise = "IMU noise on" if cfg.sensor_noise else "IMU noise off"
    wind = f"wind of its own ({d.wind_model.import_path})" if d.wind_model is not None else cfg.wind.describe()
    out.append(f"  {wind}, {noise}, seed {cfg.seed}")
    if (cfg.range_finder or cfg.lidar) and not d.fleet:
        out.append(_ranging_line(cfg.range_finder, cfg.lidar))
    for cam in d.cameras:
        out.append(
            f"  camera {cam.name}: {cam.width_px}x{cam.height_px} @ {cam.rate_hz} Hz, "
            f"vertical FOV {cam.vertical_fov_deg} deg, JPEG quality {cam.jpeg_quality}"
            + (f", depth {cam.depth}" if cam.depth else "")
            + (" colour-mapped" if cam.depth_colormap else "")
            + (", segmentation" if cam.segmentation else "")
        )
    return out


def _vehicle_line(d: RunDescription) -> str:
    """One fleet vehicle: airframe, start, controller, z-mode and input."""
    start = d.config.start
    return (
        f"{d.vehicle.name} ({d.vehicle.rotor_count} rotors, {d.vehicle.mass_kg:.3f} kg) from "
        f"x={start.x_m:g} y={start.y_m:g} m yaw={math.degrees(start.yaw_rad):g} deg, {d.controller.name}, "
        f"z-mode {d.z_mode.value}, {_driver(d)}"
    )


def _driver(d: RunDescription) -> str:
    """Its input, and the script it flew where it flew one."""
    script = d.driver.get("script")
    return f"driver {d.driver_name}" + (f" ({script})" if isinstance(script, str) and script else "")


def read_info(path: Path) -> RecordingInfo:
    """Summarise a recording from what is readable in it (every chunk's CRC verified); damage
    is listed in `damage`, and `damage_report` says what to do about it."""
    with RecordingReader(path, require_topics=False, allow_damage=True) as reader:
        f = reader.file
        t0, t1 = f.span_ns
        start, end = t0 / 1e9, t1 / 1e9
        duration = max(end - start, 1e-9)
        topics = []
        for ch in f.channels:
            count = f.counts.get(ch.key, 0)
            # a topic's rate over its own first and last message (over the file's span, a 60 Hz
            # topic of a 1 s file read 59 Hz)
            first, last = f.first_ns.get(ch.key), f.last_ns.get(ch.key)
            span = (last - first) / 1e9 if first is not None and last is not None and last > first else duration
            rate = (count - 1) / span if count > 1 else 0.0
            topics.append(TopicInfo(ch.topic, ch.schema.name if ch.schema else "?", count, rate))
        return RecordingInfo(
            path,
            f.size,
            reader.profile,
            reader.library,
            start,
            end,
            tuple(topics),
            reader.description,
            reader.description_error,
            reader.quadsim_metadata,
            tuple(dict.fromkeys(a.name for a in f.attachments)),
            tuple(reader.damage),
            tuple(reader.notes),
            f.damage_report() if reader.damage else "",
        )


def _ranging_line(range_finder: bool, lidar: LidarMode | None) -> str:
    """The ranging sensors a vehicle carried: "  range finder and 3d LiDAR"."""
    carried = ["range finder"] if range_finder else []
    return "  " + " and ".join([*carried, *([f"{lidar.value} LiDAR"] if lidar is not None else [])])
