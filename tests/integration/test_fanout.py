"""The topic fan-out: a state, a command, a frame, joystick input and an event become the
contract's messages once, the same for every consumer, with the bytes rosbags (the reference)
gives for the same ROS messages."""

import base64

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from quadsim import SimConfig, Simulator, StateLog, Twist, ZMode
from quadsim.core.kinematics import body_velocity, quaternion_from_matrix
from quadsim.physics.wind import Turbulence, WindSettings
from quadsim.recording.contract import optical_rotation
from quadsim.recording.fanout import TopicFanout
from quadsim.sensors.camera import CameraFrame, default_cameras
from quadsim.session.outputs import OutputOptions, RecordedRun

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types


class Consumer:
    def __init__(self):
        self.topics, self.messages, self.events = [], [], []

    def add_topic(self, topic):
        self.topics.append(topic.name)

    def on_messages(self, messages):
        self.messages.extend(messages)

    def on_event(self, step, kind, value, vehicle=""):
        self.events.append((step, kind, value))


def _ref(msg) -> bytes:
    return bytes(TS.serialize_cdr(msg, msg.__msgtype__))


def _header(ns, frame):
    stamp = T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
    return T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)


def _vec(v):
    return T["geometry_msgs/msg/Vector3"](x=v[0], y=v[1], z=v[2])


def _quat(q):
    return T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])


def _pose(s):
    p = s.position_m
    return T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]), orientation=_quat(s.orientation_xyzw)
    )


def _transform(ns, parent, child, xyz, q):
    return T["geometry_msgs/msg/TransformStamped"](
        header=_header(ns, parent),
        child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](translation=_vec(xyz), rotation=_quat(q)),
    )


def _state_references(s, ns):
    """What the recorder wrote before the fan-out, built with rosbags message objects."""
    zeros36, zeros9 = np.zeros(36), np.zeros(9)
    twist = T["geometry_msgs/msg/Twist"](
        linear=_vec(body_velocity(s.orientation_xyzw, s.linear_velocity_mps)), angular=_vec(s.angular_velocity_body_rps)
    )
    n = len(s.rotor_thrusts_n)
    return [
        ("/quad/pose", T["geometry_msgs/msg/PoseStamped"](header=_header(ns, "world"), pose=_pose(s))),
        (
            "/quad/odom",
            T["nav_msgs/msg/Odometry"](
                header=_header(ns, "world"),
                child_frame_id="base_link",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=_pose(s), covariance=zeros36),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=zeros36),
            ),
        ),
        (
            "/quad/imu",
            T["sensor_msgs/msg/Imu"](
                header=_header(ns, "base_link"),
                orientation=_quat(s.orientation_xyzw),
                orientation_covariance=zeros9,
                angular_velocity=_vec(s.imu.angular_velocity_body_rps),  # the noisy reading
                angular_velocity_covariance=zeros9,
                linear_acceleration=_vec(s.imu.specific_force_body_mps2),
                linear_acceleration_covariance=zeros9,
            ),
        ),
        (
            "/quad/rotor_thrusts",
            T["std_msgs/msg/Float64MultiArray"](
                layout=T["std_msgs/msg/MultiArrayLayout"](
                    dim=[T["std_msgs/msg/MultiArrayDimension"](label="rotor", size=n, stride=n)], data_offset=0
                ),
                data=np.asarray(s.rotor_thrusts_n, dtype=np.float64),
            ),
        ),
        (
            "/tf",
            T["tf2_msgs/msg/TFMessage"](
                transforms=[_transform(ns, "world", "base_link", s.position_m, s.orientation_xyzw)]
            ),
        ),
        ("/wind", T["geometry_msgs/msg/Vector3Stamped"](header=_header(ns, "world"), vector=_vec(s.wind_mps))),
    ]


@pytest.fixture(scope="module")
def flown():
    log = StateLog()
    wind = WindSettings(4.0, 45.0, Turbulence.LIGHT)
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT, wind=wind, seed=7)) as sim:
        sim.add_sink(log)
        sim.send(Twist(linear_x=1.0, linear_z=0.5, angular_z=0.4))
        sim.run_for(3.0)
        mounts = tuple((c, sim.vehicle.camera_mount(c.link_name)) for c in default_cameras())
    return log, mounts


def test_states_and_commands_become_the_contracts_bytes(flown):
    log, _ = flown
    fanout, consumer = TopicFanout(240), Consumer()
    producer = fanout.add_vehicle()
    fanout.add_consumer(consumer)
    consumer.messages.clear()  # the latched /tf_static
    for step, twist in log.commands:
        producer.on_command(step, twist)
    for state in log.states:
        producer.on_state(state)
    commands = consumer.messages[: len(log.commands)]
    for (step, twist), (topic, ns, data) in zip(log.commands, commands):
        ref = T["geometry_msgs/msg/Twist"](linear=_vec(twist[:3]), angular=_vec(twist[3:]))
        assert (topic.name, ns, data) == ("/quad_cmd_twist", step * 1_000_000_000 // 240, _ref(ref))
    states = consumer.messages[len(log.commands) :]
    # pose, odometry, IMU (with its noise: not the true rates), thrusts, /tf and /wind
    assert len(states) == 6 * len(log.states) == 6 * 180
    assert all(s.imu is not None and s.imu.angular_velocity_body_rps != s.angular_velocity_body_rps for s in log.states)
    assert consumer.topics[-1] == "/wind"
    for i, state in enumerate(log.states):
        ns = state.step * 1_000_000_000 // 240
        got = [(topic.name, stamp, data) for topic, stamp, data in states[6 * i : 6 * i + 6]]
        assert got == [(name, ns, _ref(msg)) for name, msg in _state_references(state, ns)]


def test_every_consumer_gets_the_same_messages_and_latecomers_the_latched_ones(flown):
    log, mounts = flown
    fanout = TopicFanout(240)
    producer = fanout.add_vehicle(cameras=mounts)
    first, late = Consumer(), Consumer()
    fanout.add_consumer(first)
    for state in log.states[:10]:
        producer.on_state(state)
    late_step = log.states[9].step
    fanout.add_consumer(late, late_step)
    for state in log.states[10:20]:
        producer.on_state(state)
    assert first.topics == late.topics and "/quad/front_camera/image_raw/compressed" in late.topics
    # /tf_static, latched: the first consumer's at 0, the latecomer's when it joined
    assert first.messages[0][0].name == "/tf_static" and first.messages[0][1] == 0
    assert late.messages[0][0].name == "/tf_static" and late.messages[0][1] == late_step * 1_000_000_000 // 240
    late_static = TS.deserialize_cdr(late.messages[0][2], "tf2_msgs/msg/TFMessage").transforms[0]
    assert late_static.header.stamp.sec * 1_000_000_000 + late_static.header.stamp.nanosec == late.messages[0][1]
    assert late.messages[1:] == first.messages[1 + 60 :]  # 10 states of 6 messages
    assert all(a is b for a, b in zip(late.messages[1:], first.messages[61:]))  # the same objects: encoded once
    spec, mount = mounts[0]
    static = TS.deserialize_cdr(first.messages[0][2], "tf2_msgs/msg/TFMessage").transforms[0]
    assert (static.header.frame_id, static.child_frame_id) == ("base_link", spec.optical_frame)
    q = quaternion_from_matrix(optical_rotation(mount))
    assert (static.transform.rotation.x, static.transform.rotation.w) == (q[0], q[3])


def test_frames_joy_and_events(flown):
    _, mounts = flown
    fanout, consumer = TopicFanout(240), Consumer()
    producer = fanout.add_vehicle(cameras=mounts)
    producer.note_event(3, "z_mode", "height")
    fanout.add_consumer(consumer)
    consumer.messages.clear()
    spec = mounts[1][0]
    producer.on_camera_frame(CameraFrame(spec.name, 8, b"\xff\xd8jpeg", spec.width_px, spec.height_px))
    producer.on_camera_frame(CameraFrame("nobody", 8, b"", 1, 1))  # not one of the run's cameras
    producer.on_joy(24, (0.5, -1.0), (1, 0, 0))
    producer.note_event(48, "z_mode", "velocity")
    names = [topic.name for topic, _, _ in consumer.messages]
    assert names == [f"{spec.topic_prefix}/image_raw/compressed", f"{spec.topic_prefix}/camera_info", "/joy", "/rosout"]
    image, info, joy, rosout = (TS.deserialize_cdr(d, t.type_name) for t, _, d in consumer.messages)
    assert (
        bytes(image.data) == b"\xff\xd8jpeg" and image.format == "jpeg" and image.header.frame_id == spec.optical_frame
    )
    assert (info.width, info.height) == (spec.width_px, spec.height_px) and list(info.k) == list(spec.k_matrix())
    assert list(joy.axes) == [0.5, -1.0] and list(joy.buttons) == [1, 0, 0] and joy.header.stamp.nanosec == 100_000_000
    assert rosout.msg == "z_mode: velocity" and rosout.level == 20 and rosout.name == "quadsim"
    assert rosout.stamp.nanosec == 200_000_000
    assert consumer.events == [(48, "z_mode", "velocity")]  # the one before anyone listened is gone
    assert consumer.topics[-2:] == ["/joy", "/rosout"]  # announced when first used


def test_the_loop_feeds_the_fanout_only_while_something_records(tmp_path):
    with Simulator(SimConfig()) as sim:
        with RecordedRun(sim, OutputOptions(record=False, out=tmp_path, cameras=()), "quiet") as run:
            producer = run.topics[""]
            assert producer not in sim.loop.sinks  # an unrecorded run builds no messages at all
            run.start_recording()
            assert producer in sim.loop.sinks and run.fanout.consumers == [run.recorder]
            run.stop_recording()
            assert producer not in sim.loop.sinks and not run.fanout.consumers


def test_the_scene_is_latched_for_every_consumer_with_its_meshes_inline(tmp_path):
    """Given the vehicle and the world, a latecomer gets the URDF, the world's markers and every
    link's transform too, stamped when it joined. A URDF of one's own naming a mesh beside it
    carries it inline, as a data: URL a browser app loads (tests/integration/test_scene_meshes.py: file://
    URLs for the ROS 2 bridge)."""
    from quadsim.physics.world_spec import load_world
    from quadsim.vehicle.params import DEFAULT_URDF, default_params_path, load_vehicle

    (tmp_path / "meshes").mkdir()
    arm = b"solid arm\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0.1 0 0\nvertex 0 0.1 0\nendloop\nendfacet\nendsolid arm\n"
    (tmp_path / "meshes" / "arm.stl").write_bytes(arm)  # one facet: PyBullet gets a binary copy (vehicle/meshes.py)
    urdf = tmp_path / "meshy.urdf"
    mesh_visual = '<visual><geometry><mesh filename="meshes/arm.stl" scale="1 1 1"/></geometry></visual><visual>'
    urdf.write_text(DEFAULT_URDF.read_text().replace("<visual>", mesh_visual, 1))
    default_params_path(urdf).write_bytes(default_params_path(DEFAULT_URDF).read_bytes())
    vehicle, world = load_vehicle(urdf), load_world()
    fanout, late = TopicFanout(240, world), Consumer()
    fanout.add_vehicle(vehicle=vehicle)
    fanout.add_consumer(late, 480)
    assert late.topics[-3:] == ["/robot_description", "/robot_markers", "/world/markers"]
    decoded = {t.name: (ns, TS.deserialize_cdr(d, t.type_name)) for t, ns, d in late.messages}
    assert {ns for ns, _ in decoded.values()} == {2_000_000_000}
    description = decoded["/robot_description"][1].data
    inline = base64.b64encode(arm).decode()  # the file as it is: viewers read ASCII STL
    assert f'filename="data:model/stl;base64,{inline}"' in description
    assert description.count("<link ") == DEFAULT_URDF.read_text().count("<link ")  # the rest as it was
    static = decoded["/tf_static"][1].transforms
    assert [t.child_frame_id for t in static] == [link.link_name for link in vehicle.link_frames]
    assert static[0].header.stamp.sec == 2
    markers = decoded["/world/markers"][1].markers
    assert len(markers) == 1 + len(world.landmarks) and markers[-1].header.stamp.sec == 2
    model = decoded["/robot_markers"][1].markers  # the mesh too, by the same URL, in its link's frame
    assert model[0].type == 10 and model[0].mesh_resource == f"data:model/stl;base64,{inline}"
    assert model[0].header.frame_id == "base_link" and model[0].header.stamp.sec == 2
