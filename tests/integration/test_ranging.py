"""The range finder and the LiDAR recorded as a user records them: every new message read back by
rosbags and by mcap-ros2-support, its values against the default world's geometry (the floor, the
red tower, another vehicle of a fleet), and re-flown to the same bytes. Their beams in-process:
tests/unit/test_ranging.py."""

import math

import numpy as np
import pytest
from mcap.reader import make_reader
from rosbags.typesys import Stores, get_typestore

from quadsim import SimConfig, Simulator
from quadsim.core.kinematics import matrix_from_quaternion
from quadsim.core.types import LidarMode, StartPose, ZMode
from quadsim.drivers.scripted import ScriptedDriver, parse_script
from quadsim.recording.flight import load_flight, load_flights
from quadsim.session.outputs import OutputOptions, RecordedRun
from quadsim.session.resim import resimulate
from quadsim.sim.fleet import Fleet, FleetVehicle
from tests.helpers.mcap import decoded_recording

TS = get_typestore(Stores.ROS2_JAZZY)  # a Jazzy user's (Range has its `variance` since Jazzy)
#: up to 1.5 m (height z-mode) and hold: 2.5 s
SCRIPT = "z_mode height\n2.5 linear.z=-0.5\n"
TOWER_FACE_X_M = 5.6  # the default world's red tower: a 0.8 m box at x = 6, 3 m tall
NEW_TOPICS = {
    "/quad/range": "sensor_msgs/msg/Range",
    "/quad/scan": "sensor_msgs/msg/LaserScan",
    "/quad/points": "sensor_msgs/msg/PointCloud2",
}


def _record(path, lidar: LidarMode):
    parsed = parse_script(SCRIPT, "test")
    config = SimConfig(z_mode=ZMode.HEIGHT, range_finder=True, lidar=lidar, seed=3)
    with Simulator(config, ScriptedDriver(parsed)) as sim:
        with RecordedRun(sim, OutputOptions(out=path, cameras=()), "test"):
            sim.run_for(parsed.duration_s)
        return sim.drone.vehicle


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ranging")
    paths = {mode: folder / f"{mode.value}.mcap" for mode in LidarMode}
    vehicle = None
    for mode, path in paths.items():
        vehicle = _record(path, mode)
    return paths, vehicle


def _raw(path, topics=tuple(NEW_TOPICS)):
    """(topic, schema name, log time, CDR bytes) of every message on `topics` (the new ones)."""
    with open(path, "rb") as fh:
        for schema, channel, message in make_reader(fh).iter_messages(topics=list(topics)):
            yield channel.topic, schema.name, message.log_time, bytes(message.data)


def test_both_readers_decode_every_new_message_alike(recorded):
    paths, _ = recorded
    for mode, path in paths.items():
        topics, _, _ = decoded_recording(path)  # mcap-ros2-support
        raw = list(_raw(path))
        assert {t for t, *_ in raw} == {"/quad/range", "/quad/scan" if mode is LidarMode.PLANAR else "/quad/points"}
        assert all(schema == NEW_TOPICS[topic] for topic, schema, *_ in raw)
        for topic in {t for t, *_ in raw}:
            theirs = [m for _, m in topics[topic]]
            ours = [TS.deserialize_cdr(data, NEW_TOPICS[topic]) for t, _, _, data in raw if t == topic]  # rosbags
            assert len(theirs) == len(ours) > 0
            for a, b in zip(theirs, ours):
                assert a.header.frame_id == b.header.frame_id
                if topic == "/quad/range":
                    assert a.range == b.range  # a number, or +-inf: never NaN
                elif topic == "/quad/scan":
                    assert list(a.ranges) == list(b.ranges)
                else:
                    assert bytes(a.data) == b.data.tobytes()


def _poses(topics):
    return {ns: (msg.pose.position, msg.pose.orientation) for ns, msg in topics["/quad/pose"]}


def test_the_range_is_the_height_above_the_floor_rep_117_on_the_ground(recorded):
    paths, vehicle = recorded
    topics, _, _ = decoded_recording(paths[LidarMode.PLANAR])
    poses, p = _poses(topics), vehicle.range_finder
    ranges = topics["/quad/range"]
    assert len(ranges) == pytest.approx(2.5 * p.rate_hz, abs=1)
    first = ranges[0][1]
    assert (first.radiation_type, first.header.frame_id) == (1, "range_finder_link")  # INFRARED
    assert (first.min_range, first.max_range) == pytest.approx((p.min_range_m, p.max_range_m))
    assert first.variance == pytest.approx(p.noise_std_m**2)  # Jazzy's field: the noise's, in m^2
    assert first.range == -math.inf  # resting: the floor nearer than its minimum range
    flying = [(poses[ns][0].z + p.position_m[2], msg.range) for ns, msg in ranges if poses[ns][0].z > 0.3]
    assert len(flying) > 60
    errors = np.array([reading - height for height, reading in flying])
    assert np.abs(errors).max() < 5 * p.noise_std_m  # the vehicle flies level: the beam is vertical
    assert errors.std() == pytest.approx(p.noise_std_m, rel=0.3)  # with its noise


def test_the_laser_scan_reads_the_red_tower_ahead(recorded):
    paths, vehicle = recorded
    topics, _, _ = decoded_recording(paths[LidarMode.PLANAR])
    poses, p = _poses(topics), vehicle.lidar
    ns, scan = topics["/quad/scan"][-1]  # at 1.5 m, the tower 3 m tall ahead
    assert scan.header.frame_id == "lidar_link" and len(scan.ranges) == p.samples
    assert scan.angle_min == pytest.approx(-math.pi) and scan.angle_increment == pytest.approx(2 * math.pi / p.samples)
    ahead = round(-scan.angle_min / scan.angle_increment)
    assert scan.angle_min + ahead * scan.angle_increment == pytest.approx(0.0, abs=1e-6)
    x = poses[ns][0].x + p.position_m[0]
    assert scan.ranges[ahead] == pytest.approx(TOWER_FACE_X_M - x, abs=4 * p.noise_std_m)
    assert math.inf in list(scan.ranges)  # open sky behind the pillars: no return


def _world_points(cloud, position, orientation, mount):
    points = np.frombuffer(bytes(cloud.data), dtype="<f4").reshape(-1, 3).astype(float)
    rotation = np.array(matrix_from_quaternion((orientation.x, orientation.y, orientation.z, orientation.w)))
    origin = np.array([position.x, position.y, position.z]) + rotation @ np.asarray(
        mount
    )  # lidar_link: base_link's axes
    return points @ rotation.T + origin


def test_the_point_cloud_lies_on_the_floor_and_the_tower(recorded):
    paths, vehicle = recorded
    topics, _, _ = decoded_recording(paths[LidarMode.SPATIAL])
    poses, p = _poses(topics), vehicle.lidar
    static = {t.child_frame_id: t.transform.translation for t in topics["/tf_static"][0][1].transforms}
    assert (static["lidar_link"].x, static["lidar_link"].y, static["lidar_link"].z) == pytest.approx(p.position_m)
    ns, cloud = topics["/quad/points"][-1]
    assert cloud.header.frame_id == "lidar_link" and [f.name for f in cloud.fields] == ["x", "y", "z"]
    assert cloud.width * cloud.point_step == len(cloud.data) and cloud.width <= p.samples * p.channels
    world = _world_points(cloud, *poses[ns], p.position_m)
    low = world[world[:, 2] < 0.3]  # the floor, and the landing pad's top and the blocks' feet
    on_floor = np.abs(low[:, 2]) < 5 * p.noise_std_m
    assert on_floor.sum() > 1000 and on_floor.mean() > 0.95
    tower = world[(np.abs(world[:, 1]) < 0.35) & (world[:, 0] > 5.0) & (world[:, 0] < 6.5) & (world[:, 2] > 0.3)]
    assert len(tower) >= p.channels // 2  # the tower's face, ring after ring
    assert np.abs(tower[:, 0] - TOWER_FACE_X_M).max() < 5 * p.noise_std_m


def test_a_recording_with_them_re_flies_to_the_same_bytes(recorded, tmp_path):
    paths, _ = recorded
    for mode, path in paths.items():
        report = resimulate(load_flight(path), out=tmp_path / f"again-{mode.value}.mcap")
        assert report.within(0.0, 0.0)
        before = [(t, ns, data) for t, _, ns, data in _raw(path)]
        assert before == [(t, ns, data) for t, _, ns, data in _raw(report.new_recording)]


def test_check_compares_the_readings_and_sees_them_change(recorded, tmp_path):
    """`check` re-flies the readings too: with another seed the flight is the same to the bit (the
    sensors' noise flies nothing) and the readings are not, which fails the check."""
    import json

    from quadsim.apps.regression import CheckTask, check_one
    from tests.helpers.recording import copy_recording

    paths, _ = recorded
    path = paths[LidarMode.PLANAR]
    same = resimulate(load_flight(path), record=False, position_tolerance_m=0.001, attitude_tolerance_rad=0.001)
    assert same.readings_identical is True and same.within(0.001, 0.001)
    assert "/quad/range, /quad/scan readings: max 0 m" in "\n".join(same.lines())

    def other_seed(name, data):
        if name == "quadsim":
            parameters = json.loads(data["parameters"])
            parameters["config"]["seed"] = 4
            data = {**data, "parameters": json.dumps(parameters)}
        return data

    changed = copy_recording(path, tmp_path / "other_seed.mcap", metadata=other_seed)
    report = resimulate(load_flight(changed), record=False, position_tolerance_m=0.001, attitude_tolerance_rad=0.001)
    (vehicle,) = report.vehicles.values()
    assert vehicle.position.max_error == 0.0 and vehicle.attitude.max_error == 0.0
    assert report.readings_identical is False and not report.within(0.001, 0.001)
    assert vehicle.readings.max_error > 0.001 and vehicle.readings.first_beyond_s is not None
    outcome = check_one(CheckTask(changed, 0.001, 0.001))
    assert outcome.status == "changed" and "readings" in "\n".join(outcome.lines)


def test_in_a_fleet_one_vehicles_lidar_sees_the_other(tmp_path):
    path = tmp_path / "fleet.mcap"
    parsed = parse_script(SCRIPT, "test")
    vehicles = [  # alpha alone carries a LiDAR (a fleet file's `lidar = "3d"`)
        FleetVehicle("alpha", StartPose(0.0, 0.0, 0.0), driver=ScriptedDriver(parsed), lidar=LidarMode.SPATIAL),
        FleetVehicle("bravo", StartPose(2.5, 0.0, 0.0), driver=ScriptedDriver(parsed)),
    ]
    config = SimConfig(z_mode=ZMode.HEIGHT, sensor_noise=False)
    with Fleet(vehicles, config) as fleet:
        with RecordedRun(fleet, OutputOptions(out=path, cameras=()), "test"):
            fleet.run_for(parsed.duration_s)
        bravo_reach = fleet["bravo"].physics.reach_m
        mount = fleet["alpha"].vehicle.lidar.position_m
    topics, _, _ = decoded_recording(path)
    assert "/bravo/quad/points" not in topics and "/bravo/quad/scan" not in topics
    ns, cloud = topics["/alpha/quad/points"][-1]
    assert cloud.header.frame_id == "alpha/lidar_link"
    alpha = {n: (m.pose.position, m.pose.orientation) for n, m in topics["/alpha/quad/pose"]}[ns]
    bravo = {n: m.pose.position for n, m in topics["/bravo/quad/pose"]}[ns]
    assert bravo.z > 1.0  # both in the air
    world = _world_points(cloud, *alpha, mount)
    near_bravo = np.linalg.norm(world - [bravo.x, bravo.y, bravo.z], axis=1) < bravo_reach
    assert near_bravo.sum() >= 5  # bravo, posed where it flew to, is in alpha's cloud
    assert world[near_bravo, 0].min() > bravo.x - bravo_reach  # its near side, not beyond it
    # and alpha's own body is not: nothing within its own reach
    assert (np.linalg.norm(world - [alpha[0].x, alpha[0].y, alpha[0].z], axis=1) > 0.3).all()
    again = resimulate(load_flights(path), out=tmp_path / "again.mcap")  # each vehicle with its own sensors
    assert again.within(0.0, 0.0)
    assert [m for t, *m in _raw(path, ["/alpha/quad/points"])] == [
        m for t, *m in _raw(again.new_recording, ["/alpha/quad/points"])
    ]
