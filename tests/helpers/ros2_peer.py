"""A ROS 2 node run with rclpy and rmw_fastrtps_cpp in a virtual environment of its own (the ROS 2
Jazzy or Kilted wheels), as a user's node would be: it flies quadsim with Twists and reads what
quadsim publishes. Not a test module: tests/e2e/test_ros2.py and the benchmark start it.

    python ros2_peer.py fly OUT.json [TOPIC [PREFIX]]
                                               climb, forward, left, turn; count every topic; read the
                                               graph (odometry on PREFIX/quad/odom: a namespace)
    python ros2_peer.py latency OUT.json       publish a new climb rate every 0.25 s; report when each went out
    python ros2_peer.py program OUT.json PHASES
                                               fly PHASES, JSON [[SECONDS, {"linear_x": V, ...}], ...]
    python ros2_peer.py goal OUT.json X,Y,Z,YAW_DEG TOPIC
                                               publish one PoseStamped goal (frame map) on TOPIC, as
                                               RViz's 2D Goal Pose does, and watch 9 s of the flight:
                                               once a line on standard input says quadsim heard the
                                               publisher (a person clicks seconds after start-up)
    python ros2_peer.py stop OUT.json          fly at what is ahead and stop 1 m before it, seeing it in
                                               /quad/scan alone (examples/stop_before_tower.py's loop)
    python ros2_peer.py fleet OUT.json NAME OTHER,...
                                               fly vehicle NAME of a fleet as `fly` does, on its
                                               /NAME/quad_cmd_twist; read its /NAME/quad/odom and
                                               the others' odometry

TOPIC is where the Twists go (default /quad_cmd_twist).
"""

from __future__ import annotations

import itertools
import json
import math
import statistics
import sys
import threading
import time
from typing import Any

import rclpy
from geometry_msgs.msg import PoseStamped, Twist, Vector3Stamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, Imu, Joy, LaserScan, PointCloud2, Range
from std_msgs.msg import Float64MultiArray, String
from visualization_msgs.msg import MarkerArray

WAIT_FOR_QUADSIM_S = 90.0
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: every contract topic the node can subscribe to with the wheels it has (no tf2_msgs: /tf is read off the graph)
TOPICS: dict[str, tuple[Any, Any]] = {
    "/quad/pose": (PoseStamped, 10),
    "/quad/imu": (Imu, 10),
    "/quad/rotor_thrusts": (Float64MultiArray, 10),
    "/quad/floor_camera/image_raw/compressed": (CompressedImage, 10),
    "/quad/front_camera/camera_info": (CameraInfo, 10),
    "/quad/floor_camera/camera_info": (CameraInfo, 10),
    "/quad/front_camera/depth/image_raw": (Image, 10),
    "/quad/front_camera/depth/camera_info": (CameraInfo, 10),
    "/quad/front_camera/segmentation/image_raw": (Image, 10),
    "/quad/front_camera/depth/colormap/compressed": (CompressedImage, 10),
    "/world/segmentation_labels": (String, LATCHED),
    "/robot_description": (String, LATCHED),
    "/world/markers": (MarkerArray, LATCHED),
    "/rosout": (Log, LATCHED),
    "/wind": (Vector3Stamped, 10),
    "/joy": (Joy, 10),
    "/quad/range": (Range, 10),
    "/quad/scan": (LaserScan, 10),
    "/quad/points": (PointCloud2, 10),
}
GRAPH_TOPICS = ("/quad/odom", "/tf", "/tf_static", "/clock")


def _endpoints(infos: list[Any]) -> list[dict[str, str]]:
    return [
        {
            "node": f"{i.node_namespace.rstrip('/')}/{i.node_name}",
            "type": i.topic_type,
            "durability": i.qos_profile.durability.name,
            "reliability": i.qos_profile.reliability.name,
        }
        for i in infos
    ]


def main() -> int:
    mode, out = sys.argv[1], sys.argv[2]
    program = json.loads(sys.argv[3]) if mode == "program" else []
    cmd_topic = sys.argv[3] if len(sys.argv) > 3 and mode not in ("program", "goal") else "/quad_cmd_twist"
    goal_topic = sys.argv[4] if mode == "goal" else ""
    prefix = f"/{sys.argv[3]}" if mode == "fleet" else ""  # a fleet vehicle's topics have its name in front
    if mode == "fly" and len(sys.argv) > 4:
        prefix = sys.argv[4]  # quadsim's namespace
    others = sys.argv[4].split(",") if mode == "fleet" else []
    if mode == "fleet":
        cmd_topic = f"{prefix}/quad_cmd_twist"
    rclpy.init()
    node = Node("quadsim_test_peer")
    print("peer: node up", flush=True)  # what a starter waits for (the benchmark starts its bridge then)
    clock_ns: list[int] = []
    odoms: list[dict[str, float]] = []
    images: list[bytes] = []
    formats: list[str] = []
    counts = dict.fromkeys(TOPICS, 0)
    first_clock_wall_s: list[float] = []

    def on_clock(m: Clock) -> None:
        if not clock_ns:
            first_clock_wall_s.append(time.time())
        clock_ns.append(m.clock.sec * 10**9 + m.clock.nanosec)

    node.create_subscription(Clock, "/clock", on_clock, 10)

    def on_odom(m: Odometry) -> None:
        p, q = m.pose.pose.position, m.pose.pose.orientation
        stamp = m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
        yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
        odoms.append({"ns": stamp, "x": p.x, "y": p.y, "z": p.z, "yaw": yaw, "frame": m.header.frame_id})

    frame_lag_ns: list[int] = []  # how far each front frame's stamp is behind the newest odometry's

    def on_image(m: CompressedImage) -> None:
        if odoms:
            frame_lag_ns.append(odoms[-1]["ns"] - (m.header.stamp.sec * 10**9 + m.header.stamp.nanosec))
        if not images:
            images.append(bytes(m.data))
            formats.append(m.format)
        else:
            images.append(b"")  # counted, not kept

    raw_images: dict[str, dict[str, Any]] = {}  # an Image topic -> what its last message said
    ranging: dict[str, dict[str, Any]] = {}  # a ranging topic -> what its last message said

    def counter(name: str) -> Any:
        def count(m: Any) -> None:
            counts[name] += 1
            if isinstance(m, Image):
                size = (m.height, m.width, m.step, len(m.data))
                raw_images[name] = {"encoding": m.encoding, "size": size, "frame": m.header.frame_id}
            elif isinstance(m, Range):  # the variance field is Jazzy's and Kilted's: it must read
                ranging[name] = {"range": m.range, "variance": m.variance, "frame": m.header.frame_id}
            elif isinstance(m, LaserScan):
                ranging[name] = {
                    "beams": len(m.ranges),
                    "ahead": m.ranges[len(m.ranges) // 2],
                    "frame": m.header.frame_id,
                }
            elif isinstance(m, PointCloud2):
                ranging[name] = {"points": m.width * m.height, "bytes": len(m.data), "frame": m.header.frame_id}

        return count

    node.create_subscription(Odometry, f"{prefix}/quad/odom", on_odom, 10)
    others_last: dict[str, dict[str, float]] = {}

    def other_odom(name: str) -> Any:
        def on(m: Odometry) -> None:
            p = m.pose.pose.position
            others_last[name] = {"x": p.x, "y": p.y, "z": p.z, "child": m.child_frame_id}

        return on

    for other in others:
        node.create_subscription(Odometry, f"/{other}/quad/odom", other_odom(other), 10)
    node.create_subscription(CompressedImage, "/quad/front_camera/image_raw/compressed", on_image, 10)
    if mode in ("fly", "goal"):
        for name, (kind, qos) in TOPICS.items():
            node.create_subscription(kind, name, counter(name), qos)
    pub = node.create_publisher(Twist, cmd_topic, 10)
    heard = threading.Event()  # goal mode: a line on standard input says quadsim heard goal_pub
    if mode == "goal":
        goal_pub = node.create_publisher(PoseStamped, goal_topic, 10)
        threading.Thread(target=lambda: sys.stdin.readline() and heard.set(), daemon=True).start()

    def spin_for(seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.005)

    started = time.monotonic()
    end = started + WAIT_FOR_QUADSIM_S
    while not clock_ns and time.monotonic() < end:  # quadsim is up once /clock comes
        rclpy.spin_once(node, timeout_sec=0.05)
    first_message_s = time.monotonic() - started if clock_ns else None
    sent: list[tuple[float, float]] = []  # (climb rate, wall time published)
    graph: dict[str, Any] = {}

    def sim_s() -> float:
        """quadsim's time: the latest /clock."""
        return clock_ns[-1] / 1e9

    def until_sim(seconds: float, every_20hz: Any = None) -> None:
        """Spin for `seconds` of simulated time (calling `every_20hz` every 0.05 s on the wall
        clock meanwhile): a node timed by the wall clock flies less of its program when the
        simulation falls behind on a busy machine, and the tests judge the flight in simulated
        time. Returns early once /clock has no publisher left: quadsim has ended."""
        end = sim_s() + seconds
        while sim_s() < end and node.count_publishers("/clock") > 0:
            if every_20hz is not None:
                every_20hz()
            spin_for(0.05)  # 20 Hz, as teleop_twist_joy repeats

    def send(seconds: float, **fields: float) -> None:
        m = Twist()
        for name, value in fields.items():
            part, axis = name.split("_")
            setattr(getattr(m, part), axis, value)

        def publish() -> None:
            pub.publish(m)
            sent.append((m.linear.z, time.time()))

        until_sim(seconds, publish)

    if clock_ns and mode in ("fly", "fleet"):
        send(2.5, linear_z=1.0)  # climb 1 m/s
        send(1.5, linear_x=1.0)  # forward 1 m/s
        send(1.5, linear_y=1.0)  # left 1 m/s
        send(2.0, angular_z=0.5)  # turn left 0.5 rad/s
        graph["nodes"] = sorted(f"{ns.rstrip('/')}/{name}" for name, ns in node.get_node_names_and_namespaces())
        graph["publishers"] = {t: _endpoints(node.get_publishers_info_by_topic(t)) for t in GRAPH_TOPICS}
        graph["subscriptions"] = _endpoints(node.get_subscriptions_info_by_topic(cmd_topic))
        until_sim(1.0)  # silence: quadsim holds after its dead-man timeout
    elif clock_ns and mode == "goal":
        x, y, z, yaw_deg = (float(v) for v in sys.argv[3].split(","))
        waited = time.monotonic() + 30.0
        # RViz publishes once, when the user clicks: here, once quadsim has said it heard this
        # publisher (a goal written before its reader matched the publisher is lost: DDS) and the
        # publisher has matched quadsim's reader (its own count, not the graph's)
        while not (heard.is_set() and goal_pub.get_subscription_count() > 0) and time.monotonic() < waited:
            spin_for(0.05)
        goal = PoseStamped()
        goal.header.frame_id = "map"
        goal.pose.position.x, goal.pose.position.y, goal.pose.position.z = x, y, z
        goal.pose.orientation.z = math.sin(math.radians(yaw_deg) / 2)
        goal.pose.orientation.w = math.cos(math.radians(yaw_deg) / 2)
        goal_pub.publish(goal)  # once, as RViz does
        until_sim(9.0)
    elif clock_ns and mode == "stop":
        scans: list[Any] = []
        node.create_subscription(LaserScan, "/quad/scan", scans.append, 10)

        def nearest_ahead() -> float:
            """The nearest return within 15 deg of straight ahead (REP 117: -inf is nearer than the minimum)."""
            if not scans:
                return math.inf
            m = scans[-1]
            ahead = [r for i, r in enumerate(m.ranges) if abs(m.angle_min + i * m.angle_increment) <= math.radians(15)]
            return (
                0.0
                if any(r == -math.inf for r in ahead)
                else min((r for r in ahead if math.isfinite(r)), default=math.inf)
            )

        def steer() -> None:
            z = odoms[-1]["z"] if odoms else 0.0
            m = Twist()
            m.linear.z = max(-1.0, min(1.0, 1.5 * (1.2 - z)))
            if z >= 0.96:
                m.linear.x = max(0.0, min(1.0, 0.8 * (nearest_ahead() - 1.0)))
            pub.publish(m)

        until_sim(12.0, steer)
        graph["nearest_ahead_m"] = nearest_ahead()
    elif clock_ns and mode == "program":
        for seconds, fields in program:
            send(seconds, **fields)
    elif clock_ns and mode == "latency":
        for k in range(24):
            m = Twist()
            m.linear.z = 0.3 + 0.01 * k  # a new value each time, to be found on quadsim's side
            spin_for(0.25)  # one change at a time
            sent.append((m.linear.z, time.time()))
            pub.publish(m)
        spin_for(0.5)
    report = {
        "first_message_s": first_message_s,
        "first_clock_wall_s": first_clock_wall_s[0] if first_clock_wall_s else None,
        "clock_ns": clock_ns[:1] + clock_ns[-1:],
        "clock_count": len(clock_ns),
        # a use_sim_time node's time jumps back (tf2 and RViz clear their buffers) at each of these
        "clock_backward": sum(b < a for a, b in itertools.pairwise(clock_ns)),
        "clock_repeated": sum(b == a for a, b in itertools.pairwise(clock_ns)),
        "clock_smallest_step_ns": min((b - a for a, b in itertools.pairwise(clock_ns)), default=0),
        "odom_count": len(odoms),
        "odom_last": odoms[-1] if odoms else None,
        "odoms": odoms[-50:],
        "image_count": len(images),
        "frame_lag_median_s": statistics.median(frame_lag_ns) / 1e9 if frame_lag_ns else None,
        "frame_lag_max_s": max(frame_lag_ns) / 1e9 if frame_lag_ns else None,
        "image_format": formats[0] if formats else None,
        "image_hex": images[0].hex() if images else "",
        "counts": counts,
        "raw_images": raw_images,
        "ranging": ranging,
        "graph": graph,
        "sent": sent,
        "others_last": others_last,
    }
    with open(out, "w") as f:
        json.dump(report, f)
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
