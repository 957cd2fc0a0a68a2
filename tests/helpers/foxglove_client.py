"""An independent Foxglove WebSocket client, run as its own process by the tests.

Written from the protocol's specification (foxglove/ws-protocol docs/spec.md) on a generic
WebSocket library (`websockets`), not with foxglove-sdk: it subscribes to every channel the
server advertises, decodes what arrives (CDR, by the ros2msg schema the server advertises with
the channel, as the Foxglove apps do: mcap-ros2-support's decoder), and may advertise /quad_cmd_twist
(or --topic) and publish Twists on it, then go quiet. It prints one JSON report on stdout.

    python foxglove_client.py ws://127.0.0.1:8765 --listen-s 3 [--publish json|cdr --twist 1,0,0,0 --publish-s 2]
        [--subprotocol foxglove.websocket.v1] [--program '[[SECONDS, {"linear_x": V, ...}], ...]']

--program publishes its phases one after another (from --start-s) instead of one --twist.
--goal X,Y,Z,YAW_DEG publishes one geometry_msgs/PoseStamped goal at --start-s (in --goal-frame,
on --goal-topic: the 3D panel's "publish pose"), in --goal-encoding.

Every duration (--listen-s, --start-s, --publish-s, a phase's seconds) is simulated time: the log
time of the odometry it receives, from the first odometry message on. A client timed by the
wall clock flies less of its program when the simulation falls behind on a busy machine, and
the tests judge the flight in simulated time. --wall-limit-s bounds the whole client all the same.
"""

from __future__ import annotations

import argparse
import json
import math
import struct
import time
from typing import Any

import cv2
import numpy as np
from mcap_ros2._dynamic import generate_dynamic
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

#: the protocol's names: foxglove-sdk's (current apps) and the original one (older apps, ws-protocol)
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
MESSAGE_DATA = 0x01  # server binary opcode: subscription id u32, log time u64, payload
CLIENT_MESSAGE_DATA = 0x01  # client binary opcode: channel id u32, payload


def twist_payload(encoding: str, lx: float, ly: float, lz: float, az: float) -> bytes:
    if encoding == "json":
        return json.dumps({"linear": {"x": lx, "y": ly, "z": lz}, "angular": {"x": 0.0, "y": 0.0, "z": az}}).encode()
    # CDR little endian: encapsulation header 00 01 00 00, then six float64
    return b"\x00\x01\x00\x00" + struct.pack("<6d", lx, ly, lz, 0.0, 0.0, az)


def goal_payload(encoding: str, frame: str, x: float, y: float, z: float, yaw_deg: float) -> bytes:
    """A PoseStamped goal facing `yaw_deg`, as the 3D panel sends it (JSON) or as CDR."""
    qz, qw = math.sin(math.radians(yaw_deg) / 2), math.cos(math.radians(yaw_deg) / 2)
    if encoding == "json":
        pose = {"position": {"x": x, "y": y, "z": z}, "orientation": {"x": 0.0, "y": 0.0, "z": qz, "w": qw}}
        return json.dumps({"header": {"stamp": {"sec": 0, "nsec": 0}, "frame_id": frame}, "pose": pose}).encode()
    name = frame.encode() + b"\0"
    head = struct.pack("<iII", 0, 0, len(name)) + name
    head += b"\0" * (-len(head) % 8)  # the doubles align to 8
    return b"\x00\x01\x00\x00" + head + struct.pack("<7d", x, y, z, 0.0, 0.0, qz, qw)


def summarise(type_name: str, msg: Any) -> dict[str, Any]:
    """What the tests look at in a decoded message."""
    if type_name == "nav_msgs/msg/Odometry":
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
        return {"x": p.x, "y": p.y, "z": p.z, "yaw": yaw, "child": msg.child_frame_id}
    if type_name == "sensor_msgs/msg/CompressedImage":
        image = cv2.imdecode(np.frombuffer(bytes(msg.data), np.uint8), cv2.IMREAD_COLOR)
        return {
            "format": msg.format,
            "shape": list(image.shape) if image is not None else None,
            "mean": float(image.mean()) if image is not None else None,
        }
    if type_name == "sensor_msgs/msg/Image":
        return {"encoding": msg.encoding, "shape": [msg.height, msg.width], "frame": msg.header.frame_id}
    if type_name == "tf2_msgs/msg/TFMessage":
        return {"children": [t.child_frame_id for t in msg.transforms]}
    if type_name == "std_msgs/msg/String":
        return {"length": len(msg.data)}
    if type_name == "sensor_msgs/msg/Range":
        return {"frame": msg.header.frame_id, "range": msg.range, "variance": msg.variance}
    if type_name == "sensor_msgs/msg/LaserScan":
        finite = [r for r in msg.ranges if math.isfinite(r)]
        return {"frame": msg.header.frame_id, "beams": len(msg.ranges), "returns": len(finite)}
    if type_name == "sensor_msgs/msg/PointCloud2":
        return {"frame": msg.header.frame_id, "points": msg.width, "bytes": len(msg.data)}
    if type_name == "visualization_msgs/msg/MarkerArray":
        return {"markers": len(msg.markers), "frames": sorted({m.header.frame_id for m in msg.markers})}
    return {}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("url")
    ap.add_argument("--listen-s", type=float, default=2.0)
    ap.add_argument("--publish", choices=["json", "cdr"], default=None)
    ap.add_argument("--twist", default="0,0,0,0", help="linear x,y,z, angular z")
    ap.add_argument("--topic", default="/quad_cmd_twist", help="where the Twists go (a fleet vehicle's /NAME/...)")
    ap.add_argument("--publish-s", type=float, default=0.0)
    ap.add_argument("--start-s", type=float, default=0.0, help="wait this long before publishing")
    ap.add_argument("--program", type=json.loads, default=None, help="phases [[seconds, {field: value}], ...]")
    ap.add_argument("--goal", default=None, help="publish one goal X,Y,Z,YAW_DEG at --start-s")
    ap.add_argument("--goal-topic", default="/move_base_simple/goal")
    ap.add_argument("--goal-frame", default="world")
    ap.add_argument("--goal-encoding", choices=["json", "cdr"], default="json")
    ap.add_argument("--subprotocol", choices=SUBPROTOCOLS, action="append", help="offer this name (default: both)")
    ap.add_argument("--wall-limit-s", type=float, default=50.0, help="give up after this long on the wall clock")
    args = ap.parse_args()
    decoders: dict[int, Any] = {}  # channel id -> its schema's decoder
    channels: dict[int, dict[str, Any]] = {}
    subscriptions: dict[int, int] = {}  # subscription id -> channel id
    topics: dict[str, dict[str, Any]] = {}
    report: dict[str, Any] = {"topics": topics, "odom": [], "undecodable": 0}
    twist = [float(v) for v in args.twist.split(",")]
    if args.program is not None:
        args.publish_s = sum(seconds for seconds, _ in args.program)

    def twist_at(elapsed_s: float) -> list[float]:
        """The Twist (linear x, y, z, angular z) to publish `elapsed_s` after publishing began."""
        if args.program is None:
            return twist
        for seconds, fields in args.program:
            if elapsed_s < seconds:
                return [float(fields.get(f, 0.0)) for f in ("linear_x", "linear_y", "linear_z", "angular_z")]
            elapsed_s -= seconds
        return [0.0] * 4

    # max_queue=None: the library stops reading the socket while 16 frames it received wait to be
    # read; once this client stops reading and closes, the server's answer to the close waited
    # behind camera frames for the library's whole 10 s close timeout
    connection = connect(
        args.url, subprotocols=args.subprotocol or SUBPROTOCOLS, compression=None, max_size=None, max_queue=None
    )
    with connection as ws:
        report["subprotocol"] = ws.subprotocol
        wall_limit = time.monotonic() + args.wall_limit_s
        # simulated time (ns): the first odometry's log time, and the latest one's
        start_ns: int | None = None
        now_ns = 0
        published, next_publish, advertised = 0, time.monotonic(), False
        while time.monotonic() < wall_limit:
            elapsed_s = 0.0 if start_ns is None else (now_ns - start_ns) / 1e9
            if start_ns is not None and elapsed_s >= args.listen_s:
                break
            publishing = (
                args.publish and start_ns is not None and args.start_s <= elapsed_s < args.start_s + args.publish_s
            )
            if publishing and "serverInfo" in report and time.monotonic() >= next_publish:
                if not advertised:
                    ws.send(
                        json.dumps(
                            {
                                "op": "advertise",
                                "channels": [
                                    {
                                        "id": 7,
                                        "topic": args.topic,
                                        "encoding": args.publish,
                                        "schemaName": "geometry_msgs/msg/Twist",
                                    }
                                ],
                            }
                        )
                    )
                    advertised = True
                ws.send(
                    struct.pack("<BI", CLIENT_MESSAGE_DATA, 7)
                    + twist_payload(args.publish, *twist_at(elapsed_s - args.start_s))
                )
                published += 1
                next_publish = time.monotonic() + 0.05  # 20 Hz, as the Teleop panel and the joy node publish
            if args.goal and start_ns is not None and elapsed_s >= args.start_s and "goal_sent" not in report:
                goal_channel = {
                    "id": 8,
                    "topic": args.goal_topic,
                    "encoding": args.goal_encoding,
                    "schemaName": "geometry_msgs/msg/PoseStamped",
                }
                ws.send(json.dumps({"op": "advertise", "channels": [goal_channel]}))
                x, y, z, yaw = (float(v) for v in args.goal.split(","))
                ws.send(
                    struct.pack("<BI", CLIENT_MESSAGE_DATA, 8)
                    + goal_payload(args.goal_encoding, args.goal_frame, x, y, z, yaw)
                )
                report["goal_sent"] = elapsed_s
            try:
                frame = ws.recv(timeout=0.01)
            except TimeoutError:
                continue
            except ConnectionClosed:  # the run ended
                report["closed"] = True
                break
            if isinstance(frame, str):
                msg = json.loads(frame)
                if msg["op"] == "serverInfo":
                    report["serverInfo"] = msg
                elif msg["op"] == "advertise":
                    subscribe = []
                    for ch in msg["channels"]:
                        channels[ch["id"]] = ch
                        sub_id = len(subscriptions) + 100
                        subscriptions[sub_id] = ch["id"]
                        subscribe.append({"id": sub_id, "channelId": ch["id"]})
                    ws.send(json.dumps({"op": "subscribe", "subscriptions": subscribe}))
                elif msg["op"] == "status":
                    report.setdefault("status", []).append(msg["message"])
                continue
            if frame[0] != MESSAGE_DATA:
                continue
            sub_id, log_time_ns = struct.unpack_from("<IQ", frame, 1)
            ch = channels[subscriptions[sub_id]]
            payload = bytes(frame[13:])
            entry = topics.setdefault(
                ch["topic"],
                {
                    "count": 0,
                    "type": ch["schemaName"],
                    "encoding": ch["encoding"],
                    "schemaEncoding": ch.get("schemaEncoding"),
                },
            )
            entry["count"] += 1
            try:
                if ch["id"] not in decoders:
                    decoders[ch["id"]] = generate_dynamic(ch["schemaName"], ch["schema"])[ch["schemaName"]]
                decoded = decoders[ch["id"]](payload)
            except Exception:
                report["undecodable"] += 1
                continue
            summary = summarise(ch["schemaName"], decoded)
            entry.setdefault("first", summary)
            entry["last"] = summary
            entry["last_ns"] = log_time_ns
            if ch["schemaName"] == "nav_msgs/msg/Odometry":
                report["odom"].append([log_time_ns, summary["x"], summary["y"], summary["z"]])
                report["yaw"] = summary["yaw"]
                start_ns = log_time_ns if start_ns is None else start_ns
                now_ns = max(now_ns, log_time_ns)
        report["published"] = published
    print(json.dumps(report))


if __name__ == "__main__":
    main()
