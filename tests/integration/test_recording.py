"""Round trip of the recording contract, read back with readers quadsim does not use to write;
and a run flown as a user flies it (`run`), alone or a fleet of three: each vehicle recorded
under its names, and read back vehicle by vehicle."""

import itertools
import json
import math
from pathlib import Path
from xml.etree import ElementTree

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from quadsim import QuadsimError
from quadsim.physics.world_spec import DEFAULT_WORLD, Shape, load_world
from quadsim.recording.flight import load_flight, load_flights
from quadsim.vehicle.params import DEFAULT_URDF, load_vehicle
from tests.helpers.fleets import RUNS, Flier, frame, run_args, under
from tests.helpers.mcap import decoded_recording
from tests.helpers.recording import record_flight
from tests.integration.test_cli import cli

CONTRACT = {
    "/quad_cmd_twist": ("geometry_msgs/msg/Twist", 20),
    "/quad/pose": ("geometry_msgs/msg/PoseStamped", 60),
    "/quad/odom": ("nav_msgs/msg/Odometry", 60),
    "/quad/imu": ("sensor_msgs/msg/Imu", 60),
    "/quad/rotor_thrusts": ("std_msgs/msg/Float64MultiArray", 60),
    "/tf": ("tf2_msgs/msg/TFMessage", 60),
    "/tf_static": ("tf2_msgs/msg/TFMessage", None),
    "/robot_description": ("std_msgs/msg/String", None),
    "/robot_markers": ("visualization_msgs/msg/MarkerArray", None),
    "/world/markers": ("visualization_msgs/msg/MarkerArray", None),
    "/rosout": ("rcl_interfaces/msg/Log", None),  # recording started and stopped, the take-off
    "/quad/front_camera/image_raw/compressed": ("sensor_msgs/msg/CompressedImage", 30),
    "/quad/floor_camera/image_raw/compressed": ("sensor_msgs/msg/CompressedImage", 30),
    "/quad/front_camera/camera_info": ("sensor_msgs/msg/CameraInfo", 30),
    "/quad/floor_camera/camera_info": ("sensor_msgs/msg/CameraInfo", 30),
}
DURATION_S = 3.0


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "flight.mcap"
    log = record_flight(path)
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        header, summary = reader.get_header(), reader.get_summary()
        decoded = [(ch.topic, msg, dec) for _, ch, msg, dec in reader.iter_decoded_messages(log_time_order=True)]
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        attachments = {a.name: a.data for a in reader.iter_attachments()}
    return path, log, header, summary, decoded, metadata, attachments


def test_profile_schemas_encodings_and_qos(recorded):
    _, _, header, summary, _, _, _ = recorded
    assert header.profile == "ros2"
    channels = {ch.topic: ch for ch in summary.channels.values()}
    assert set(channels) == set(CONTRACT)
    for topic, (type_name, _) in CONTRACT.items():
        ch = channels[topic]
        schema = summary.schemas[ch.schema_id]
        assert (schema.name, schema.encoding, ch.message_encoding) == (type_name, "ros2msg", "cdr")
        assert "offered_qos_profiles" in ch.metadata
    assert len(summary.schemas) == len({t for t, _ in CONTRACT.values()})  # one schema per type
    for latched in ("/tf_static", "/robot_description", "/robot_markers", "/world/markers", "/rosout"):
        assert "durability: 1" in channels[latched].metadata["offered_qos_profiles"], latched
    assert "durability: 2" in channels["/quad/pose"].metadata["offered_qos_profiles"]
    # dependencies concatenated the rosbag2 way
    odom_schema = summary.schemas[channels["/quad/odom"].schema_id].data.decode()
    assert "MSG: std_msgs/Header" in odom_schema and "MSG: builtin_interfaces/Time" in odom_schema


def test_counts_at_declared_rates(recorded):
    _, _, _, summary, _, _, _ = recorded
    counts = {summary.channels[c].topic: n for c, n in summary.statistics.channel_message_counts.items()}
    for topic, (_, rate) in CONTRACT.items():
        if topic == "/rosout":  # recording started, the take-off, recording stopped
            assert counts[topic] == 3, counts[topic]
            continue
        expected = 1 if rate is None else round(DURATION_S * rate)
        assert counts[topic] == expected, topic


def test_stamps_equal_log_time_and_frames(recorded):
    _, _, _, _, decoded, _, _ = recorded
    frames = {}
    for topic, msg, dec in decoded:
        assert msg.publish_time == msg.log_time
        assert msg.log_time % 1 == 0 and msg.log_time <= DURATION_S * 1e9
        headers = (
            [t.header for t in dec.transforms]
            if topic.startswith("/tf")
            else [m.header for m in dec.markers]
            if topic.endswith("markers")
            else ([dec.header] if hasattr(dec, "header") else [])
        )
        for h in headers:
            assert h.stamp.sec * 1_000_000_000 + h.stamp.nanosec == msg.log_time, topic
        if topic.startswith("/tf"):
            frames[topic] = {(t.header.frame_id, t.child_frame_id) for t in dec.transforms}
        elif headers:
            frames.setdefault(topic, set()).update(h.frame_id for h in headers)
        if topic == "/quad/odom":
            assert dec.child_frame_id == "base_link"
    assert frames["/tf"] == {("world", "base_link")}
    links = {link.get("name") for link in ElementTree.parse(DEFAULT_URDF).getroot().iter("link")} - {"base_link"}
    optical = {"front_camera_optical", "floor_camera_optical"}
    assert frames["/tf_static"] == {("base_link", child) for child in links | optical}
    assert frames["/world/markers"] == {"world"}
    assert frames["/robot_markers"] == {"base_link"} | links  # each shape in its own link's frame
    assert (
        frames["/quad/pose"] == {"world"} and frames["/quad/odom"] == {"world"} and frames["/quad/imu"] == {"base_link"}
    )
    assert frames["/quad/front_camera/image_raw/compressed"] == {"front_camera_optical"}
    assert frames["/quad/floor_camera/camera_info"] == {"floor_camera_optical"}


def _latched(decoded, topic):
    (message,) = [dec for t, _, dec in decoded if t == topic]
    return message


def test_robot_description_is_the_urdf(recorded):
    """The URDF as its file has it: primitive shapes only, nothing a viewer must find on disk."""
    description = _latched(recorded[4], "/robot_description").data
    assert description == DEFAULT_URDF.read_text()
    assert not list(ElementTree.fromstring(description).iter("mesh"))


def test_tf_static_places_every_link_where_the_urdf_puts_it(recorded):
    transforms = {t.child_frame_id: t.transform for t in _latched(recorded[4], "/tf_static").transforms}
    urdf = ElementTree.parse(DEFAULT_URDF).getroot()
    for joint in urdf.iter("joint"):  # the shipped URDF: every joint's parent is base_link, rpy given
        child = joint.find("child").get("link")
        xyz = [float(v) for v in joint.find("origin").get("xyz").split()]
        pitch = float(joint.find("origin").get("rpy").split()[1])
        t = transforms[child]
        assert [t.translation.x, t.translation.y, t.translation.z] == pytest.approx(xyz)
        q = t.rotation  # a pitch alone: (0, sin(p/2), 0, cos(p/2))
        assert [q.x, q.y, q.z, q.w] == pytest.approx([0.0, math.sin(pitch / 2), 0.0, math.cos(pitch / 2)], abs=1e-12)
    assert {link.link_name for link in load_vehicle(DEFAULT_URDF).link_frames} <= set(transforms)


def test_world_markers_are_the_world_files_floor_and_landmarks(recorded):
    world = load_world(DEFAULT_WORLD)
    floor, *landmarks = _latched(recorded[4], "/world/markers").markers
    assert (floor.ns, floor.type, floor.pose.position.z + floor.scale.z / 2) == ("floor", 1, 0.0)
    assert (floor.scale.x, floor.scale.y) == (world.floor.size_m, world.floor.size_m)
    assert [m.ns for m in landmarks] == [lm.name for lm in world.landmarks]
    marker_type = {Shape.BOX: 1, Shape.SPHERE: 2, Shape.CYLINDER: 3}
    for marker, lm in zip(landmarks, world.landmarks, strict=True):
        p, s, c = marker.pose.position, marker.scale, marker.color
        assert (p.x, p.y, p.z) == lm.position_m and marker.type == marker_type[lm.shape]
        extent = {Shape.BOX: lm.size_m, Shape.CYLINDER: (2 * lm.size_m[0], 2 * lm.size_m[1], lm.size_m[2])}
        assert (s.x, s.y, s.z) == extent.get(lm.shape, (2 * lm.size_m[0],) * 3)
        assert [c.r, c.g, c.b, c.a] == pytest.approx(lm.color_rgba, abs=1e-6)  # float32 on the wire
        assert marker.header.frame_id == "world" and marker.action == 0 and marker.lifetime.sec == 0


def test_rosout_says_when_recording_started_and_stopped(recorded):
    logs = [(msg.log_time, dec) for topic, msg, dec in recorded[4] if topic == "/rosout"]
    assert [(ns, log.name, log.level, log.msg) for ns, log in logs] == [
        (0, "quadsim", 20, "recording: started"),
        (0, "quadsim", 20, "takeoff: climbing from the ground"),
        (int(DURATION_S * 1e9), "quadsim", 20, "recording: stopped"),
    ]


def test_recorded_poses_equal_simulated_ones(recorded):
    _, log, _, _, decoded, _, _ = recorded
    poses = [(msg.log_time, dec.pose) for topic, msg, dec in decoded if topic == "/quad/pose"]
    assert len(poses) == len(log.states)
    for (ns, pose), state in zip(poses, log.states):
        assert ns == state.step * 1_000_000_000 // 240
        assert (pose.position.x, pose.position.y, pose.position.z) == state.position_m
        q = pose.orientation
        assert (q.x, q.y, q.z, q.w) == state.orientation_xyzw
    commands = [dec for topic, _, dec in decoded if topic == "/quad_cmd_twist"]
    assert commands[-1].linear.x == 1.0 and commands[-1].angular.z == 0.5


def test_imu_specific_force_matches_recorded_thrust(recorded, vehicle):
    # an accelerometer in flight reads (rotor thrust - body drag - rotor drag along the rotor
    # axis) / mass along body z, plus its noise
    from quadsim.vehicle.aero import rotor_speed_radps

    _, _, _, _, decoded, _, _ = recorded
    imu = {msg.log_time: dec.linear_acceleration.z for topic, msg, dec in decoded if topic == "/quad/imu"}
    rotors = {msg.log_time: dec.data for topic, msg, dec in decoded if topic == "/quad/rotor_thrusts"}
    climb = {msg.log_time: dec.twist.twist.linear.z for topic, msg, dec in decoded if topic == "/quad/odom"}
    airborne = [t for t in imu if t > 1.0e9]
    assert len(airborne) > 100
    aero, kf = vehicle.aero, vehicle.thrust_coefficient_n_per_rad2s2
    linear, quadratic = aero.body_drag_linear_ns_per_m[2], aero.body_drag_quadratic_ns2_per_m2[2]

    def drag_coefficient(t: int) -> float:
        axial = aero.rotor_axial_drag_ns_per_m_rad * sum(rotor_speed_radps(f, kf) for f in rotors[t])
        return linear + quadratic * abs(climb[t]) + axial

    error = [imu[t] - (sum(rotors[t]) - drag_coefficient(t) * climb[t]) / vehicle.mass_kg for t in airborne]
    # white noise of 0.03 m/s^2 at 60 Hz (MPU-6000) on a small bias; and the IMU sits at the base
    # origin, 1.8 mm from the CoM, so pitching adds a little
    assert max(abs(e) for e in error) < 0.15
    assert abs(sum(error) / len(error)) < 0.02
    assert any(abs(imu[t] - 9.81) < 0.2 for t in airborne)  # and hovering, it reads about g


def test_metadata_and_attachments(recorded):
    _, _, _, _, _, metadata, attachments = recorded
    meta = metadata["quadsim"]
    params = json.loads(meta["parameters"])
    assert params["controller"]["name"] == "cascade" and params["config"]["rates"]["physics_hz"] == 240
    assert params["vehicle"]["mass_kg"] == pytest.approx(1.01)
    assert [c["name"] for c in params["cameras"]] == ["front", "floor"]
    assert "wall_clock_start_utc" in meta and meta["quadsim_version"]
    assert attachments["quadsim_x.urdf"] == DEFAULT_URDF.read_bytes()
    assert "quadsim_x.params.toml" in attachments and "default.toml" in attachments


def test_rosbags_reads_it_as_a_ros2_bag(recorded):
    from rosbags.highlevel import AnyReader

    path = recorded[0]
    with AnyReader([Path(path)]) as reader:
        conns = [c for c in reader.connections if c.topic == "/quad/odom"]
        first = next(reader.messages(connections=conns))
        odom = reader.deserialize(first[2], conns[0].msgtype)
        assert odom.child_frame_id == "base_link" and first[1] == 1_000_000_000 // 60


def test_our_reader_gives_typed_data(recorded):
    from quadsim.recording.reader import RecordingReader

    path, log = recorded[0], recorded[1]
    with RecordingReader(path) as reader:
        poses = list(reader.poses())
        assert [p for _, p, _ in poses] == [s.position_m for s in log.states]
        assert reader.description is not None and reader.description.driver["script"] == "test"
        assert len(list(reader.images("front"))) == 90


def test_a_run_without_commands_is_still_a_quadsim_recording(tmp_path):
    """No command was ever sent: the file has no /quad_cmd_twist channel (a channel is written
    with its first message), and it is still read, shown and checked as quadsim's own."""
    from quadsim.recording.info import read_info
    from quadsim.recording.reader import RecordingReader

    path = tmp_path / "silent.mcap"
    record_flight(path, cameras=False, script="silence 1.0\n")
    with RecordingReader(path) as reader:
        assert "/quad_cmd_twist" not in reader.topics and list(reader.commands()) == []
        assert len(list(reader.poses())) == 60
    assert read_info(path).missing_topics() == []


# --- a run as a user flies it, alone or a fleet --------------------------------------------------

#: each vehicle's topics (under its names) and the run's own (once, whatever flies)
VEHICLE_TOPICS = ("quad/pose", "quad/odom", "quad/imu", "quad/rotor_thrusts", "robot_description", "robot_markers")
RUN_TOPICS = {"/tf", "/tf_static", "/world/markers", "/rosout"}
#: each airframe's URDF (its name in `info` and the description) and rotors
AIRFRAMES = {"quad": ("quadsim_x", 4), "hexa": ("quadsim_hexa", 6), "crazyflie": ("crazyflie", 4)}
#: the commands each input sends in the 27 s run (the square's and yaw's at 20 Hz till they end)
COMMANDS = {"script:square": 540, "script:yaw": 280, "idle": 0}


@pytest.fixture(scope="module", params=list(RUNS))
def run_recorded(request, tmp_path_factory) -> tuple[Path, tuple[Flier, ...]]:
    """A run of each shape (tests.helpers.fleets.RUNS) flown and recorded by `run`: its file and
    its vehicles."""
    folder = tmp_path_factory.mktemp("run")
    out = cli(*run_args(request.param, folder), "--out", str(folder / "run.mcap"))
    assert out.returncode == 0, out.stderr
    return folder / "run.mcap", RUNS[request.param]


def _yaw(q) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def _flew_its_input(flier: Flier, poses: list, thrusts: list) -> None:
    """The vehicle's recorded poses and rotor thrusts show what its input flew."""
    x0, y0, _, heading_deg = flier.start
    if flier.input == "script:square":  # the 3 m square, back over its start at 2 m
        points = [p.position for p in poses]
        path_m = sum(math.dist((a.x, a.y, a.z), (b.x, b.y, b.z)) for a, b in itertools.pairwise(points))
        assert 13.0 < path_m < 16.0 and math.dist((points[-1].x, points[-1].y), (x0, y0)) < 0.2, path_m
        assert abs(points[-1].z - 2.0) < 0.1 and max(p.x for p in points) > x0 + 2.8
        assert max(p.y for p in points) > y0 + 2.8
    elif flier.input == "script:yaw":  # turned 6 rad from its heading where it stands
        last = poses[-1]
        assert math.dist((last.position.x, last.position.y), (x0, y0)) < 0.1
        turned = _yaw(last.orientation) - (math.radians(heading_deg) + 6.0)
        assert abs(math.remainder(turned, 2 * math.pi)) < 0.1
    else:  # idle: on the floor, its rotors still
        assert flier.input == "idle" and max(p.position.z for p in poses) < 0.1
        assert sum(thrusts[-1].data) == 0.0


def test_each_vehicle_is_recorded_under_its_names(run_recorded):
    """Read back with mcap-ros2-support: each vehicle on its own topics and frames (a fleet's
    under its name, one flying alone the contract's own), the run's topics once, and each vehicle
    flew what its input said."""
    path, fliers = run_recorded
    names = [f.name for f in fliers]
    fleet = names != [""]
    commanded = [f.name for f in fliers if COMMANDS[f.input]]
    topics, metadata, attachments = decoded_recording(path)
    own = {under(n, t) for n in names for t in VEHICLE_TOPICS}
    sent = {under(n, "quad_cmd_twist") for n in commanded}  # idle: nothing was sent
    assert set(topics) == RUN_TOPICS | own | sent  # a fleet's only under its names, alone only unprefixed
    assert [len(topics[t]) for t in ("/tf_static", "/world/markers")] == [1, 1]  # the run's, once
    static = topics["/tf_static"][0][1].transforms
    for flier in fliers:
        name, (urdf, rotors) = flier.name, AIRFRAMES[flier.airframe]
        poses = [m.pose for _, m in topics[under(name, "quad/pose")]]
        thrusts = [m for _, m in topics[under(name, "quad/rotor_thrusts")]]
        _flew_its_input(flier, poses, thrusts)
        assert len(thrusts[-1].data) == rotors
        assert sum(t.child_frame_id.startswith(frame(name, "rotor")) for t in static) == rotors
        odom = topics[under(name, "quad/odom")][0][1]
        assert (odom.header.frame_id, odom.child_frame_id) == ("world", frame(name, "base_link"))
        assert topics[under(name, "quad/imu")][0][1].header.frame_id == frame(name, "base_link")
        assert f'<robot name="{urdf}"' in topics[under(name, "robot_description")][0][1].data
    # frames under each name, in one TF tree rooted at world
    bases = {frame(n, "base_link") for n in names}
    assert {t.child_frame_id for _, m in topics["/tf"] for t in m.transforms} == bases
    assert {t.header.frame_id for _, m in topics["/tf"] for t in m.transforms} == {"world"}
    assert {t.header.frame_id for t in static} == bases
    # the run: a fleet's parameters, each airframe's files attached once
    params = json.loads(metadata["quadsim"]["parameters"])
    assert params["schema_version"] == (3 if fleet else 2)
    assert [v["name"] for v in params.get("fleet", [])] == (names if fleet else [])
    assert sorted(attachments) == sorted(set(attachments))
    assert len(attachments) == 2 * len({f.airframe for f in fliers}) + 1  # URDF and parameters, and the world
    takeoffs = [m.name for _, m in topics["/rosout"] if "takeoff" in m.msg]
    assert sorted(takeoffs) == sorted(f"{n}.quadsim" if n else "quadsim" for n in commanded)


def test_it_reads_back_vehicle_by_vehicle(run_recorded):
    """(Re-flown at 0 m by check and replay --resim as every run is: tests/e2e/test_one_path.py.)"""
    path, fliers = run_recorded
    names = [f.name for f in fliers]
    fleet = names != [""]
    flights = load_flights(path)
    assert list(flights) == names
    for flier in fliers:
        flight = flights[flier.name]
        assert flight.vehicle == flier.name and len(flight.commands) == COMMANDS[flier.input]
        assert flight.description.vehicle.rotor_count == AIRFRAMES[flier.airframe][1]
        assert (flight.states[-1].position_m[2] < 0.1) == (flier.input == "idle")  # its own end: idle on the floor
    assert load_flight(path).vehicle == names[0]
    last = load_flight(path, names[-1])
    assert last.vehicle == names[-1] and last.states == flights[names[-1]].states
    have = ", ".join(names) if fleet else "one vehicle, unnamed"
    with pytest.raises(QuadsimError, match=rf"no vehicle named 'zulu' in this recording \(it has {have}\)"):
        load_flight(path, "zulu")
    info = cli("info", str(path)).stdout
    assert (f"a fleet of {len(names)} vehicles:" in info) == fleet, info
    for flier in fliers:
        urdf, rotors = AIRFRAMES[flier.airframe]
        assert (f"{flier.name}: {urdf} ({rotors} rotors" if fleet else f"vehicle {urdf} ({rotors} rotors)") in info
