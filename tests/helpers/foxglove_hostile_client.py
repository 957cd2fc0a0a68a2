"""A hostile Foxglove client, run as its own process by the tests: what a broken or malicious
client sends (huge names, numbers no float holds, deep nesting, floods), over the protocol on a
generic WebSocket library. It reconnects whenever the server closes it and prints one JSON report.

    python foxglove_hostile_client.py ws://127.0.0.1:8765 [--subprotocol foxglove.websocket.v1]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import struct
import time
from collections.abc import Iterator
from typing import Any

from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidStatus
from websockets.sync.client import ClientConnection, connect

TWIST = "/quad_cmd_twist"
HUGE_NAME_BYTES = 5 * 1024 * 1024
CONNECTIONS = 24


def advertise(channel_id: int, topic: str, encoding: str = "json", schema: str = "geometry_msgs/msg/Twist") -> str:
    channel = {"id": channel_id, "topic": topic, "encoding": encoding, "schemaName": schema}
    return json.dumps({"op": "advertise", "channels": [channel]})


def data(channel_id: int, payload: bytes) -> bytes:
    return struct.pack("<BI", 0x01, channel_id) + payload


def cases() -> Iterator[tuple[str, list[str | bytes]]]:
    """(case, frames in order); each case starts on a fresh connection."""
    huge = "/" + "x" * HUGE_NAME_BYTES
    yield "huge_topic_names", [advertise(100 + i, huge + str(i)) for i in range(30)]
    yield "many_channels", [advertise(200 + i, f"/spam/{i}" + "y" * 200) for i in range(200)]
    big_number = b'{"linear": {"x": ' + b"9" * 400 + b"}}"
    yield "400_digit_number", [advertise(7, TWIST), *[data(7, big_number)] * 300]
    deep = b'{"linear": ' + b"[" * 100_000 + b"]" * 100_000 + b"}"
    yield "100000_deep_array", [advertise(7, TWIST), *[data(7, deep)] * 50]
    yield "flood_bad_twists", [advertise(7, TWIST), *[data(7, b"{not json")] * 2000]
    yield (
        "flood_bad_json_ops",
        [
            "{" * 1000,
            '{"op": []}',
            '{"op": "unadvertise", "channelIds": [[1]]}',
            *['{"op": "' + "z" * 1000 + '"}'] * 2000,
        ],
    )
    yield "flood_unadvertised_data", [data(99, b"\x00" * 100)] * 2000
    requests = [  # forwarded to the SDK, which answers the asking client
        {"op": "subscribe", "subscriptions": [{"id": 5, "channelId": 99_999}]},
        {"op": "unsubscribe", "subscriptionIds": [77_777]},
        {"op": "fetchAsset", "uri": "file:///etc/passwd", "requestId": 1},
        {"op": "getParameters", "parameterNames": ["x" * 1000]},
    ]
    yield "flood_requests_the_sdk_answers", [json.dumps(requests[i % 4]) for i in range(2000)]
    yield (
        "panel_topics",
        [
            advertise(11, "/clicked_point", schema="geometry_msgs/msg/PointStamped"),
            advertise(12, "/move_base_simple/goal", schema="geometry_msgs/msg/PoseStamped"),
            advertise(13, "/initialpose", schema="geometry_msgs/msg/PoseWithCovarianceStamped"),
        ],
    )


def drain(ws: ClientConnection, report: dict[str, Any], case: str) -> None:
    while True:
        try:
            frame = ws.recv(timeout=0)
        except TimeoutError:
            return
        if isinstance(frame, str):
            msg = json.loads(frame)
            if msg.get("op") == "status":
                report["status"].setdefault(case, []).append(msg["message"][:200])
                report["status_bytes"] += len(frame)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("url")
    ap.add_argument("--subprotocol", default="foxglove.websocket.v1")
    args = ap.parse_args()
    report: dict[str, Any] = {"status": {}, "status_bytes": 0, "closed": {}, "sent": {}, "seconds": {}}
    for case, frames in cases():
        start = time.monotonic()
        sent = 0
        try:
            with connect(args.url, subprotocols=[args.subprotocol], compression=None, max_size=None) as ws:
                for frame in frames:
                    ws.send(frame)
                    sent += 1
                    drain(ws, report, case)
                ws.send(json.dumps({"op": "subscribe", "subscriptions": []}))  # then wait a little for statuses
                deadline = time.monotonic() + 1.0
                while time.monotonic() < deadline:
                    drain(ws, report, case)
                    time.sleep(0.05)
        except (ConnectionClosed, InvalidHandshake, OSError) as exc:
            code = getattr(getattr(exc, "rcvd", None), "code", None)
            report["closed"][case] = code if code is not None else type(exc).__name__
        report["sent"][case] = sent
        report["seconds"][case] = round(time.monotonic() - start, 2)
    # many connections at once: past the server's limit, each further one is refused
    held, refused = 0, []
    with contextlib.ExitStack() as stack:
        for _ in range(CONNECTIONS):
            try:
                stack.enter_context(connect(args.url, subprotocols=[args.subprotocol], compression=None))
                held += 1
            except InvalidStatus as exc:
                refused.append(exc.response.status_code)
            except (InvalidHandshake, OSError) as exc:
                refused.append(type(exc).__name__)
    report["connections"] = {"held": held, "refused": refused}
    print(json.dumps(report))


if __name__ == "__main__":
    main()
