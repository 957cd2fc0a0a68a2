"""The hand-written CDR encoders give, byte for byte, what rosbags' serialize_cdr (the reference)
gives, for random values: odd string lengths, empty sequences, any rotor count, every padding case."""

import random
import struct

import numpy as np
import pytest
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
from rosbags.typesys import Stores, get_typestore

from quadsim.recording import cdr
from quadsim.recording.contract import schema_text

TS = get_typestore(Stores.ROS2_HUMBLE)  # the reference
T = TS.types
RUNS = 60


def _ref(msg) -> bytes:
    return bytes(TS.serialize_cdr(msg, msg.__msgtype__))


def _text(rng: random.Random, max_len: int = 9) -> str:
    """ASCII and multi-byte UTF-8, lengths 0..max_len: every string padding case."""
    return "".join(rng.choice("abcxyz_/é→") for _ in range(rng.randint(0, max_len)))


def _floats(rng: random.Random, n: int) -> tuple[float, ...]:
    return tuple(rng.uniform(-1e3, 1e3) for _ in range(n))


def _ns(rng: random.Random) -> int:
    return rng.randrange(0, 2**31 * 1_000_000_000)


def _stamp(ns: int):
    return T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def _header(ns: int, frame: str):
    return T["std_msgs/msg/Header"](stamp=_stamp(ns), frame_id=frame)


def _vec(v):
    return T["geometry_msgs/msg/Vector3"](x=v[0], y=v[1], z=v[2])


def _quat(q):
    return T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])


def _pose(p, q):
    return T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]), orientation=_quat(q)
    )


def _f64(values) -> np.ndarray:
    return np.asarray(values, dtype=np.float64)


def _rngs():
    """RUNS random cases, seeded: the same ones on every run."""
    return (random.Random(seed) for seed in range(RUNS))


def test_twist():
    for rng in _rngs():
        lin, ang = _floats(rng, 3), _floats(rng, 3)
        ref = T["geometry_msgs/msg/Twist"](linear=_vec(lin), angular=_vec(ang))
        assert cdr.twist(lin, ang) == _ref(ref)


def test_pose_stamped_and_vector3_stamped():
    for rng in _rngs():
        ns, frame, p, q = _ns(rng), _text(rng), _floats(rng, 3), _floats(rng, 4)
        ref = T["geometry_msgs/msg/PoseStamped"](header=_header(ns, frame), pose=_pose(p, q))
        assert cdr.pose_stamped(ns, frame, p, q) == _ref(ref)
        ref = T["geometry_msgs/msg/Vector3Stamped"](header=_header(ns, frame), vector=_vec(p))
        assert cdr.vector3_stamped(ns, frame, p) == _ref(ref)


def test_pose_stamped_is_read_back_in_either_byte_order():
    for rng in _rngs():
        ns, frame, p, q = _ns(rng), _text(rng), _floats(rng, 3), _floats(rng, 4)
        ref = T["geometry_msgs/msg/PoseStamped"](header=_header(ns, frame), pose=_pose(p, q))
        for little in (True, False):
            data = bytes(TS.serialize_cdr(ref, ref.__msgtype__, little_endian=little))
            assert cdr.pose_stamped_fields(data) == (frame, p, q)


def test_what_is_not_a_pose_stamped_is_refused():
    good = cdr.pose_stamped(1, "world", (1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))
    cases = [
        b"",
        good[:20],  # cut inside the frame_id
        good[:-1],  # cut inside the orientation
        b"\x00\x07" + good[2:],  # not a CDR encapsulation
        good[:12] + struct.pack("<I", 2**31) + good[16:],  # a frame_id of 2 GB
        good[:12] + struct.pack("<I", 0) + good[16:],  # no frame_id at all (not even its NUL)
        good[:16] + b"\xff" + good[17:],  # a frame_id that is not UTF-8
    ]
    for data in cases:
        with pytest.raises(ValueError):
            cdr.pose_stamped_fields(data)


@pytest.mark.parametrize("with_covariance", [False, True])
def test_odometry(with_covariance):
    for rng in _rngs():
        ns, frame, child = _ns(rng), _text(rng), _text(rng)
        p, q, lin, ang = _floats(rng, 3), _floats(rng, 4), _floats(rng, 3), _floats(rng, 3)
        pc, tc = (_floats(rng, 36), _floats(rng, 36)) if with_covariance else (None, None)
        ref = T["nav_msgs/msg/Odometry"](
            header=_header(ns, frame),
            child_frame_id=child,
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=_pose(p, q), covariance=_f64(pc or [0.0] * 36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=_vec(lin), angular=_vec(ang)),
                covariance=_f64(tc or [0.0] * 36),
            ),
        )
        assert cdr.odometry(ns, frame, child, p, q, lin, ang, pc, tc) == _ref(ref)


@pytest.mark.parametrize("given", [(False, False, False), (True, False, True), (True, True, True)])
def test_imu(given):
    for rng in _rngs():
        ns, frame, q, w, a = _ns(rng), _text(rng), _floats(rng, 4), _floats(rng, 3), _floats(rng, 3)
        covs = [_floats(rng, 9) if g else None for g in given]
        ref = T["sensor_msgs/msg/Imu"](
            header=_header(ns, frame),
            orientation=_quat(q),
            orientation_covariance=_f64(covs[0] or [0.0] * 9),
            angular_velocity=_vec(w),
            angular_velocity_covariance=_f64(covs[1] or [0.0] * 9),
            linear_acceleration=_vec(a),
            linear_acceleration_covariance=_f64(covs[2] or [0.0] * 9),
        )
        assert cdr.imu(ns, frame, q, w, a, *covs) == _ref(ref)


def test_float64_multi_array():
    for rng in _rngs():
        dims = [
            cdr.ArrayDimension(_text(rng), rng.randrange(2**32), rng.randrange(2**32)) for _ in range(rng.randint(0, 3))
        ]
        data = _floats(rng, rng.choice([0, 1, 3, 4, 6, 8]))  # no data, a quad, a hexa, an octo
        offset = rng.randrange(2**32)
        layout = T["std_msgs/msg/MultiArrayLayout"](
            dim=[T["std_msgs/msg/MultiArrayDimension"](label=d.label, size=d.size, stride=d.stride) for d in dims],
            data_offset=offset,
        )
        ref = T["std_msgs/msg/Float64MultiArray"](layout=layout, data=_f64(data))
        assert cdr.float64_multi_array(data, dims, offset) == _ref(ref)


def test_tf_message():
    for rng in _rngs():
        transforms = [
            cdr.TransformStamped(_ns(rng), _text(rng), _text(rng), _floats(rng, 3), _floats(rng, 4))
            for _ in range(rng.randint(0, 4))
        ]
        ref = T["tf2_msgs/msg/TFMessage"](
            transforms=[
                T["geometry_msgs/msg/TransformStamped"](
                    header=_header(t.ns, t.frame_id),
                    child_frame_id=t.child_frame_id,
                    transform=T["geometry_msgs/msg/Transform"](
                        translation=_vec(t.translation), rotation=_quat(t.rotation)
                    ),
                )
                for t in transforms
            ]
        )
        assert cdr.tf_message(transforms) == _ref(ref)
        if len(transforms) == 1:
            t = transforms[0]
            assert cdr.transform_encoder(t.frame_id, t.child_frame_id)(t.ns, t.translation, t.rotation) == _ref(ref)


def test_compressed_image():
    for rng in _rngs():
        ns, frame, fmt = _ns(rng), _text(rng), _text(rng, 5)
        data = bytes(rng.randrange(256) for _ in range(rng.randint(0, 40)))
        ref = T["sensor_msgs/msg/CompressedImage"](
            header=_header(ns, frame), format=fmt, data=np.frombuffer(data, dtype=np.uint8)
        )
        assert cdr.compressed_image(ns, frame, fmt, data) == _ref(ref)


def test_image():
    """sensor_msgs/msg/Image: every padding case of the frame and encoding strings, either byte order."""
    for rng in _rngs():
        ns, frame, encoding = _ns(rng), _text(rng), rng.choice(["32FC1", "16UC1", "mono8", _text(rng, 6)])
        h, w, step, bigendian = rng.randrange(2**32), rng.randrange(2**32), rng.randrange(2**32), rng.random() < 0.3
        data = bytes(rng.randrange(256) for _ in range(rng.randint(0, 40)))
        ref = T["sensor_msgs/msg/Image"](
            header=_header(ns, frame),
            height=h,
            width=w,
            encoding=encoding,
            is_bigendian=bigendian,
            step=step,
            data=np.frombuffer(data, dtype=np.uint8),
        )
        assert cdr.image(ns, frame, h, w, encoding, step, data, bigendian) == _ref(ref)


def test_camera_info():
    for rng in _rngs():
        ns, frame, model = _ns(rng), _text(rng), _text(rng)
        h, w, bx, by = (rng.randrange(2**32) for _ in range(4))
        d, k, r, p = _floats(rng, rng.choice([0, 1, 5, 8])), _floats(rng, 9), _floats(rng, 9), _floats(rng, 12)
        roi = cdr.RegionOfInterest(*(rng.randrange(2**32) for _ in range(4)), rng.random() < 0.5)
        ref = T["sensor_msgs/msg/CameraInfo"](
            header=_header(ns, frame),
            height=h,
            width=w,
            distortion_model=model,
            d=_f64(d),
            k=_f64(k),
            r=_f64(r),
            p=_f64(p),
            binning_x=bx,
            binning_y=by,
            roi=T["sensor_msgs/msg/RegionOfInterest"](**roi._asdict()),
        )
        assert cdr.camera_info(ns, frame, h, w, model, d, k, r, p, bx, by, roi) == _ref(ref)


def test_joy():
    for rng in _rngs():
        ns, frame = _ns(rng), _text(rng)
        axes = [struct.unpack("<f", struct.pack("<f", v))[0] for v in _floats(rng, rng.randint(0, 7))]  # float32 exact
        buttons = [rng.randrange(-(2**31), 2**31) for _ in range(rng.randint(0, 13))]
        ref = T["sensor_msgs/msg/Joy"](
            header=_header(ns, frame), axes=np.asarray(axes, np.float32), buttons=np.asarray(buttons, np.int32)
        )
        assert cdr.joy(ns, frame, axes, buttons) == _ref(ref)


def test_string_and_log():
    for rng in _rngs():
        text = _text(rng, 30)
        assert cdr.string(text) == _ref(T["std_msgs/msg/String"](data=text))
        ns, level, texts, line = (
            _ns(rng),
            rng.choice([10, 20, 30, 40, 50]),
            [_text(rng) for _ in range(4)],
            rng.randrange(2**32),
        )
        ref = T["rcl_interfaces/msg/Log"](
            stamp=_stamp(ns), level=level, name=texts[0], msg=texts[1], file=texts[2], function=texts[3], line=line
        )
        assert cdr.log(ns, level, *texts, line) == _ref(ref)


def test_other_decoders_read_them():
    """mcap_ros2's own decoder (generated from the schema text, as Foxglove does) reads them too."""
    ns = 12_345_678_901
    odom = cdr.odometry(ns, "world", "base_link", (1.0, 2.0, 3.0), (0.0, 0.0, 0.6, 0.8), (0.5, 0.0, 0.0), (0, 0, 0.1))
    schema = Schema(
        id=1, name="nav_msgs/msg/Odometry", encoding="ros2msg", data=schema_text("nav_msgs/msg/Odometry").encode()
    )
    decoded = DecoderFactory().decoder_for("cdr", schema)(odom)
    assert decoded.header.stamp.sec == 12 and decoded.header.stamp.nanosec == 345_678_901
    assert decoded.child_frame_id == "base_link" and decoded.pose.pose.orientation.w == 0.8
    assert list(decoded.pose.covariance) == [0.0] * 36 and decoded.twist.twist.angular.z == 0.1
    thrusts = cdr.float64_multi_array((1.0, 2.0, 3.0, 4.0, 5.0, 6.0), (cdr.ArrayDimension("rotor", 6, 6),))
    decoded = TS.deserialize_cdr(thrusts, "std_msgs/msg/Float64MultiArray")
    assert list(decoded.data) == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0] and decoded.layout.dim[0].label == "rotor"


def test_camera_info_refuses_wrong_matrix_sizes():
    with pytest.raises(ValueError, match="9 k"):
        cdr.camera_info(0, "f", 1, 1, "plumb_bob", (), (1.0,) * 8, (0.0,) * 9, (0.0,) * 12)


def _f32(rng: random.Random, n: int) -> tuple[float, ...]:
    """Values float32 holds exactly (ColorRGBA is float32)."""
    return tuple(struct.unpack("<f", struct.pack("<f", v))[0] for v in _floats(rng, n))


def _rgba(c):
    return T["std_msgs/msg/ColorRGBA"](r=c[0], g=c[1], b=c[2], a=c[3])


def test_marker_array():
    for rng in _rngs():
        markers = [
            cdr.Marker(
                _ns(rng),
                _text(rng),
                _text(rng),
                rng.randrange(-(2**31), 2**31),
                rng.choice([1, 2, 3, 9]),
                _floats(rng, 3),
                _floats(rng, 4),
                _floats(rng, 3),
                _f32(rng, 4),
                action=rng.choice([0, 2, 3]),
                lifetime_ns=_ns(rng),
                frame_locked=rng.random() < 0.5,
                points=[_floats(rng, 3) for _ in range(rng.randint(0, 3))],
                colors=[_f32(rng, 4) for _ in range(rng.randint(0, 3))],
                texture_resource=_text(rng),
                text=_text(rng),
                mesh_resource=_text(rng),
                mesh_use_embedded_materials=rng.random() < 0.5,
            )
            for _ in range(rng.randint(0, 3))
        ]
        empty = np.zeros(0, np.uint8)
        ref = T["visualization_msgs/msg/MarkerArray"](
            markers=[
                T["visualization_msgs/msg/Marker"](
                    header=_header(m.ns, m.frame_id),
                    ns=m.namespace,
                    id=m.id,
                    type=m.type,
                    action=m.action,
                    pose=_pose(m.position, m.orientation),
                    scale=_vec(m.scale),
                    color=_rgba(m.color),
                    lifetime=T["builtin_interfaces/msg/Duration"](
                        sec=m.lifetime_ns // 1_000_000_000, nanosec=m.lifetime_ns % 1_000_000_000
                    ),
                    frame_locked=m.frame_locked,
                    points=[T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]) for p in m.points],
                    colors=[_rgba(c) for c in m.colors],
                    texture_resource=m.texture_resource,
                    texture=T["sensor_msgs/msg/CompressedImage"](header=_header(0, ""), format="", data=empty),
                    uv_coordinates=[],
                    text=m.text,
                    mesh_resource=m.mesh_resource,
                    mesh_file=T["visualization_msgs/msg/MeshFile"](filename="", data=empty),
                    mesh_use_embedded_materials=m.mesh_use_embedded_materials,
                )
                for m in markers
            ]
        )
        assert cdr.marker_array(markers) == _ref(ref)


def test_range_as_jazzy_and_kilted_have_it():
    """sensor_msgs/Range gained `variance` after Humble: the contract's is Jazzy's (what its live
    peers read), the same in Kilted."""
    jazzy, kilted = get_typestore(Stores.ROS2_JAZZY), get_typestore(Stores.ROS2_KILTED)
    assert jazzy.fielddefs["sensor_msgs/msg/Range"] == kilted.fielddefs["sensor_msgs/msg/Range"]
    assert schema_text("sensor_msgs/msg/Range") == jazzy.generate_msgdef("sensor_msgs/msg/Range", ros_version=2)[0]
    for rng in _rngs():
        ns, frame = _ns(rng), _text(rng)
        kind, fov, low, high = rng.randrange(2), rng.uniform(0, 1), rng.uniform(0, 1), rng.uniform(1, 50)
        value = rng.choice([rng.uniform(low, high), float("inf"), float("-inf")])
        variance = rng.choice([0.0, rng.uniform(0, 1)])
        ref = jazzy.types["sensor_msgs/msg/Range"](
            header=_header(ns, frame),
            radiation_type=kind,
            field_of_view=fov,
            min_range=low,
            max_range=high,
            range=value,
            variance=variance,
        )
        reference = bytes(jazzy.serialize_cdr(ref, ref.__msgtype__))
        assert cdr.range_encoder(frame, kind, fov, low, high, variance)(ns, value) == reference


def test_laser_scan():
    for rng in _rngs():
        ns, frame = _ns(rng), _text(rng)
        ranges = np.asarray((*_floats(rng, rng.randint(0, 12)), float("inf"), float("-inf")), dtype=np.float32)
        angles, times, limits = _floats(rng, 3), _floats(rng, 2), _floats(rng, 2)
        ref = T["sensor_msgs/msg/LaserScan"](
            header=_header(ns, frame),
            angle_min=angles[0],
            angle_max=angles[1],
            angle_increment=angles[2],
            time_increment=times[0],
            scan_time=times[1],
            range_min=limits[0],
            range_max=limits[1],
            ranges=ranges,
            intensities=np.zeros(0, dtype=np.float32),
        )
        assert cdr.laser_scan_encoder(frame, angles, times, limits)(ns, ranges.astype("<f4").tobytes()) == _ref(ref)


def test_xyz_cloud():
    for rng in _rngs():
        ns, frame = _ns(rng), _text(rng)
        points = np.asarray(_floats(rng, 3 * rng.randint(0, 9)), dtype="<f4")
        field = T["sensor_msgs/msg/PointField"]
        ref = T["sensor_msgs/msg/PointCloud2"](
            header=_header(ns, frame),
            height=1,
            width=len(points) // 3,
            fields=[field(name=n, offset=4 * i, datatype=field.FLOAT32, count=1) for i, n in enumerate("xyz")],
            is_bigendian=False,
            point_step=12,
            row_step=4 * len(points),
            data=np.frombuffer(points.tobytes(), dtype=np.uint8),
            is_dense=True,
        )
        assert cdr.xyz_cloud_encoder(frame)(ns, points.tobytes()) == _ref(ref)
