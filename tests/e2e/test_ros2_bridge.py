"""The ROS 2 bridge's parts that need no ROS 2 node: the DDS types against recorded bytes, the
environment ROS 2 users set, the recorded feed of replay --ros2, the window and `run` flown by
ROS 2 input, and a real SIGTERM ending `run --input ros2`. (tests/e2e/test_ros2.py flies it from rclpy.)"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

from quadsim.live.dds_types import idl_type
from quadsim.recording.reader import RecordingReader
from tests.helpers import ROOT
from tests.helpers.cli import wait_for_line
from tests.helpers.ros2_env import free_domain, local_env

RECORDING = ROOT / "tests" / "recordings" / "keyboard_session_cascade.mcap"


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
    (_, said, readers) = wait_for_line(proc, "live: 1 s flown", 1)  # a second of flight in the file
    proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=60)
    for reader in readers:
        reader.join(timeout=10)
    err = "".join(said)
    assert proc.returncode == 143, err
    assert "live: 1 s flown (" in err and "; 0 Twists from ros2" in err, err
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


def test_goal_publishers_are_said_when_heard_and_a_best_effort_one_is_warned_about(caplog) -> None:
    """A goal comes once (RViz: one per click), so quadsim says when it hears a node's goal
    publisher: from then on a goal it sends arrives, and it does. A best-effort goal publisher
    cannot be heard by the reliable reader: said once, in a warning."""
    import threading

    from cyclonedds.core import Policy, Qos
    from cyclonedds.domain import DomainParticipant
    from cyclonedds.pub import DataWriter
    from cyclonedds.topic import Topic

    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.live.ros2 import Ros2Bridge

    domain = free_domain(8)
    driver = SubscribedDriver("ros2")
    heard: list[tuple[str, int]] = []
    changed = threading.Condition()

    def on_publishers(topic: str, count: int) -> None:
        with changed:
            heard.append((topic, count))
            changed.notify_all()

    def until(what, seconds: float = 30.0) -> None:
        """Until `what()` holds: woken by a change of publishers, or looking again every 50 ms
        (a goal or a log record arrives on Cyclone's thread without telling)."""
        deadline = time.monotonic() + seconds
        with changed:
            while not what():
                assert time.monotonic() < deadline, (heard, driver.goals_received, caplog.records)
                changed.wait(timeout=0.05)

    kind = idl_type("geometry_msgs/msg/PoseStamped")
    with Ros2Bridge(env=local_env(domain)) as bridge:
        bridge.subscribe_goals(driver, on_publishers)
        node = DomainParticipant(domain)
        reliable = Qos(Policy.Reliability.Reliable(max_blocking_time=100_000_000), Policy.History.KeepLast(10))
        writer = DataWriter(node, Topic(node, "rt/goal_pose", kind), qos=reliable)
        until(lambda: ("/goal_pose", 1) in heard)
        goal = kind(
            header=idl_type("std_msgs/msg/Header")(stamp=idl_type("builtin_interfaces/msg/Time")(0, 0), frame_id="map"),
            pose=idl_type("geometry_msgs/msg/Pose")(
                position=idl_type("geometry_msgs/msg/Point")(2.0, -1.5, 0.0),
                orientation=idl_type("geometry_msgs/msg/Quaternion")(0.0, 0.0, 0.0, 1.0),
            ),
        )
        with caplog.at_level("WARNING", logger="quadsim.live.ros2"):
            writer.write(goal)
            best_effort = DataWriter(
                node, Topic(node, "rt/move_base_simple/goal", kind), qos=Qos(Policy.Reliability.BestEffort)
            )
            until(lambda: driver.goals_received == 1 and caplog.records)
            del best_effort
            del writer
            until(lambda: ("/goal_pose", 0) in heard)
    taken = driver.take_goal()
    assert taken is not None and driver.goals_received == 1, heard
    assert heard == [("/goal_pose", 1), ("/goal_pose", 0)]  # the best-effort one was never heard
    assert [r.getMessage() for r in caplog.records] == [
        "a publisher on /move_base_simple/goal is not heard: its QoS does not match this reader's "
        "(reliable, keep last; publish reliably, as ROS 2 does by default)"
    ]


def test_a_node_started_later_gets_every_rosout_message_so_far() -> None:
    """/rosout is transient-local with depth 1000, but a node that joined late got only the last
    message: Cyclone keeps what late joiners get in its durability service, whose history was
    its default, the last 1."""
    from cyclonedds.core import InstanceState, Policy, Qos, ReadCondition, SampleState, ViewState, WaitSet
    from cyclonedds.domain import DomainParticipant
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic
    from cyclonedds.util import duration

    from quadsim.live.ros2 import Ros2Bridge
    from quadsim.recording.fanout import TopicFanout

    domain = free_domain(8)
    fanout = TopicFanout(240)
    with Ros2Bridge(env=local_env(domain)) as bridge:
        fanout.add_consumer(bridge)
        for step, (kind, value) in enumerate((("recording", "started"), ("takeoff", "at 0.05 m"), ("goal", "x=1"))):
            fanout.note_event(step * 240, kind, value)
        participant = DomainParticipant(domain)  # the late node, as rclpy's /rosout subscription asks
        topic = Topic(participant, "rt/rosout", idl_type("rcl_interfaces/msg/Log"))
        qos = Qos(
            Policy.Reliability.Reliable(max_blocking_time=0),
            Policy.History.KeepLast(1000),
            Policy.Durability.TransientLocal,
        )
        reader = DataReader(participant, topic, qos=qos)
        arrived = WaitSet(participant)
        arrived.attach(ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any))
        got: list[str] = []
        while len(got) < 3 and arrived.wait(duration(seconds=10)):  # as they come: discovery, then the history
            got += [m.msg for m in reader.take(100)]
    assert got == ["recording: started", "takeoff: at 0.05 m", "goal: x=1"], got


def test_a_twist_that_is_not_finite_is_warned_about_once(caplog) -> None:
    """The bridge dropped what the driver refused without a word (Foxglove's client is told;
    command-semantics.md says a warning is logged once); the summary counted them."""
    import math
    import threading

    from cyclonedds.core import Listener, Policy, Qos
    from cyclonedds.domain import DomainParticipant
    from cyclonedds.pub import DataWriter
    from cyclonedds.topic import Topic

    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.live.ros2 import Ros2Bridge

    domain = free_domain(9)
    driver = SubscribedDriver("ros2")
    kind = idl_type("geometry_msgs/msg/Twist")
    vector = idl_type("geometry_msgs/msg/Vector3")
    heard = threading.Semaphore(0)  # released by the bridge for each Twist it took or refused
    matched = threading.Event()
    with Ros2Bridge(env=local_env(domain)) as bridge:
        bridge.subscribe_twist(driver, on_twist=heard.release)
        participant = DomainParticipant(domain)  # the user's node
        topic = Topic(participant, "rt/quad_cmd_twist", kind)
        qos = Qos(Policy.Reliability.Reliable(max_blocking_time=10**9))
        writer = DataWriter(
            participant, topic, qos=qos, listener=Listener(on_publication_matched=lambda *_: matched.set())
        )
        assert matched.wait(10.0)
        for _attempt in range(60):  # until three are taken: one sent before the bridge's reader matched is lost
            if driver.rejected >= 3:
                break
            writer.write(kind(linear=vector(math.nan, 0.0, 0.0), angular=vector(0.0, 0.0, 0.0)))
            heard.acquire(timeout=0.5)  # returns as the bridge takes it
    said = [r.getMessage() for r in caplog.records if "not finite" in r.getMessage()]
    assert driver.rejected >= 3 and driver.received == 0
    assert said == [
        "a Twist on /quad_cmd_twist with a field that is not finite is ignored (the summary counts any more)"
    ]
