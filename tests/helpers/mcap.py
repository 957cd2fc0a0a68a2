"""A recording's messages decoded as ROS 2 messages (mcap-ros2-support), for tests that read what
was recorded without quadsim's own reader. Not a test module."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def decoded_messages(path: Path, topics: Sequence[str] | None = None) -> Iterator[tuple[Any, Any, Any]]:
    """(channel, message, decoded) for each message of `path` on `topics` (None: every topic), in
    the file's order."""
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(topics=topics):
            yield channel, message, decoded


def topic_messages(path: Path, topic: str) -> list[tuple[float, Any]]:
    """(log time in s, decoded message) for each message of `path` on `topic`."""
    return [(message.log_time / 1e9, decoded) for _, message, decoded in decoded_messages(path, [topic])]


def decoded_recording(path: Path) -> tuple[dict[str, list[tuple[int, Any]]], dict[str, dict[str, str]], list[str]]:
    """A recording read whole: topic -> [(log time in ns, decoded message)] in log-time order, its
    metadata records by name, and its attachments' names."""
    topics: dict[str, list[tuple[int, Any]]] = {}
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            topics.setdefault(channel.topic, []).append((message.log_time, decoded))
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        attachments = [a.name for a in reader.iter_attachments()]
    return topics, metadata, attachments
