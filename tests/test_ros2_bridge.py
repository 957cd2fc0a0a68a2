"""The ROS 2 bridge's parts that need no ROS 2 node: the DDS types against recorded bytes, the
environment ROS 2 users set, the recorded feed of replay --ros2, the window and `run` flown by
ROS 2 input, and a real SIGTERM ending `run --input ros2`. (tests/test_ros2.py flies it from rclpy.)"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from quadsim.errors import QuadsimError
from quadsim.live.dds_types import dds_type_name, idl_type
from quadsim.live.ros2 import discovery_config, domain_id
from quadsim.recording import cdr
from quadsim.recording.reader import RecordingReader
from tests.helpers import ROOT
from tests.helpers.ros2_env import free_domain, local_env

RECORDING = ROOT / "tests" / "recordings" / "keyboard_session_cascade.mcap"


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
    }
    for name, data in encoded.items():
        assert idl_type(name).deserialize(data).serialize() == data, name
    assert dds_type_name("tf2_msgs/msg/TFMessage") == "tf2_msgs::msg::dds_::TFMessage_"


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


class _Collect:
    def __init__(self) -> None:
        self.topics: list[str] = []
        self.messages: list[tuple[str, int, bytes]] = []

    def add_topic(self, topic) -> None:
        self.topics.append(topic.name)

    def on_messages(self, messages) -> None:
        self.messages += [(t.name, ns, data) for t, ns, data in messages]

    def on_event(self, step: int, kind: str, value: str, vehicle: str = "") -> None:
        pass


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


def test_run_with_ros2_input_ends_on_sigterm_with_its_recording_finished(tmp_path: Path) -> None:
    recording = tmp_path / "ros2.mcap"
    env = local_env(free_domain())
    proc = subprocess.Popen(
        [sys.executable, str(ROOT / "main.py"), "run", "--input", "ros2", "--cameras", "none", "--out", str(recording)],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()
    while line and not line.startswith("recording to"):
        line = proc.stdout.readline()
    time.sleep(1.0)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "the recording is finished and readable" in err
    with RecordingReader(recording) as reader:
        assert reader.topic_counts()["/quad/odom"] > 10
        assert reader.description is not None


def test_ros2_input_and_a_script_are_refused_together() -> None:
    proc = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "run", "--input", "ros2", "--script", "hover"],
        env=local_env(free_domain()),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        "quadsim: error: --script, --commands-from and --input ros2 each say where commands come from; give one"
    )


def _clock_reader(domain: int) -> tuple[object, object]:
    """A reader of /clock in a participant of its own (as a use_sim_time node has), in this process."""
    from cyclonedds.core import Policy, Qos
    from cyclonedds.domain import DomainParticipant
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic

    participant = DomainParticipant(domain)
    topic = Topic(participant, "rt/clock", idl_type("rosgraph_msgs/msg/Clock"))
    qos = Qos(Policy.Reliability.Reliable(max_blocking_time=0), Policy.History.KeepAll)
    return participant, DataReader(participant, topic, qos=qos)


def _clock_read(reader) -> list[int]:
    """Every /clock sample the reader holds, in ns, in the order they came."""
    return [m.clock.sec * 1_000_000_000 + m.clock.nanosec for m in reader.take(100_000)]


def test_clock_is_the_states_time_strictly_increasing_whatever_frames_arrive_late() -> None:
    """/clock as a use_sim_time node reads it: one tick per state, before that state's messages,
    strictly increasing, though camera frames come in after the states that followed them (as
    render workers hand them over); back in time only at a reset to step 0, once."""
    from quadsim.core.types import VehicleState
    from quadsim.live.ros2 import Ros2Bridge
    from quadsim.recording.fanout import TopicFanout
    from quadsim.sensors.camera import CameraFrame, default_cameras
    from quadsim.vehicle.params import load_vehicle

    domain = free_domain(7)
    vehicle = load_vehicle()
    cameras = tuple((spec, vehicle.camera_mount(spec.link_name)) for spec in default_cameras())
    fanout = TopicFanout(240)
    producer = fanout.add_vehicle(cameras=cameras, vehicle=vehicle)
    with Ros2Bridge(env=local_env(domain)) as bridge:
        _participant, reader = _clock_reader(domain)
        fanout.add_consumer(bridge)

        def state(step: int) -> VehicleState:
            return VehicleState(
                step, (0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0), (0.0,) * 3, (0.0,) * 3, (1.0,) * 4, (0, 0, 9.81)
            )

        def frames(step: int) -> None:  # both cameras' frames of `step`, late
            for spec, _ in cameras:
                producer.on_camera_frame(CameraFrame(spec.name, step, b"\xff\xd8\xff\xd9", 320, 240))

        for step in range(4, 97, 4):  # 60 Hz states; each 30 Hz frame arrives two states after its step
            producer.on_state(state(step))
            if step % 8 == 0 and step >= 24:
                frames(step - 16)
        producer.on_state(state(96))  # the same step again (a fleet's second vehicle): no tick
        for step in (4, 8):  # the window's reset: back to step 0
            producer.on_state(state(step))
        frames(88)  # a frame rendered before the reset, arriving after it
        producer.on_state(state(12))
        clock = _clock_read(reader)
    ns = [step * 1_000_000_000 // 240 for step in range(4, 97, 4)]
    assert clock == [*ns, ns[0], ns[1], ns[2]]
    assert bridge.published > 0  # the frames went out, stamped as they were


def test_replay_clock_follows_the_recorded_times_and_jumps_back_only_on_a_seek() -> None:
    """replay --ros2: /clock at each recorded log time, before its messages, strictly increasing;
    a seek back (or a loop) starts it again where playback went."""
    from quadsim.live.playback import RecordingFeed
    from quadsim.live.ros2 import Ros2Bridge

    domain = free_domain(8)
    with Ros2Bridge(env=local_env(domain)) as bridge:
        _participant, reader = _clock_reader(domain)
        feed = RecordingFeed(RECORDING, [bridge])
        times = sorted({ns for _, ns, _ in feed.messages})
        feed.play_to(1_000_000_000)
        feed.play_to(2_000_000_000)
        feed.play_to(500_000_000)  # seek back
        feed.play_to(1_000_000_000)
        clock = _clock_read(reader)
    first = [t for t in times if t <= 2_000_000_000]
    back = max(t for t in times if t <= 500_000_000)
    again = [t for t in times if back < t <= 1_000_000_000]
    assert len(first) > 100  # a 60 Hz state rate at least
    assert clock == [*first, back, *again]
