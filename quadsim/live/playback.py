"""A recording played to a live consumer (the Foxglove bridge): its messages, as recorded, handed
over as playback time passes them, so `replay --foxglove` shows in Foxglove what the window plays.

Only the channels a live bridge can serve are played: CDR with a `ros2msg` schema (every topic of
a quadsim recording, and of ROS 2 bags). Seeking back plays again from the start of the file up
to the new time the latched topics' last messages only, as a late joiner would get them.

A consumer that follows the clock (the ROS 2 bridge's /clock, `on_clock`) hears the playback time
at each recorded log time, before that time's messages, strictly increasing; a seek back or a loop
restarting is told as a seek (time jumps back there, as `ros2 bag play` does).
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Sequence
from pathlib import Path

from quadsim.recording.contract import QOS_LATCHED, QOS_VOLATILE, Topic
from quadsim.recording.fanout import ClockConsumer, Message, TopicConsumer
from quadsim.recording.reader import RecordingReader


class RecordingFeed:
    """The servable messages of a recording, in log-time order, handed to `consumers` by
    `play_to(t_ns)`."""

    def __init__(self, path: Path, consumers: Sequence[TopicConsumer]) -> None:
        self.consumers = list(consumers)
        self.messages: list[Message] = []
        with RecordingReader(path, require_topics=False, allow_damage=True) as reader:
            f = reader.file
            topics: dict[int, Topic] = {}
            for ch in f.channels:
                s = ch.schema
                if ch.message_encoding == "cdr" and s is not None and s.encoding == "ros2msg":
                    topics[ch.key] = Topic(ch.topic, s.name, ch.metadata.get("offered_qos_profiles", QOS_VOLATILE))
            for m in f.messages(set(topics)):
                self.messages.append((topics[m.channel.key], m.log_time, m.data))
        self._times = [m[1] for m in self.messages]
        self.topics = list({t.name: t for t, _, _ in self.messages}.values())
        for consumer in self.consumers:
            for topic in self.topics:
                consumer.add_topic(topic)
        self._next = 0  # index of the next message to hand over
        self.played = 0
        self._clocks: list[ClockConsumer] = [c for c in self.consumers if callable(getattr(c, "on_clock", None))]  # type: ignore[misc]

    @property
    def end_ns(self) -> int:
        return self._times[-1] if self._times else 0

    def play_to(self, t_ns: int) -> None:
        """Hand over every message up to `t_ns`; back in time, start again there (latched first)."""
        end = bisect_right(self._times, t_ns)
        if end < self._next:
            for consumer in self._clocks:
                consumer.on_clock(self._times[end - 1] if end else 0, seek=True)
            latched = {m[0].name: m for m in self.messages[:end] if m[0].qos == QOS_LATCHED}
            self._send(list(latched.values()))
            self._next = end
            return
        start, self._next = self._next, end
        if not self._clocks:
            self._send(self.messages[start:end])
            return
        times = self._times
        while start < end:  # each log time: the clock, then its messages
            same = bisect_right(times, times[start], start, end)
            for consumer in self._clocks:
                consumer.on_clock(times[start])
            self._send(self.messages[start:same])
            start = same

    def _send(self, messages: list[Message]) -> None:
        if not messages:
            return
        for consumer in self.consumers:
            consumer.on_messages(messages)
        self.played += len(messages)
