"""A recording's messages fed to live consumers (the ROS 2 bridge) as its playback time moves:
the bytes as recorded, each topic with the QoS it was recorded with."""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Sequence
from pathlib import Path

from quadsim.recording.contract import QOS_VOLATILE, Topic
from quadsim.recording.fanout import Message, TopicConsumer
from quadsim.recording.reader import RecordingReader


class RecordedFeed:
    """The ROS 2 (CDR) messages of a recording, in log-time order, handed to `consumers` up to the
    playback time given to `advance`. Going back (a seek, a loop) plays on from there."""

    def __init__(self, path: Path | str, consumers: Sequence[TopicConsumer]) -> None:
        self.consumers = list(consumers)
        self.messages: list[Message] = []
        with RecordingReader(path, require_topics=False, allow_damage=True) as reader:
            topics: dict[int, Topic] = {}
            for ch in reader.file.channels:
                if ch.message_encoding == "cdr" and ch.schema is not None and ch.schema.encoding == "ros2msg":
                    qos = ch.metadata.get("offered_qos_profiles") or QOS_VOLATILE
                    topics[ch.key] = Topic(ch.topic, ch.schema.name, qos)
            self.messages = [(topics[m.channel.key], m.log_time, m.data) for m in reader.file.messages(set(topics))]
        self.messages.sort(key=lambda m: m[1])
        self._times = [ns for _, ns, _ in self.messages]
        self._next = 0  # index of the first message not yet played
        self._played_ns = -1
        for topic in dict.fromkeys(t for t, _, _ in self.messages):
            for consumer in self.consumers:
                consumer.add_topic(topic)

    def advance(self, t_ns: int) -> int:
        """Hand over the messages logged up to `t_ns`; returns how many."""
        if t_ns < self._played_ns:
            self._next = bisect_right(self._times, t_ns)
            self._played_ns = t_ns
            return 0
        end = bisect_right(self._times, t_ns)
        batch = self.messages[self._next : end]
        self._next, self._played_ns = end, t_ns
        if batch:
            for consumer in self.consumers:
                consumer.on_messages(batch)
        return len(batch)
