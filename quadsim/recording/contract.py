"""ROS 2 messages of the recording contract (DESIGN.md): topics, types, QoS, and conversion.

Messages are typed rosbags (ROS 2 Humble) message classes, serialised to CDR; schemas are their
`ros2msg` definitions with dependencies concatenated the way rosbag2 writes them.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore

from quadsim.core.kinematics import Mat3, body_velocity, mat_mul, quaternion_from_matrix
from quadsim.core.types import Twist, VehicleState
from quadsim.sensors.camera import LINK_FROM_OPTICAL, CameraFrame, CameraSpec
from quadsim.vehicle.params import CameraMount

TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)
_T = TYPESTORE.types

WORLD_FRAME = "world"
BODY_FRAME = "base_link"


def _qos(durability: int, depth: int) -> str:
    """An offered_qos_profiles entry as rosbag2 writes it (YAML). reliability 1 = reliable;
    durability 1 = transient local, 2 = volatile; history 1 = keep last."""
    infinite = "    sec: 9223372036\n    nsec: 854775807\n"
    return (
        f"- history: 1\n  depth: {depth}\n  reliability: 1\n  durability: {durability}\n"
        f"  deadline:\n{infinite}  lifespan:\n{infinite}  liveliness: 1\n"
        f"  liveliness_lease_duration:\n{infinite}  avoid_ros_namespace_conventions: false\n"
    )


QOS_VOLATILE = _qos(2, 10)
QOS_LATCHED = _qos(1, 1)  # /tf_static: late joiners still get it


@dataclass(frozen=True)
class Topic:
    name: str
    type_name: str  # pkg/msg/Type
    qos: str = QOS_VOLATILE


TWIST = Topic("/quad_cmd_twist", "geometry_msgs/msg/Twist")
JOY = Topic("/joy", "sensor_msgs/msg/Joy")
POSE = Topic("/quad/pose", "geometry_msgs/msg/PoseStamped")
ODOM = Topic("/quad/odom", "nav_msgs/msg/Odometry")
IMU = Topic("/quad/imu", "sensor_msgs/msg/Imu")
ROTOR_THRUSTS = Topic("/quad/rotor_thrusts", "std_msgs/msg/Float64MultiArray")
TF = Topic("/tf", "tf2_msgs/msg/TFMessage")
TF_STATIC = Topic("/tf_static", "tf2_msgs/msg/TFMessage", QOS_LATCHED)
STATE_TOPICS = (POSE, ODOM, IMU, ROTOR_THRUSTS, TF)
#: topics every quadsim recording has (cameras and /joy depend on the run)
CORE_TOPICS = (TWIST.name, *(t.name for t in STATE_TOPICS), TF_STATIC.name)


def image_topic(spec: CameraSpec) -> Topic:
    return Topic(f"{spec.topic_prefix}/image_raw/compressed", "sensor_msgs/msg/CompressedImage")


def camera_info_topic(spec: CameraSpec) -> Topic:
    return Topic(f"{spec.topic_prefix}/camera_info", "sensor_msgs/msg/CameraInfo")


@cache
def schema_text(type_name: str) -> str:
    return TYPESTORE.generate_msgdef(type_name, ros_version=2)[0]


def serialize(msg: object) -> bytes:
    return bytes(TYPESTORE.serialize_cdr(msg, msg.__msgtype__))  # type: ignore[attr-defined]


# --- conversion ----------------------------------------------------------------------------

_ZERO36 = np.zeros(36, dtype=np.float64)
_ZERO9 = np.zeros(9, dtype=np.float64)


def stamp(ns: int):
    return _T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def header(ns: int, frame: str):
    return _T["std_msgs/msg/Header"](stamp=stamp(ns), frame_id=frame)


def _vec(v) -> Any:
    return _T["geometry_msgs/msg/Vector3"](x=float(v[0]), y=float(v[1]), z=float(v[2]))


def _quat(q) -> Any:
    return _T["geometry_msgs/msg/Quaternion"](x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))


def _pose(s: VehicleState):
    p = s.position_m
    return _T["geometry_msgs/msg/Pose"](
        position=_T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]), orientation=_quat(s.orientation_xyzw)
    )


def twist_msg(t: Twist):
    return _T["geometry_msgs/msg/Twist"](
        linear=_vec((t.linear_x, t.linear_y, t.linear_z)), angular=_vec((t.angular_x, t.angular_y, t.angular_z))
    )


def pose_msg(s: VehicleState, ns: int):
    return _T["geometry_msgs/msg/PoseStamped"](header=header(ns, WORLD_FRAME), pose=_pose(s))


def odom_msg(s: VehicleState, ns: int):
    twist = _T["geometry_msgs/msg/Twist"](
        linear=_vec(body_velocity(s.orientation_xyzw, s.linear_velocity_mps)), angular=_vec(s.angular_velocity_body_rps)
    )
    return _T["nav_msgs/msg/Odometry"](
        header=header(ns, WORLD_FRAME),
        child_frame_id=BODY_FRAME,
        pose=_T["geometry_msgs/msg/PoseWithCovariance"](pose=_pose(s), covariance=_ZERO36),
        twist=_T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=_ZERO36),
    )


def imu_msg(s: VehicleState, ns: int):
    return _T["sensor_msgs/msg/Imu"](
        header=header(ns, BODY_FRAME),
        orientation=_quat(s.orientation_xyzw),
        orientation_covariance=_ZERO9,
        angular_velocity=_vec(s.angular_velocity_body_rps),
        angular_velocity_covariance=_ZERO9,
        linear_acceleration=_vec(s.specific_force_body_mps2),
        linear_acceleration_covariance=_ZERO9,
    )


def rotor_thrusts_msg(s: VehicleState):
    dim = _T["std_msgs/msg/MultiArrayDimension"](
        label="rotor", size=len(s.rotor_thrusts_n), stride=len(s.rotor_thrusts_n)
    )
    return _T["std_msgs/msg/Float64MultiArray"](
        layout=_T["std_msgs/msg/MultiArrayLayout"](dim=[dim], data_offset=0),
        data=np.asarray(s.rotor_thrusts_n, dtype=np.float64),
    )


def _transform(ns: int, parent: str, child: str, xyz, q):
    return _T["geometry_msgs/msg/TransformStamped"](
        header=header(ns, parent),
        child_frame_id=child,
        transform=_T["geometry_msgs/msg/Transform"](translation=_vec(xyz), rotation=_quat(q)),
    )


def tf_msg(s: VehicleState, ns: int):
    return _T["tf2_msgs/msg/TFMessage"](
        transforms=[_transform(ns, WORLD_FRAME, BODY_FRAME, s.position_m, s.orientation_xyzw)]
    )


def optical_rotation(mount: CameraMount) -> Mat3:
    """base_link <- optical frame of a camera."""
    return mat_mul(mount.rotation, LINK_FROM_OPTICAL)


def tf_static_msg(cameras: tuple[tuple[CameraSpec, CameraMount], ...]):
    return _T["tf2_msgs/msg/TFMessage"](
        transforms=[
            _transform(
                0, BODY_FRAME, spec.optical_frame, mount.position_m, quaternion_from_matrix(optical_rotation(mount))
            )
            for spec, mount in cameras
        ]
    )


def compressed_image_msg(frame: CameraFrame, spec: CameraSpec, ns: int):
    return _T["sensor_msgs/msg/CompressedImage"](
        header=header(ns, spec.optical_frame), format="jpeg", data=np.frombuffer(frame.jpeg, dtype=np.uint8)
    )


def camera_info_msg(spec: CameraSpec, ns: int):
    f = spec.focal_px
    cx, cy = spec.principal_point_px
    return _T["sensor_msgs/msg/CameraInfo"](
        header=header(ns, spec.optical_frame),
        height=spec.height_px,
        width=spec.width_px,
        distortion_model="plumb_bob",
        d=np.zeros(5, dtype=np.float64),
        k=np.asarray(spec.k_matrix(), dtype=np.float64),
        r=np.asarray((1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), dtype=np.float64),
        p=np.asarray((f, 0.0, cx, 0.0, 0.0, f, cy, 0.0, 0.0, 0.0, 1.0, 0.0), dtype=np.float64),
        binning_x=0,
        binning_y=0,
        roi=_T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False),
    )


def joy_msg(axes: tuple[float, ...], buttons: tuple[int, ...], ns: int):
    return _T["sensor_msgs/msg/Joy"](
        header=header(ns, "joy"), axes=np.asarray(axes, dtype=np.float32), buttons=np.asarray(buttons, dtype=np.int32)
    )
