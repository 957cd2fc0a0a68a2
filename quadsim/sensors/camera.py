"""Onboard cameras as data: settings, intrinsics (CameraInfo), the view from the body's pose, frames.

A camera link's x axis is the viewing direction and its z axis the image's up (REP 103 body
axes). Images are published in the optical frame (x right, y down, z forward), which is the link
frame turned by the fixed rotation below.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, Any

from quadsim.core.kinematics import Mat3, matrix_from_quaternion, rotate
from quadsim.errors import ConfigError
from quadsim.vehicle.params import CameraMount

if TYPE_CHECKING:
    import numpy as np

#: optical frame axes expressed in the camera link frame: x_opt = -y_link, y_opt = -z_link, z_opt = x_link
LINK_FROM_OPTICAL: Mat3 = ((0.0, 0.0, 1.0), (-1.0, 0.0, 0.0), (0.0, -1.0, 0.0))


class ImageKind(enum.Enum):
    """What a rendered frame carries: what its consumers asked for."""

    JPEG = "jpeg"  # the RGB image JPEG-encoded (recordings, the window)
    RGB = "rgb"  # height x width x 3 uint8 (code)
    DEPTH = "depth"  # height x width float32, metres along the optical axis, inf where nothing was drawn
    SEGMENTATION = "segmentation"  # height x width int32: the body drawn at each pixel, -1 for none


#: the depth image encodings a camera may publish (REP 118): metres as float32, or millimetres
#: as uint16 (half the size; 0 where there is no depth, and beyond 65.535 m)
DEPTH_ENCODINGS = ("32FC1", "16UC1")
#: the depth encoding of a camera named without one (`--camera-depth front`): half the size
DEFAULT_DEPTH_ENCODING = "16UC1"


class RendererKind(enum.Enum):
    TINY = "tiny"  # PyBullet's TinyRenderer, on the CPU (always there)
    EGL = "egl"  # PyBullet's EGL plugin: needs an EGL driver (a GPU, or Mesa's)


@dataclass(frozen=True)
class CameraSpec:
    """One onboard camera. `name` makes the topics: /quad/<name>_camera/...

    Besides its JPEG images, a camera may publish a depth image (`depth`: one of
    DEPTH_ENCODINGS, "" for none), that depth colour-mapped for people as a JPEG
    (`depth_colormap`: quadsim.sensors.images.depth_colour_mapped; only with depth) and a
    segmentation image (`segmentation`), rendered with the same frame (docs/recordings.md)."""

    name: str
    link_name: str
    width_px: int = 320
    height_px: int = 240
    vertical_fov_deg: float = 60.0
    rate_hz: int = 30
    near_m: float = 0.05
    far_m: float = 100.0
    jpeg_quality: int = 85
    depth: str = ""
    segmentation: bool = False
    depth_colormap: bool = False

    def __post_init__(self) -> None:
        if self.depth not in ("", *DEPTH_ENCODINGS):
            raise ConfigError(
                f"camera {self.name}: depth encoding {self.depth!r:.20} must be one of {', '.join(DEPTH_ENCODINGS)}"
            )
        for key in ("segmentation", "depth_colormap"):
            if not isinstance(getattr(self, key), bool):
                raise ConfigError(f"camera {self.name}: {key} must be true or false, got {getattr(self, key)!r:.20}")
        if self.depth_colormap and not self.depth:
            raise ConfigError(f"camera {self.name}: a depth colour map needs the camera's depth image (depth)")
        if not (16 <= self.width_px <= 4096 and 16 <= self.height_px <= 4096):
            raise ConfigError(f"camera {self.name}: size {self.width_px}x{self.height_px} must be within 16..4096 px")
        if not 1.0 <= self.vertical_fov_deg <= 170.0:
            raise ConfigError(f"camera {self.name}: field of view {self.vertical_fov_deg} deg must be within 1..170")
        if not 1 <= self.jpeg_quality <= 100:
            raise ConfigError(f"camera {self.name}: JPEG quality must be within 1..100")
        if not 0 < self.near_m < self.far_m <= 1e5:
            raise ConfigError(f"camera {self.name}: need 0 < near < far <= 100 km")
        if isinstance(self.rate_hz, bool) or not isinstance(self.rate_hz, int) or not 1 <= self.rate_hz <= 1000:
            raise ConfigError(
                f"camera {self.name}: rate must be a whole number of Hz within 1..1000, got {self.rate_hz!r}"
            )

    @property
    def optical_frame(self) -> str:
        return f"{self.name}_camera_optical"

    @property
    def topic_prefix(self) -> str:
        return f"/quad/{self.name}_camera"

    @property
    def focal_px(self) -> float:
        """fx = fy: square pixels, and the projection's aspect ratio is width / height."""
        return (self.height_px / 2.0) / math.tan(math.radians(self.vertical_fov_deg) / 2.0)

    @property
    def principal_point_px(self) -> tuple[float, float]:
        """(cx, cy) with pixel centres at integer coordinates, as CameraInfo has them."""
        return ((self.width_px - 1) / 2.0, (self.height_px - 1) / 2.0)

    def k_matrix(self) -> tuple[float, ...]:
        f = self.focal_px
        cx, cy = self.principal_point_px
        return (f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0)

    def camera_info(self) -> CameraInfo:
        """The intrinsics of this camera's images, as sensor_msgs/CameraInfo has them (no distortion)."""
        f = self.focal_px
        cx, cy = self.principal_point_px
        return CameraInfo(
            frame_id=self.optical_frame,
            width_px=self.width_px,
            height_px=self.height_px,
            k=self.k_matrix(),
            p=(f, 0.0, cx, 0.0, 0.0, f, cy, 0.0, 0.0, 0.0, 1.0, 0.0),
        )

    def to_dict(self) -> dict[str, Any]:
        """Its fields, the images a camera may add (depth, segmentation, the colour map) only
        where it has them: a run without them describes its cameras as it always did, byte for
        byte (tests/integration/test_recording_golden.py)."""
        fields = asdict(self)
        for key, off in (("depth", ""), ("segmentation", False), ("depth_colormap", False)):
            if fields[key] == off:
                del fields[key]
        return fields


@dataclass(frozen=True)
class CameraInfo:
    """A camera's intrinsics, field for field as sensor_msgs/msg/CameraInfo (row-major matrices):
    a pixel (u, v) sees the ray ((u - cx) / fx, (v - cy) / fy, 1) in the optical frame."""

    frame_id: str
    width_px: int
    height_px: int
    k: tuple[float, ...]  # 3x3 camera matrix (fx, 0, cx, 0, fy, cy, 0, 0, 1)
    p: tuple[float, ...]  # 3x4 projection matrix
    d: tuple[float, ...] = (0.0,) * 5  # plumb_bob distortion: none (a rendered image)
    r: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)  # rectification: identity
    distortion_model: str = "plumb_bob"

    @property
    def fx(self) -> float:
        return self.k[0]

    @property
    def fy(self) -> float:
        return self.k[4]

    @property
    def cx(self) -> float:
        return self.k[2]

    @property
    def cy(self) -> float:
        return self.k[5]


def default_cameras(width_px: int = 320, height_px: int = 240, rate_hz: int = 30) -> tuple[CameraSpec, CameraSpec]:
    # the floor camera sits 3.4 cm above the skids' bottom: a near plane of 1 cm still sees the
    # ground when the vehicle has landed
    return (
        CameraSpec("front", "front_camera_link", width_px, height_px, 60.0, rate_hz),
        CameraSpec("floor", "floor_camera_link", width_px, height_px, 60.0, rate_hz, near_m=0.01),
    )


def with_images(
    specs: Sequence[CameraSpec],
    depth: Iterable[str],
    segmentation: Iterable[str],
    colormap: Iterable[str],
    where: tuple[str, str, str],
) -> tuple[CameraSpec, ...]:
    """`specs` with the depth, segmentation and colour-mapped depth images asked for by lists of
    camera names, as the command line and fleet files give them: depth as NAME or NAME:ENCODING
    (`front`, `floor:32FC1`; DEFAULT_DEPTH_ENCODING when none is said), segmentation and the
    depth colour map as NAME. A ConfigError starting with `where` (what says depth, segmentation,
    the colour map: an option, a key) names an unknown camera, encoding, a camera named twice, or
    a colour map for a camera without depth."""
    names = [s.name for s in specs]
    choices: dict[str, dict[str, Any]] = {name: {} for name in names}
    for key, items, what in zip(("depth", "segmentation", "depth_colormap"), (depth, segmentation, colormap), where):
        for item in items:
            if not isinstance(item, str):
                raise ConfigError(f"{what}: expected camera names, got {item!r:.40}")
            name, _, encoding = item.strip().partition(":")
            if key != "depth" and encoding:
                raise ConfigError(f"{what}: {item!r:.40}: a {key.replace('_', ' ')} image has no encoding to choose")
            if name not in choices:
                known = ", ".join(names) or "no camera"
                raise ConfigError(f"{what}: {name!r:.40} is not a camera of this run ({known})")
            if key in choices[name]:
                raise ConfigError(f"{what}: {name} is named twice")
            if key == "depth" and encoding not in ("", *DEPTH_ENCODINGS):
                raise ConfigError(f"{what}: depth encoding {encoding!r:.20}: choose {' or '.join(DEPTH_ENCODINGS)}")
            if key == "depth_colormap" and "depth" not in choices[name]:
                raise ConfigError(f"{what}: {name} has no depth image to colour-map (name it in {where[0]} too)")
            choices[name][key] = (encoding or DEFAULT_DEPTH_ENCODING) if key == "depth" else True
    return tuple(replace(spec, **choices[spec.name]) for spec in specs)


@dataclass(frozen=True)
class CameraPose:
    """A camera's pose in the world: eye, viewing direction, image up."""

    eye: tuple[float, float, float]
    forward: tuple[float, float, float]
    up: tuple[float, float, float]


def camera_pose(
    mount: CameraMount, position: tuple[float, float, float], orientation_xyzw: tuple[float, float, float, float]
) -> CameraPose:
    """The camera's pose for the body at (position, orientation)."""
    r = matrix_from_quaternion(orientation_xyzw)
    m = mount.rotation
    offset = rotate(r, mount.position_m)
    eye = (position[0] + offset[0], position[1] + offset[1], position[2] + offset[2])
    forward = rotate(r, (m[0][0], m[1][0], m[2][0]))  # the link's x axis
    up = rotate(r, (m[0][2], m[1][2], m[2][2]))  # the link's z axis
    return CameraPose(eye, forward, up)


@dataclass(frozen=True)
class CameraFrame:
    """One rendered image, stamped with the simulation step at which it was captured. It carries
    what was asked of the renderer (ImageKind); the rest is None."""

    camera: str
    step: int
    jpeg: bytes | None
    width_px: int
    height_px: int
    rgb: np.ndarray | None = None
    depth_m: np.ndarray | None = None
    segmentation: np.ndarray | None = None
    #: the depth in its camera's contract encoding (spec.depth: uint16 mm or float32 m), for a
    #: camera whose spec asks for it (quadsim.sensors.images.depth_image): half the bytes of
    #: `depth_m` to hand over from a render worker in 16UC1
    depth_pixels: np.ndarray | None = None
    #: the segmentation as the contract's label ids (uint8 or uint16; 0: nothing drawn), for a
    #: camera whose spec asks for it (quadsim.sensors.labels)
    labels: np.ndarray | None = None
    #: the depth colour-mapped for people, JPEG-encoded (quadsim.sensors.images.depth_jpeg), for a
    #: camera whose spec asks for it, made where the frame was rendered when JPEG was asked for
    depth_colormap_jpeg: bytes | None = None
