"""The Foxglove bridge, from outside.

Its unit tests (in-process, one part at a time); the others are in tests/e2e/test_foxglove.py."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from quadsim.errors import QuadsimError
from quadsim.live.foxglove import parse_endpoint, twist_from_cdr, twist_from_json
from quadsim.recording import cdr
from tests.e2e.test_foxglove import IMAGES


@pytest.mark.parametrize("text", ["127.0.0.1:99999", "a:b:c", "host:port", "[::1", ""])
def test_a_bad_endpoint_is_refused(text: str) -> None:
    with pytest.raises(QuadsimError, match="--foxglove"):
        parse_endpoint(text)


def test_endpoints() -> None:
    assert parse_endpoint("0.0.0.0:9000") == ("0.0.0.0", 9000)
    assert parse_endpoint("9000") == ("127.0.0.1", 9000)
    assert parse_endpoint(":9000") == ("127.0.0.1", 9000)
    assert parse_endpoint("localhost") == ("localhost", 8765)
    assert parse_endpoint("[::1]:9000") == ("::1", 9000)


def test_twists_decode_from_json_and_cdr_in_both_byte_orders() -> None:
    assert twist_from_json(b'{"linear": {"x": 1, "y": -2.5}, "angular": {"z": 0.5}}') == ((1.0, -2.5, 0.0), 0.5)
    assert twist_from_cdr(cdr.twist((1.0, 2.0, 3.0), (4.0, 5.0, 6.0))) == ((1.0, 2.0, 3.0), 6.0)
    big_endian = b"\x00\x00\x00\x00" + struct.pack(">6d", 1.5, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert twist_from_cdr(big_endian) == ((1.5, 0.0, 0.0), 0.0)
    for bad in (b"[]", b'{"linear": {"x": "fast"}}', b"not json"):
        with pytest.raises(ValueError):
            twist_from_json(bad)
    with pytest.raises(ValueError):
        twist_from_cdr(b"\x00\x01\x00\x00" + bytes(8))


class _Collect:
    """A live consumer that keeps what it is handed."""

    def __init__(self) -> None:
        self.topics: list[str] = []
        self.messages: list[tuple[str, int]] = []

    def add_topic(self, topic) -> None:
        self.topics.append(topic.name)

    def on_messages(self, messages) -> None:
        self.messages += [(topic.name, ns) for topic, ns, _ in messages]

    def on_event(self, step: int, kind: str, value: str, vehicle: str = "") -> None:
        pass


def test_the_replay_window_hands_the_recording_to_its_feed_as_it_plays(tmp_path: Path) -> None:
    from quadsim.apps.window.replay import ReplayApp
    from quadsim.live.playback import RecordingFeed
    from quadsim.recording.flight import load_flight
    from tests.helpers.recording import record_flight

    path = tmp_path / "flight.mcap"
    record_flight(path)
    sink = _Collect()
    feed = RecordingFeed(path, [sink])
    assert {"/tf_static", "/quad/odom", *IMAGES} <= set(sink.topics)
    with ReplayApp(load_flight(path), (640, 360), frame_s=0.1, feed=feed) as app:
        app.run(max_frames=10)  # 1 s of playback
        played = list(sink.messages)
        assert played and max(ns for _, ns in played) <= app.t_ns <= 1_000_000_000
        assert [ns for _, ns in played] == sorted(ns for _, ns in played)
        assert {"/tf_static", "/quad/odom", *IMAGES} <= {name for name, _ in played}
        app.seek(0.0)  # back to the start: the latched topics again, as a late joiner gets them
        app.playing = False
        app.frame()
        assert sorted(name for name, _ in sink.messages[len(played) :]) == [
            "/robot_description",
            "/robot_markers",
            "/tf_static",
            "/world/markers",
        ]
