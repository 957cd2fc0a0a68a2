"""The recording contract (docs/recordings.md): topics, their ROS 2 types and QoS, frames, schemas.

Messages are encoded by `quadsim.recording.cdr` (by hand, byte for byte what ROS 2 writes) and
made once per step by `quadsim.recording.fanout`. rosbags' typestore (ROS 2 Humble, with the few
types that changed since taken from Jazzy: JAZZY_TYPES) stays the reference: it gives the
`ros2msg` schema texts (dependencies concatenated the way rosbag2 writes them), the live ROS 2
bridge's DDS types, and decodes recordings; it is imported only when one of those is needed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache
from typing import Any

from quadsim.core.kinematics import Mat3, mat_mul
from quadsim.core.types import Twist
from quadsim.sensors.camera import LINK_FROM_OPTICAL, CameraSpec
from quadsim.vehicle.params import CameraMount

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
QOS_LATCHED = _qos(1, 1)  # /tf_static, /robot_description, the markers: late joiners still get them
QOS_ROSOUT = _qos(1, 1000)  # as rcl offers /rosout: transient local, the last 1000


@dataclass(frozen=True)
class Topic:
    """A topic of the contract: its name, its ROS 2 type and the QoS it is offered with."""

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
ROSOUT = Topic("/rosout", "rcl_interfaces/msg/Log", QOS_ROSOUT)
ROBOT_DESCRIPTION = Topic("/robot_description", "std_msgs/msg/String", QOS_LATCHED)
#: the vehicle's model as markers in its own link frames (scene.robot_markers): drawn by every
#: viewer that draws markers, where a URDF from a topic under a fleet's name is not
ROBOT_MARKERS = Topic("/robot_markers", "visualization_msgs/msg/MarkerArray", QOS_LATCHED)
WORLD_MARKERS = Topic("/world/markers", "visualization_msgs/msg/MarkerArray", QOS_LATCHED)
#: the wind at the vehicle, `world` frame, in runs with wind (a state's sixth message)
WIND = Topic("/wind", "geometry_msgs/msg/Vector3Stamped")
#: goals a live input flies to (quadsim.drivers.goal): RViz 2's "2D Goal Pose", Foxglove's 3D panel
GOALS = (
    Topic("/goal_pose", "geometry_msgs/msg/PoseStamped"),
    Topic("/move_base_simple/goal", "geometry_msgs/msg/PoseStamped"),
)
#: the legend of the segmentation images: a JSON list of names, label id i is the body named [i]
#: (quadsim.sensors.images.segment_names); the run's one, in runs with a segmenting camera
SEGMENTATION_LABELS = Topic("/world/segmentation_labels", "std_msgs/msg/String", QOS_LATCHED)
STATE_TOPICS = (POSE, ODOM, IMU, ROTOR_THRUSTS, TF)
#: the range finder's readings, in runs with it (REP 117: +-inf out of range)
RANGE = Topic("/quad/range", "sensor_msgs/msg/Range")
#: the LiDAR's 2D scans, or its 3D scans as points in its frame, in runs with it
SCAN = Topic("/quad/scan", "sensor_msgs/msg/LaserScan")
POINTS = Topic("/quad/points", "sensor_msgs/msg/PointCloud2")
#: the range finder's frame (x along its beam, as sensor_msgs/Range has it) and the LiDAR's
#: (base_link's axes), each with a static transform from base_link
RANGE_FRAME = "range_finder_link"
LIDAR_FRAME = "lidar_link"
#: topics every quadsim recording has (cameras and /joy depend on the run)
CORE_TOPICS = (TWIST.name, *(t.name for t in STATE_TOPICS), TF_STATIC.name)


#: topics a fleet shares: one world, one TF tree, one log
SHARED_TOPICS = frozenset(
    {TF.name, TF_STATIC.name, ROSOUT.name, WORLD_MARKERS.name, SEGMENTATION_LABELS.name, "/clock"}
)


@dataclass(frozen=True)
class Names:
    """How one vehicle's topics and frames are named on the wire: as the contract has them for
    a run of one vehicle (`vehicle` empty), or with the vehicle's name in front in a fleet
    (/alpha/quad/odom, /alpha/quad_cmd_twist, TF frame alpha/base_link). The topics in
    SHARED_TOPICS and the `world` frame are the same for every vehicle."""

    vehicle: str = ""

    def topic(self, topic: Topic) -> Topic:
        if not self.vehicle or topic.name in SHARED_TOPICS:
            return topic
        return replace(topic, name=f"/{self.vehicle}{topic.name}")

    def frame(self, frame: str) -> str:
        if not self.vehicle or frame == WORLD_FRAME:
            return frame
        return f"{self.vehicle}/{frame}"


def twist_from_msg(msg: Any) -> Twist:
    """A decoded geometry_msgs/msg/Twist as quadsim's Twist, field by field."""
    lin, ang = msg.linear, msg.angular
    return Twist(linear_x=lin.x, linear_y=lin.y, linear_z=lin.z, angular_x=ang.x, angular_y=ang.y, angular_z=ang.z)


#: a camera's topics by kind: what follows its prefix (CameraSpec.topic_prefix), their type and the
#: CameraSpec field that asks for them (None: every camera has them), in the order a frame's messages
#: come. Its image and CameraInfo; its depth image (spec.depth: 32FC1 metres or 16UC1 millimetres,
#: REP 118) and that image's CameraInfo; its depth colour-mapped for people (a JPEG of the depth
#: image, turbo on a log scale from 0.2 m (red) to 50 m (blue), black where there is no depth); its
#: segmentation image (label ids: SEGMENTATION_LABELS says which is which body)
CAMERA_TOPICS = {
    "image": ("/image_raw/compressed", "sensor_msgs/msg/CompressedImage", None),
    "info": ("/camera_info", "sensor_msgs/msg/CameraInfo", None),
    "depth": ("/depth/image_raw", "sensor_msgs/msg/Image", "depth"),
    "depth_info": ("/depth/camera_info", "sensor_msgs/msg/CameraInfo", "depth"),
    "colormap": ("/depth/colormap/compressed", "sensor_msgs/msg/CompressedImage", "depth_colormap"),
    "segmentation": ("/segmentation/image_raw", "sensor_msgs/msg/Image", "segmentation"),
}


def frame_topics(spec: CameraSpec) -> dict[str, Topic]:
    """The topics one of the camera's frames becomes, by kind (CAMERA_TOPICS), where it has them."""
    return {
        kind: Topic(spec.topic_prefix + suffix, type_name)
        for kind, (suffix, type_name, asked_by) in CAMERA_TOPICS.items()
        if asked_by is None or getattr(spec, asked_by)
    }


#: the contract's types whose definition changed after Humble, as Jazzy and Kilted (the ROS 2
#: releases the live bridge serves) have them: sensor_msgs/Range gained `variance` in Jazzy, and a
#: Jazzy node cannot read a Humble Range (4 bytes short)
JAZZY_TYPES = ("sensor_msgs/msg/Range",)


@cache
def typestore() -> Any:
    """rosbags' ROS 2 Humble typestore with JAZZY_TYPES as Jazzy has them: the reference for
    schemas, the live bridge's types and decoding."""
    from rosbags.typesys import Stores, get_typestore

    humble, jazzy = get_typestore(Stores.ROS2_HUMBLE), get_typestore(Stores.ROS2_JAZZY)
    store = get_typestore(Stores.EMPTY)
    store.register({**humble.fielddefs, **{name: jazzy.fielddefs[name] for name in JAZZY_TYPES}})
    return store


@cache
def schema_text(type_name: str) -> str:
    """The `ros2msg` schema of a type, its dependencies concatenated as rosbag2 writes them."""
    return str(typestore().generate_msgdef(type_name, ros_version=2)[0])


def optical_rotation(mount: CameraMount) -> Mat3:
    """base_link <- optical frame of a camera."""
    return mat_mul(mount.rotation, LINK_FROM_OPTICAL)
