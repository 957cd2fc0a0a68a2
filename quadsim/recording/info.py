"""`quadsim info`: what a recording holds (duration, topics, rates, the run's parameters),
or, for a damaged file, what is wrong and how much of it is readable."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from quadsim.errors import QuadsimError
from quadsim.recording.contract import CORE_TOPICS
from quadsim.recording.reader import RecordingReader
from quadsim.recording.salvage import damage_report


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
    parameters: dict | None
    metadata: dict[str, str]
    attachments: tuple[str, ...]

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    def missing_topics(self) -> list[str]:
        """Core topics a foreign file lacks (in quadsim's own, a topic with no message has no channel)."""
        if "quadsim_version" in self.metadata:
            return []
        have = {t.name for t in self.topics}
        return [t for t in CORE_TOPICS if t not in have]

    def lines(self) -> list[str]:
        writer = self.library or "?"
        if "quadsim_version" in self.metadata and not writer.startswith("quadsim"):  # through foxglove-sdk
            writer = f"quadsim {self.metadata['quadsim_version']} ({writer})"
        out = [
            f"file        {self.path} ({self.size_bytes / 1e6:.2f} MB)",
            f"written by  {writer} (profile {self.profile or 'none'})",
            f"duration    {self.duration_s:.2f} s of simulation time ({self.start_s:.2f} .. {self.end_s:.2f} s)",
        ]
        if "wall_clock_start_utc" in self.metadata:
            out.append(f"recorded    {self.metadata['wall_clock_start_utc']} (wall clock)")
        out.append("topics:")
        width = max((len(t.name) for t in self.topics), default=10)
        for t in self.topics:
            out.append(f"  {t.name:<{width}}  {t.type_name:<34} {t.count:7d} msgs  {t.rate_hz:6.1f} Hz")
        if self.attachments:
            out.append(f"attachments {', '.join(self.attachments)}")
        p = self.parameters
        if p:
            cfg = p.get("config", {})
            rates = cfg.get("rates", {})
            out.append("run parameters:")
            out.append(
                f"  controller {p.get('controller', {}).get('name', '?')}, z-mode {cfg.get('z_mode', '?')}, "
                f"driver {p.get('driver', {}).get('name', '?')}"
                + (f" ({p['driver'].get('script')})" if p.get("driver", {}).get("script") else "")
            )
            out.append("  rates " + ", ".join(f"{k.replace('_hz', '')} {v} Hz" for k, v in rates.items()))
            out.append(
                f"  vehicle {p.get('vehicle', {}).get('name', '?')}, mass {p.get('vehicle', {}).get('mass_kg', 0):.3f} kg, "
                f"command timeout {cfg.get('command_timeout_s')} s"
            )
            for cam in p.get("cameras", []):
                out.append(
                    f"  camera {cam['name']}: {cam['width_px']}x{cam['height_px']} @ {cam['rate_hz']} Hz, "
                    f"vertical FOV {cam['vertical_fov_deg']} deg, JPEG quality {cam['jpeg_quality']}"
                )
        else:
            out.append("run parameters: none (not recorded by quadsim)")
        return out


def read_info(path: Path) -> RecordingInfo:
    """Summarise a complete recording; raise QuadsimError saying what is wrong otherwise."""
    with RecordingReader(path, require_topics=False) as reader:
        header, summary, ours = reader.header, reader.summary, reader.quadsim_metadata
        attachments = tuple(reader.attachments())
    stats = summary.statistics
    if stats is None:
        raise QuadsimError(damage_report(path))
    start, end = stats.message_start_time / 1e9, stats.message_end_time / 1e9
    duration = max(end - start, 1e-9)
    topics = []
    for cid, ch in sorted(summary.channels.items()):
        schema = summary.schemas.get(ch.schema_id)
        count = stats.channel_message_counts.get(cid, 0)
        topics.append(
            TopicInfo(ch.topic, schema.name if schema else "?", count, (count - 1) / duration if count > 1 else 0.0)
        )
    return RecordingInfo(
        path,
        path.stat().st_size,
        header.profile,
        header.library,
        start,
        end,
        tuple(topics),
        reader.parameters,
        ours,
        attachments,
    )
