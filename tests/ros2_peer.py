"""A ROS 2 node run with rclpy and rmw_fastrtps_cpp in a virtual environment of its own (the ROS 2
Jazzy wheels), as a user's node would be: it flies quadsim over /quad_cmd_twist and reads what
quadsim publishes. Not a test module: tests/test_ros2.py and the benchmark start it.

    python ros2_peer.py fly OUT.json     climb, then fly forward; report odometry, images, /clock
    python ros2_peer.py latency OUT.json publish a new climb rate every 0.25 s; report when each went out
"""

from __future__ import annotations

import json
import sys
import time

import rclpy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CompressedImage

WAIT_FOR_QUADSIM_S = 90.0


def main() -> int:
    mode, out = sys.argv[1], sys.argv[2]
    rclpy.init()
    node = Node("quadsim_test_peer")
    clock_ns: list[int] = []
    odoms: list[dict[str, float]] = []
    images: list[bytes] = []
    formats: list[str] = []
    node.create_subscription(Clock, "/clock", lambda m: clock_ns.append(m.clock.sec * 10**9 + m.clock.nanosec), 10)

    def on_odom(m: Odometry) -> None:
        p = m.pose.pose.position
        odoms.append(
            {
                "ns": m.header.stamp.sec * 10**9 + m.header.stamp.nanosec,
                "x": p.x,
                "y": p.y,
                "z": p.z,
                "frame": m.header.frame_id,
            }
        )

    def on_image(m: CompressedImage) -> None:
        if not images:
            images.append(bytes(m.data))
            formats.append(m.format)
        else:
            images.append(b"")  # counted, not kept

    node.create_subscription(Odometry, "/quad/odom", on_odom, 10)
    node.create_subscription(CompressedImage, "/quad/front_camera/image_raw/compressed", on_image, 10)
    pub = node.create_publisher(Twist, "/quad_cmd_twist", 10)

    def spin_for(seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.005)

    end = time.monotonic() + WAIT_FOR_QUADSIM_S
    while not clock_ns and time.monotonic() < end:  # quadsim is up once /clock comes
        rclpy.spin_once(node, timeout_sec=0.05)
    sent: list[tuple[float, float]] = []  # (climb rate, wall time published)

    def send(vx: float, vz: float, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            m = Twist()
            m.linear.x, m.linear.z = vx, vz
            pub.publish(m)
            sent.append((vz, time.time()))
            spin_for(0.05)  # 20 Hz, as teleop_twist_joy repeats

    if clock_ns and mode == "fly":
        send(0.0, 1.0, 2.5)  # climb 1 m/s
        send(1.0, 0.0, 2.5)  # forward 1 m/s
        spin_for(1.0)  # silence: quadsim holds after its dead-man timeout
    elif clock_ns and mode == "latency":
        for k in range(24):
            m = Twist()
            m.linear.z = 0.3 + 0.01 * k  # a new value each time, to be found on quadsim's side
            spin_for(0.25)  # one change at a time
            sent.append((m.linear.z, time.time()))
            pub.publish(m)
        spin_for(0.5)
    report = {
        "clock_ns": clock_ns[:1] + clock_ns[-1:],
        "clock_count": len(clock_ns),
        "odom_count": len(odoms),
        "odom_last": odoms[-1] if odoms else None,
        "odoms": odoms[-50:],
        "image_count": len(images),
        "image_format": formats[0] if formats else None,
        "image_hex": images[0].hex() if images else "",
        "sent": sent,
    }
    with open(out, "w") as f:
        json.dump(report, f)
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
