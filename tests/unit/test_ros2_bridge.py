"""The ROS 2 bridge's parts that need no ROS 2 node.

Its unit tests (in-process, one part at a time); the others are in tests/e2e/test_ros2_bridge.py."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from quadsim.errors import QuadsimError
from quadsim.live.dds_types import dds_type_name, idl_type
from quadsim.live.ros2 import discovery_config, domain_id
from quadsim.recording import cdr
from quadsim.recording.reader import RecordingReader
from tests.e2e.test_ros2_bridge import RECORDING


def test_every_recorded_type_is_a_dds_type_that_reads_and_writes_the_recorded_bytes() -> None:
    with RecordingReader(RECORDING) as reader:
        channels = {ch.key: ch for ch in reader.file.channels}
        seen: dict[str, int] = {}
        for m in reader.file.messages(set(channels)):
            name = channels[m.channel.key].schema.name
            if seen.get(name, 0) >= 3:
                continue
            seen[name] = seen.get(name, 0) + 1
            assert idl_type(name).deserialize(m.data).serialize() == m.data
    assert {"tf2_msgs/msg/TFMessage", "nav_msgs/msg/Odometry", "sensor_msgs/msg/Imu"} <= set(seen)
    encoded = {  # the fan-out's other messages
        "sensor_msgs/msg/CompressedImage": cdr.compressed_image(5, "front_camera_optical", "jpeg", b"\xff\xd8\xff"),
        "sensor_msgs/msg/CameraInfo": cdr.camera_info(
            5, "f", 240, 320, "plumb_bob", (0.0,) * 5, (1.0,) * 9, (0.0,) * 9, (2.0,) * 12
        ),
        "sensor_msgs/msg/Joy": cdr.joy(5, "joy", (0.5, -1.0), (1, 0, 1)),
        "rcl_interfaces/msg/Log": cdr.log(5, cdr.LogLevel.INFO, "quadsim", "z-mode: height"),
        "std_msgs/msg/String": cdr.string("<robot/>"),
        "geometry_msgs/msg/Vector3Stamped": cdr.vector3_stamped(5, "world", (1.0, 2.0, 3.0)),
        "sensor_msgs/msg/Range": cdr.range_encoder("range_finder_link", 1, 0.06, 0.1, 12.0, 4e-4)(5, -math.inf),
        "sensor_msgs/msg/LaserScan": cdr.laser_scan_encoder("lidar_link", (-3.1, 3.1, 0.1), (0.0, 0.1), (0.1, 30.0))(
            5, np.array([1.5, math.inf], "<f4").tobytes()
        ),
        "sensor_msgs/msg/PointCloud2": cdr.xyz_cloud_encoder("lidar_link")(5, np.arange(6, dtype="<f4").tobytes()),
    }
    for name, data in encoded.items():
        assert idl_type(name).deserialize(data).serialize() == data, name
    assert dds_type_name("tf2_msgs/msg/TFMessage") == "tf2_msgs::msg::dds_::TFMessage_"
    assert idl_type("sensor_msgs/msg/Range").deserialize(encoded["sensor_msgs/msg/Range"]).variance == pytest.approx(
        4e-4
    )


def test_the_ros2_environment_is_read_as_ros2_reads_it() -> None:
    assert domain_id({}) == 0 and domain_id({"ROS_DOMAIN_ID": "42"}) == 42
    with pytest.raises(QuadsimError, match="ROS_DOMAIN_ID must be a whole number from 0 to 232, got '300'"):
        domain_id({"ROS_DOMAIN_ID": "300"})
    local = discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    assert local is not None and '<Peer address="127.0.0.1"/>' in local and "<AllowMulticast>false" in local
    assert discovery_config({"ROS_LOCALHOST_ONLY": "1"}) == local
    assert discovery_config({}) is None  # SUBNET, ROS 2's default: Cyclone's multicast discovery
    assert discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "CYCLONEDDS_URI": "file:///x.xml"}) is None
    off = discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"})
    assert off is not None and "<Peer" not in off
    with pytest.raises(QuadsimError, match="ROS_AUTOMATIC_DISCOVERY_RANGE must be SUBNET, LOCALHOST or OFF"):
        discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LAN"})


def test_the_window_flies_the_ros2_input(tmp_path: Path) -> None:
    pygame = pytest.importorskip("pygame")
    from quadsim.apps.window.teleop import TeleopApp, TeleopOptions
    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.session.outputs import OutputOptions
    from quadsim.session.pacing import FixedStepPacer
    from quadsim.sim.config import SimConfig

    driver = SubscribedDriver("ros2")
    options = TeleopOptions(input="ros2")
    outputs = OutputOptions(out=tmp_path, cameras=(), render_workers=0)
    with TeleopApp(SimConfig(), outputs, options, pacer=FixedStepPacer(240, 1 / 30), commands=driver) as app:

        def publish(a: TeleopApp) -> None:
            if a.frame_count < 60:
                driver.deliver((0.0, 0.0, 1.0), 0.0)  # climb 1 m/s for 2 s, from "another thread"
            pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_UP, mod=0, unicode="", scancode=0))

        app.run(max_frames=90, before_frame=publish)
        assert 1.5 < app.sim.state.position_m[2] < 2.6
        assert abs(app.sim.state.position_m[0]) < 0.05  # the keyboard's Up did not fly it
        assert app._model().input_status.startswith("ros2: Twists on /quad_cmd_twist")
