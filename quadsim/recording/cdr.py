"""CDR encoding, written by hand, of the ROS 2 messages the recording contract uses.

The bytes are the ones ROS 2's type support writes (the tests compare them with rosbags'
`serialize_cdr`, the reference, byte for byte): a 4-byte encapsulation header (CDR, little
endian), then the fields in order, each primitive aligned to its own size counted from the end
of that header; a string is a uint32 length that counts its terminating NUL, then its UTF-8 bytes
and the NUL; a sequence is a uint32 count, then its elements (aligned only when there is one).

Each message shape (its frame names, the lengths of its strings and sequences) compiles once to
a struct.Struct, so encoding a message is one `pack` call. The `*_encoder` functions give that
compiled encoder for a fixed shape (what a producer calls many times a second); the plain
functions take any shape. Covariances left out (None) are all zeros, ROS's "unknown", written as
padding, which is much cheaper than packing 36 floats.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from functools import lru_cache
from typing import NamedTuple

#: CDR_LE (representation 0x0001, big-endian on the wire) and options 0
ENCAPSULATION = b"\x00\x01\x00\x00"
NS_PER_S = 1_000_000_000

Vec3 = Sequence[float]  # x, y, z
Quat = Sequence[float]  # x, y, z, w


class _Layout:
    """Builds the struct format of one message shape, keeping track of CDR alignment."""

    def __init__(self) -> None:
        self._codes = ["<4s"]  # the encapsulation header, passed as ENCAPSULATION
        self._offset = 0  # from the end of the encapsulation header

    def _align(self, size: int) -> None:
        pad = -self._offset % size
        if pad:
            self._codes.append(f"{pad}x")
            self._offset += pad

    def scalars(self, code: str, count: int = 1, zeros: bool = False) -> _Layout:
        """`count` primitives of struct code `code` (d, f, I, i, B, ?); with `zeros`, all zero,
        written as padding (nothing to pass)."""
        if count:
            size = struct.calcsize(code)
            self._align(size)
            self._codes.append(f"{size * count}x" if zeros else f"{count}{code}")
            self._offset += size * count
        return self

    def string(self, text: bytes) -> _Layout:
        """A string, passed as `_text` made it (its length and bytes; the NUL is the field's
        last byte, which struct pads)."""
        self._align(4)
        self._codes.append(f"{len(text) + 1}s")
        self._offset += len(text) + 1
        return self

    def header(self, frame: bytes) -> _Layout:
        """std_msgs/Header: stamp (int32 sec, uint32 nanosec), frame_id (from `_text`)."""
        return self.scalars("i").scalars("I").string(frame)

    def sequence(self, code: str, count: int) -> _Layout:
        """A sequence of `count` primitives: pass the count, then the elements."""
        return self.scalars("I").scalars(code, count)

    def build(self) -> struct.Struct:
        return struct.Struct("".join(self._codes))


def _text(value: str) -> bytes:
    """A CDR string as one struct field: its uint32 length (counting the NUL), then its UTF-8 bytes."""
    data = value.encode()
    return struct.pack("<I", len(data) + 1) + data


#: the empty string, as `_text` makes it
_EMPTY = _text("")


def _given(values: Sequence[float] | None) -> Sequence[float]:
    return () if values is None else values


# --- geometry_msgs ---------------------------------------------------------------------------

_TWIST = _Layout().scalars("d", 6).build()


def twist(linear: Vec3, angular: Vec3) -> bytes:
    """geometry_msgs/msg/Twist."""
    return _TWIST.pack(ENCAPSULATION, *linear, *angular)


_BYTE_ORDER = {b"\x00\x01": "<", b"\x00\x00": ">"}  # CDR_LE, CDR_BE


def twist_fields(data: bytes) -> tuple[float, float, float, float, float, float]:
    """The six fields (linear x y z, angular x y z) of a CDR geometry_msgs/msg/Twist, in either
    byte order. ValueError for bytes that are not one."""
    order = _BYTE_ORDER.get(bytes(data[:2]))
    if order is None or len(data) < 4 + 48:
        raise ValueError(f"not a CDR geometry_msgs/msg/Twist ({len(data)} bytes, header {bytes(data[:4]).hex()})")
    return struct.unpack_from(order + "6d", data, 4)


#: the longest frame_id a decoded PoseStamped may name (a TF frame name is a few dozen bytes)
MAX_FRAME_ID_BYTES = 256


def pose_stamped_fields(
    data: bytes,
) -> tuple[str, tuple[float, float, float], tuple[float, float, float, float]]:
    """frame_id, position and orientation (x, y, z, w) of a CDR geometry_msgs/msg/PoseStamped, in
    either byte order. ValueError for bytes that are not one (a frame_id past MAX_FRAME_ID_BYTES
    included)."""
    order = _BYTE_ORDER.get(bytes(data[:2]))
    if order is None or len(data) < 16:
        raise ValueError(f"not a CDR geometry_msgs/msg/PoseStamped ({len(data)} bytes)")
    (length,) = struct.unpack_from(order + "I", data, 12)  # after the header's stamp (sec, nanosec)
    if not 1 <= length <= MAX_FRAME_ID_BYTES or len(data) < 16 + length:
        raise ValueError(f"not a CDR geometry_msgs/msg/PoseStamped (a frame_id of {length} bytes)")
    frame = bytes(data[16 : 16 + length - 1])
    start = 4 + (12 + length + 7) // 8 * 8  # the doubles align to 8 from the encapsulation's end
    if len(data) < start + 56:
        raise ValueError(f"not a CDR geometry_msgs/msg/PoseStamped ({len(data)} bytes)")
    values = struct.unpack_from(order + "7d", data, start)
    try:
        frame_id = frame.decode()
    except UnicodeDecodeError:
        raise ValueError("a PoseStamped whose frame_id is not UTF-8") from None
    return frame_id, (values[0], values[1], values[2]), (values[3], values[4], values[5], values[6])


@lru_cache(maxsize=256)
def pose_stamped_encoder(frame_id: str) -> Callable[[int, Vec3, Quat], bytes]:
    """geometry_msgs/msg/PoseStamped in `frame_id`: encode(ns, position, orientation)."""
    frame = _text(frame_id)
    pack = _Layout().header(frame).scalars("d", 7).build().pack

    def encode(ns: int, position: Vec3, orientation: Quat) -> bytes:
        return pack(ENCAPSULATION, *divmod(ns, NS_PER_S), frame, *position, *orientation)

    return encode


def pose_stamped(ns: int, frame_id: str, position: Vec3, orientation: Quat) -> bytes:
    """geometry_msgs/msg/PoseStamped."""
    return pose_stamped_encoder(frame_id)(ns, position, orientation)


@lru_cache(maxsize=256)
def _vector3_stamped(frame_id: str) -> tuple[struct.Struct, bytes]:
    frame = _text(frame_id)
    return _Layout().header(frame).scalars("d", 3).build(), frame


def vector3_stamped(ns: int, frame_id: str, vector: Vec3) -> bytes:
    """geometry_msgs/msg/Vector3Stamped."""
    layout, frame = _vector3_stamped(frame_id)
    return layout.pack(ENCAPSULATION, *divmod(ns, NS_PER_S), frame, *vector)


# --- nav_msgs, sensor_msgs ---------------------------------------------------------------------


@lru_cache(maxsize=256)
def odometry_encoder(
    frame_id: str, child_frame_id: str, pose_covariance: bool = False, twist_covariance: bool = False
) -> Callable[..., bytes]:
    """nav_msgs/msg/Odometry, pose in `frame_id`, twist in `child_frame_id`: encode(ns, position,
    orientation, linear, angular, pose_cov, twist_cov), each covariance 36 values where its flag
    is set, and () (all zeros) where it is not."""
    frame, child = _text(frame_id), _text(child_frame_id)
    layout = _Layout().header(frame).string(child).scalars("d", 7)  # pose: position, orientation
    layout = layout.scalars("d", 36, zeros=not pose_covariance).scalars("d", 6)  # twist: linear, angular
    pack = layout.scalars("d", 36, zeros=not twist_covariance).build().pack

    def encode(
        ns: int,
        position: Vec3,
        orientation: Quat,
        linear: Vec3,
        angular: Vec3,
        pose_cov: Sequence[float] = (),
        twist_cov: Sequence[float] = (),
    ) -> bytes:
        sec, nanosec = divmod(ns, NS_PER_S)
        return pack(
            ENCAPSULATION, sec, nanosec, frame, child, *position, *orientation, *pose_cov, *linear, *angular, *twist_cov
        )

    return encode


def odometry(
    ns: int,
    frame_id: str,
    child_frame_id: str,
    position: Vec3,
    orientation: Quat,
    linear: Vec3,
    angular: Vec3,
    pose_covariance: Sequence[float] | None = None,
    twist_covariance: Sequence[float] | None = None,
) -> bytes:
    """nav_msgs/msg/Odometry: pose in `frame_id`, twist in `child_frame_id`. Covariances: 36 each."""
    encode = odometry_encoder(frame_id, child_frame_id, pose_covariance is not None, twist_covariance is not None)
    return encode(ns, position, orientation, linear, angular, _given(pose_covariance), _given(twist_covariance))


@lru_cache(maxsize=256)
def imu_encoder(frame_id: str, covariances: tuple[bool, bool, bool] = (False, False, False)) -> Callable[..., bytes]:
    """sensor_msgs/msg/Imu in `frame_id`: encode(ns, orientation, angular_velocity,
    linear_acceleration, orientation_cov, angular_velocity_cov, linear_acceleration_cov), each
    covariance (9 values) where `covariances` says it is given, () where it is all zeros."""
    frame = _text(frame_id)
    layout = _Layout().header(frame)
    for count, given in zip((4, 3, 3), covariances):  # orientation, angular velocity, linear acceleration
        layout = layout.scalars("d", count).scalars("d", 9, zeros=not given)
    pack = layout.build().pack

    def encode(
        ns: int,
        orientation: Quat,
        angular_velocity: Vec3,
        linear_acceleration: Vec3,
        orientation_cov: Sequence[float] = (),
        angular_velocity_cov: Sequence[float] = (),
        linear_acceleration_cov: Sequence[float] = (),
    ) -> bytes:
        return pack(
            ENCAPSULATION,
            *divmod(ns, NS_PER_S),
            frame,
            *orientation,
            *orientation_cov,
            *angular_velocity,
            *angular_velocity_cov,
            *linear_acceleration,
            *linear_acceleration_cov,
        )

    return encode


def imu(
    ns: int,
    frame_id: str,
    orientation: Quat,
    angular_velocity: Vec3,
    linear_acceleration: Vec3,
    orientation_covariance: Sequence[float] | None = None,
    angular_velocity_covariance: Sequence[float] | None = None,
    linear_acceleration_covariance: Sequence[float] | None = None,
) -> bytes:
    """sensor_msgs/msg/Imu. Covariances: 9 each."""
    covariances = (orientation_covariance, angular_velocity_covariance, linear_acceleration_covariance)
    encode = imu_encoder(frame_id, (covariances[0] is not None, covariances[1] is not None, covariances[2] is not None))
    return encode(ns, orientation, angular_velocity, linear_acceleration, *(_given(c) for c in covariances))


@lru_cache(maxsize=256)
def _compressed_image(frame_id: str, image_format: str) -> tuple[struct.Struct, bytes, bytes]:
    frame, fmt = _text(frame_id), _text(image_format)
    return _Layout().header(frame).string(fmt).scalars("I").build(), frame, fmt


def compressed_image(ns: int, frame_id: str, image_format: str, data: bytes) -> bytes:
    """sensor_msgs/msg/CompressedImage (`image_format` e.g. "jpeg")."""
    layout, frame, fmt = _compressed_image(frame_id, image_format)
    # uint8 elements need no alignment: the data follows its count directly
    return layout.pack(ENCAPSULATION, *divmod(ns, NS_PER_S), frame, fmt, len(data)) + data


@lru_cache(maxsize=256)
def _image(frame_id: str, encoding: str) -> tuple[struct.Struct, bytes, bytes]:
    frame, enc = _text(frame_id), _text(encoding)
    layout = _Layout().header(frame).scalars("I", 2).string(enc).scalars("B").scalars("I", 2)
    return layout.build(), frame, enc  # height, width, encoding, is_bigendian, step, the data's count


def image(
    ns: int, frame_id: str, height: int, width: int, encoding: str, step: int, data: bytes, is_bigendian: bool = False
) -> bytes:
    """sensor_msgs/msg/Image: `height` rows of `step` bytes each in `data` (e.g. "32FC1")."""
    layout, frame, enc = _image(frame_id, encoding)
    head = layout.pack(*_image_head(ns, frame, height, width, enc), is_bigendian, step, len(data))
    return head + data  # uint8 elements: no alignment after the count


def _image_head(ns: int, frame: bytes, height: int, width: int, text: bytes) -> tuple[object, ...]:
    """What Image and CameraInfo begin with: the header, height, width and a string (the
    encoding; the distortion model)."""
    return (ENCAPSULATION, *divmod(ns, NS_PER_S), frame, height, width, text)


@lru_cache(maxsize=256)
def range_encoder(
    frame_id: str,
    radiation_type: int,
    field_of_view_rad: float,
    min_range_m: float,
    max_range_m: float,
    variance_m2: float = 0.0,
) -> Callable[[int, float], bytes]:
    """sensor_msgs/msg/Range as Jazzy has it (with `variance`, 0: unknown) from a fixed sensor in
    `frame_id` (radiation_type 0 ultrasound, 1 infrared): encode(ns, range_m)."""
    frame = _text(frame_id)
    pack = _Layout().header(frame).scalars("B").scalars("f", 5).build().pack
    fixed = (frame, radiation_type, field_of_view_rad, min_range_m, max_range_m)

    def encode(ns: int, range_m: float) -> bytes:
        return pack(ENCAPSULATION, *divmod(ns, NS_PER_S), *fixed, range_m, variance_m2)

    return encode


@lru_cache(maxsize=256)
def laser_scan_encoder(
    frame_id: str, angles: tuple[float, float, float], times: tuple[float, float], limits: tuple[float, float]
) -> Callable[[int, bytes], bytes]:
    """sensor_msgs/msg/LaserScan in `frame_id` with `angles` (min, max, increment), `times`
    (time_increment, scan_time) and `limits` (range_min, range_max), no intensities:
    encode(ns, ranges), `ranges` the float32 values as little-endian bytes."""
    frame = _text(frame_id)
    pack = _Layout().header(frame).scalars("f", 7).scalars("I").build().pack
    fixed = (frame, *angles, *times, *limits)
    no_intensities = struct.pack("<I", 0)  # ranges end 4-aligned: the count follows them directly

    def encode(ns: int, ranges: bytes) -> bytes:
        return pack(ENCAPSULATION, *divmod(ns, NS_PER_S), *fixed, len(ranges) // 4) + ranges + no_intensities

    return encode


#: sensor_msgs/msg/PointField's datatype for float32
FLOAT32 = 7


@lru_cache(maxsize=256)
def xyz_cloud_encoder(frame_id: str) -> Callable[[int, bytes], bytes]:
    """sensor_msgs/msg/PointCloud2 in `frame_id` of unordered points (height 1) with float32 x, y,
    z fields, little-endian, dense: encode(ns, points), `points` 12 bytes a point."""
    frame = _text(frame_id)
    layout = _Layout().header(frame).scalars("I", 2).scalars("I")  # height, width, field count
    fields: list[object] = []
    for offset, name in enumerate(map(_text, "xyz")):
        layout = layout.string(name).scalars("I").scalars("B").scalars("I")  # name, offset, datatype, count
        fields += (name, 4 * offset, FLOAT32, 1)
    pack = layout.scalars("?").scalars("I", 2).scalars("I").build().pack  # is_bigendian, steps, data count
    dense = b"\x01"

    def encode(ns: int, points: bytes) -> bytes:
        width = len(points) // 12
        head = pack(
            ENCAPSULATION, *divmod(ns, NS_PER_S), frame, 1, width, 3, *fields, False, 12, len(points), len(points)
        )
        return head + points + dense

    return encode


class RegionOfInterest(NamedTuple):
    x_offset: int = 0
    y_offset: int = 0
    height: int = 0
    width: int = 0
    do_rectify: bool = False


#: the whole image (sensor_msgs' "all zeros: full resolution")
FULL_IMAGE = RegionOfInterest()


@lru_cache(maxsize=256)
def _camera_info(frame_id: str, distortion_model: str, d_count: int) -> tuple[struct.Struct, bytes, bytes]:
    frame, model = _text(frame_id), _text(distortion_model)
    layout = _Layout().header(frame).scalars("I", 2).string(model).sequence("d", d_count)
    layout = layout.scalars("d", 9 + 9 + 12).scalars("I", 2)  # k, r, p; binning_x, binning_y
    return layout.scalars("I", 4).scalars("?").build(), frame, model  # roi


def camera_info(
    ns: int,
    frame_id: str,
    height: int,
    width: int,
    distortion_model: str,
    d: Sequence[float],
    k: Sequence[float],
    r: Sequence[float],
    p: Sequence[float],
    binning_x: int = 0,
    binning_y: int = 0,
    roi: RegionOfInterest = FULL_IMAGE,
) -> bytes:
    """sensor_msgs/msg/CameraInfo (k and r: 9 values, p: 12)."""
    if (len(k), len(r), len(p)) != (9, 9, 12):
        raise ValueError(f"CameraInfo needs 9 k, 9 r and 12 p values, got {len(k)}, {len(r)}, {len(p)}")
    layout, frame, model = _camera_info(frame_id, distortion_model, len(d))
    return layout.pack(
        *_image_head(ns, frame, height, width, model),
        len(d),
        *d,
        *k,
        *r,
        *p,
        binning_x,
        binning_y,
        *roi,
    )


@lru_cache(maxsize=256)
def _joy(frame_id: str, axes: int, buttons: int) -> tuple[struct.Struct, bytes]:
    frame = _text(frame_id)
    return _Layout().header(frame).sequence("f", axes).sequence("i", buttons).build(), frame


def joy(ns: int, frame_id: str, axes: Sequence[float], buttons: Sequence[int]) -> bytes:
    """sensor_msgs/msg/Joy (axes float32, buttons int32)."""
    layout, frame = _joy(frame_id, len(axes), len(buttons))
    return layout.pack(ENCAPSULATION, *divmod(ns, NS_PER_S), frame, len(axes), *axes, len(buttons), *buttons)


# --- std_msgs, tf2_msgs, rcl_interfaces ----------------------------------------------------------


class ArrayDimension(NamedTuple):
    """std_msgs/msg/MultiArrayDimension."""

    label: str
    size: int
    stride: int


@lru_cache(maxsize=256)
def float64_multi_array_encoder(
    dims: tuple[ArrayDimension, ...], count: int, data_offset: int = 0
) -> Callable[[Sequence[float]], bytes]:
    """std_msgs/msg/Float64MultiArray with this layout and `count` values: encode(data)."""
    layout = _Layout().scalars("I")  # dim count
    head: list[object] = [ENCAPSULATION, len(dims)]
    for dim in dims:
        label = _text(dim.label)
        layout = layout.string(label).scalars("I", 2)  # size, stride
        head += (label, dim.size, dim.stride)
    pack = layout.scalars("I").sequence("d", count).build().pack  # data_offset, data
    fixed = (*head, data_offset, count)

    def encode(data: Sequence[float]) -> bytes:
        return pack(*fixed, *data)

    return encode


def float64_multi_array(data: Sequence[float], dims: Sequence[ArrayDimension] = (), data_offset: int = 0) -> bytes:
    """std_msgs/msg/Float64MultiArray."""
    return float64_multi_array_encoder(tuple(dims), len(data), data_offset)(data)


class TransformStamped(NamedTuple):
    """geometry_msgs/msg/TransformStamped: `child_frame_id` in `frame_id` at `ns`."""

    ns: int
    frame_id: str
    child_frame_id: str
    translation: Vec3
    rotation: Quat


@lru_cache(maxsize=256)
def _tf_message(frames: tuple[tuple[str, str], ...]) -> tuple[struct.Struct, tuple[tuple[bytes, bytes], ...]]:
    layout = _Layout().scalars("I")  # transform count
    encoded = tuple((_text(parent), _text(child)) for parent, child in frames)
    for parent, child in encoded:
        layout = layout.header(parent).string(child).scalars("d", 7)  # translation, rotation
    return layout.build(), encoded


def tf_message(transforms: Sequence[TransformStamped]) -> bytes:
    """tf2_msgs/msg/TFMessage."""
    layout, frames = _tf_message(tuple((t.frame_id, t.child_frame_id) for t in transforms))
    args: list[object] = [ENCAPSULATION, len(transforms)]
    for t, (parent, child) in zip(transforms, frames):
        args += (*divmod(t.ns, NS_PER_S), parent, child, *t.translation, *t.rotation)
    return layout.pack(*args)


@lru_cache(maxsize=256)
def transform_encoder(frame_id: str, child_frame_id: str) -> Callable[[int, Vec3, Quat], bytes]:
    """tf2_msgs/msg/TFMessage with one transform, `child_frame_id` in `frame_id`:
    encode(ns, translation, rotation) (what /tf carries for a single body)."""
    layout, ((parent, child),) = _tf_message(((frame_id, child_frame_id),))
    pack = layout.pack

    def encode(ns: int, translation: Vec3, rotation: Quat) -> bytes:
        return pack(ENCAPSULATION, 1, *divmod(ns, NS_PER_S), parent, child, *translation, *rotation)

    return encode


def string(data: str) -> bytes:
    """std_msgs/msg/String (latched messages: not compiled)."""
    text = _text(data)
    return _Layout().string(text).build().pack(ENCAPSULATION, text)


class LogLevel:
    """rcl_interfaces/msg/Log levels."""

    DEBUG = 10
    INFO = 20
    WARN = 30
    ERROR = 40
    FATAL = 50


def log(ns: int, level: int, name: str, msg: str, file: str = "", function: str = "", line: int = 0) -> bytes:
    """rcl_interfaces/msg/Log (what /rosout carries, an event at a time: not compiled)."""
    texts = [_text(s) for s in (name, msg, file, function)]
    layout = _Layout().scalars("i").scalars("I").scalars("B")  # stamp, level
    for text in texts:  # name, msg, file, function; then line
        layout.string(text)
    return layout.scalars("I").build().pack(ENCAPSULATION, *divmod(ns, NS_PER_S), level, *texts, line)


# --- visualization_msgs ------------------------------------------------------------------------

Rgba = Sequence[float]  # r, g, b, a in 0..1 (float32 on the wire)


class MarkerType:
    """visualization_msgs/msg/Marker shapes (the ones quadsim draws)."""

    CUBE = 1
    SPHERE = 2
    CYLINDER = 3
    TEXT_VIEW_FACING = 9


class Marker(NamedTuple):
    """visualization_msgs/msg/Marker: a shape `scale` big at a pose in `frame_id` (action ADD).

    The texture, its UV coordinates and the embedded mesh file (fields since ROS 2 Humble) are
    always written empty: quadsim draws primitive shapes only."""

    ns: int  # header stamp
    frame_id: str
    namespace: str
    id: int
    type: int
    position: Vec3
    orientation: Quat
    scale: Vec3
    color: Rgba
    action: int = 0
    lifetime_ns: int = 0  # 0: forever
    frame_locked: bool = False
    points: Sequence[Vec3] = ()
    colors: Sequence[Rgba] = ()
    texture_resource: str = ""
    text: str = ""
    mesh_resource: str = ""
    mesh_use_embedded_materials: bool = False


def _marker(layout: _Layout, args: list[object], m: Marker) -> None:
    """Append one Marker's layout and values."""
    frame, namespace, texture, text, mesh = map(
        _text, (m.frame_id, m.namespace, m.texture_resource, m.text, m.mesh_resource)
    )
    layout.header(frame).string(namespace).scalars("i", 3)  # id, type, action
    layout.scalars("d", 7).scalars("d", 3).scalars("f", 4)  # pose, scale, color
    layout.scalars("i").scalars("I").scalars("?")  # lifetime, frame_locked
    layout.sequence("d", 3 * len(m.points)).sequence("f", 4 * len(m.colors))
    layout.string(texture)
    layout.header(_EMPTY).string(_EMPTY).sequence("B", 0)  # texture: an empty CompressedImage
    layout.sequence("f", 0)  # uv_coordinates
    layout.string(text).string(mesh)
    layout.string(_EMPTY).sequence("B", 0).scalars("?")  # mesh_file (empty), mesh_use_embedded_materials
    args += (*divmod(m.ns, NS_PER_S), frame, namespace, m.id, m.type, m.action)
    args += (*m.position, *m.orientation, *m.scale, *m.color, *divmod(m.lifetime_ns, NS_PER_S), m.frame_locked)
    args += (len(m.points), *(v for p in m.points for v in p), len(m.colors), *(v for c in m.colors for v in c))
    args += (texture, 0, 0, _EMPTY, _EMPTY, 0, 0)
    args += (text, mesh, _EMPTY, 0, m.mesh_use_embedded_materials)


def marker_array(markers: Sequence[Marker]) -> bytes:
    """visualization_msgs/msg/MarkerArray (encoded once per consumer: not compiled)."""
    layout = _Layout().scalars("I")
    args: list[object] = [ENCAPSULATION, len(markers)]
    for m in markers:
        _marker(layout, args, m)
    return layout.build().pack(*args)
