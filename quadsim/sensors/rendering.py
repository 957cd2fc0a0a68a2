"""Rendering the onboard cameras with PyBullet (TinyRenderer or EGL), and their JPEG coding."""

from __future__ import annotations

import contextlib
import importlib.util

import cv2
import numpy as np

from quadsim.errors import ConfigError
from quadsim.physics.pybullet_quiet import c_output_silenced, pb
from quadsim.sensors.camera import CameraPose, CameraSpec, RendererKind


def view_matrix(pose: CameraPose) -> tuple[float, ...]:
    target = (pose.eye[0] + pose.forward[0], pose.eye[1] + pose.forward[1], pose.eye[2] + pose.forward[2])
    return pb.computeViewMatrix(pose.eye, target, pose.up)


def projection_matrix(spec: CameraSpec) -> tuple[float, ...]:
    return pb.computeProjectionMatrixFOV(spec.vertical_fov_deg, spec.width_px / spec.height_px, spec.near_m, spec.far_m)


def render_raw(
    spec: CameraSpec,
    pose: CameraPose,
    cid: int,
    renderer: RendererKind = RendererKind.TINY,
    projection: tuple[float, ...] | None = None,
    segmentation: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """What the renderer drew: RGB (height x width x 3, uint8, row 0 at the top), the depth
    buffer (float32, 1.0 where nothing was drawn) and, if asked, the segmentation mask (int32:
    the PyBullet body id drawn at each pixel, -1 for none)."""
    args = (spec.width_px, spec.height_px, view_matrix(pose), projection or projection_matrix(spec))
    flags = 0 if segmentation else pb.ER_NO_SEGMENTATION_MASK
    tiny = renderer is RendererKind.TINY
    # the EGL plugin prints its GL vendor as it renders
    with contextlib.nullcontext() if tiny else c_output_silenced():
        kind = pb.ER_TINY_RENDERER if tiny else pb.ER_BULLET_HARDWARE_OPENGL
        _, _, rgba, depth, seg = pb.getCameraImage(*args, renderer=kind, flags=flags, physicsClientId=cid)
    shape = (spec.height_px, spec.width_px)
    rgb = np.ascontiguousarray(np.reshape(np.asarray(rgba, dtype=np.uint8), (*shape, 4))[:, :, :3])
    mask = np.reshape(np.asarray(seg, dtype=np.int32), shape) if segmentation else None
    return rgb, np.reshape(np.asarray(depth, dtype=np.float32), shape), mask


def depth_metres(spec: CameraSpec, depth_buffer: np.ndarray) -> np.ndarray:
    """The depth buffer as metres along the optical axis (float32; inf where nothing was drawn,
    as REP 118 has it for out-of-range pixels)."""
    near, far = np.float32(spec.near_m), np.float32(spec.far_m)
    with np.errstate(divide="ignore"):
        metres = far * near / (far - (far - near) * depth_buffer)
    metres[depth_buffer >= np.float32(0.99999)] = np.inf
    return metres.astype(np.float32, copy=False)


def is_blank(rgb: np.ndarray, depth: np.ndarray) -> bool:
    """True when a renderer drew nothing: one flat colour, or no depth anywhere."""
    return int(rgb.max()) - int(rgb.min()) <= 2 or float(depth.min()) >= 0.99999


class Atmosphere:
    """What makes a TinyRenderer image look like a camera's: sky and distance.

    TinyRenderer leaves the background white and samples textures without mip-mapping, so the
    far floor's grid lines alias into white speckle. From the depth buffer it has anyway:
    - distance blur: beyond `sharp_m` the image blends into a blurred copy, fully at `soft_m`
      (what mip-mapping would do for the texture);
    - aerial haze: the scene fades toward the horizon colour as exp(-distance / visibility);
    - sky: pixels with nothing drawn get a gradient by each pixel's elevation above the
      horizon, computed on a quarter-size grid and scaled up (it is smooth).
    About 1 ms per 320x240 frame (TinyRenderer itself takes 10-30 ms).
    """

    ZENITH_RGB = (70, 120, 190)
    HORIZON_RGB = (200, 218, 235)

    def __init__(
        self, spec: CameraSpec, visibility_m: float = 45.0, sharp_m: float = 4.0, soft_m: float = 16.0
    ) -> None:
        w, h = spec.width_px, spec.height_px
        f = spec.focal_px
        cx, cy = spec.principal_point_px
        xs, ys = np.meshgrid((np.arange(w) - cx) / f, (np.arange(h) - cy) / f)
        ray_length = np.sqrt(1.0 + xs * xs + ys * ys)  # distance per unit of depth along the axis
        near, far = spec.near_m, spec.far_m
        # depth buffer d -> distance = ray_length * far * near / (far - (far - near) d)
        self._k_haze = (ray_length * far * near / visibility_m).astype(np.float32)
        self._k_blur = (ray_length * far * near).astype(np.float32)
        self._far, self._far_near = np.float32(far), np.float32(far - near)
        self._sharp_m, self._blur_span_m = np.float32(sharp_m), np.float32(soft_m - sharp_m)
        # elevation of each pixel's ray on a quarter grid: fwd_z * a + left_z * b + up_z * c
        sx, sy = np.meshgrid((np.arange(w // 4) * 4 + 1.5 - cx) / f, (np.arange(h // 4) * 4 + 1.5 - cy) / f)
        norm = np.sqrt(1.0 + sx * sx + sy * sy)
        self._ray_fwd = (1.0 / norm).astype(np.float32)
        self._ray_left = (-sx / norm).astype(np.float32)
        self._ray_up = (-sy / norm).astype(np.float32)
        t = np.linspace(0.0, 1.0, 256) ** 0.6
        horizon, zenith = np.array(self.HORIZON_RGB, np.float64), np.array(self.ZENITH_RGB, np.float64)
        self._sky_lut = (horizon[None, :] * (1 - t[:, None]) + zenith[None, :] * t[:, None]).astype(np.uint8)
        self._sky_lut = self._sky_lut.reshape(256, 1, 3)
        self._haze = np.empty((h, w, 3), np.uint8)
        self._haze[:] = self.HORIZON_RGB
        self._size = (w, h)

    def apply(self, rgb: np.ndarray, depth: np.ndarray, pose: CameraPose) -> np.ndarray:
        denom = self._far - self._far_near * depth
        remaining = np.exp(-self._k_haze / denom)  # how much of the scene survives the haze
        sharp = np.clip((self._sharp_m + self._blur_span_m - self._k_blur / denom) / self._blur_span_m, 0.0, 1.0)
        blurred = cv2.GaussianBlur(rgb, (5, 5), 0)
        image = cv2.blendLinear(rgb, blurred, sharp, 1.0 - sharp)
        image = cv2.blendLinear(image, self._haze, remaining, 1.0 - remaining)
        sky = depth >= np.float32(0.99999)
        if sky.any():
            fwd, up = pose.forward, pose.up
            left_z = up[0] * fwd[1] - up[1] * fwd[0]  # z of up x forward
            elevation = (
                self._ray_fwd * np.float32(fwd[2])
                + self._ray_left * np.float32(left_z)
                + self._ray_up * np.float32(up[2])
            )
            index = (np.clip(elevation, 0.0, 1.0) * 255.0).astype(np.uint8)
            small = cv2.LUT(cv2.merge((index, index, index)), self._sky_lut)
            cv2.copyTo(cv2.resize(small, self._size, interpolation=cv2.INTER_LINEAR), sky.view(np.uint8), image)
        return image


def encode_jpeg(rgb: np.ndarray, quality: int) -> bytes:
    ok, buf = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:  # pragma: no cover - OpenCV fails only on invalid arrays
        raise RuntimeError("JPEG encoding failed")
    return buf.tobytes()


def decode_jpeg(data: bytes) -> np.ndarray:
    """JPEG bytes -> RGB array (for viewers and tests)."""
    bgr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError("not a decodable JPEG image")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def enable_egl(cid: int) -> None:
    """Load PyBullet's EGL renderer plugin into client `cid`, or raise ConfigError saying why not."""
    spec = importlib.util.find_spec("eglRenderer")
    if spec is None or spec.origin is None:
        raise ConfigError(
            "the EGL renderer: this pybullet build has no eglRenderer plugin; use the tiny renderer",
            "--renderer egl: this pybullet build has no eglRenderer plugin; use --renderer tiny",
        )
    with c_output_silenced():  # the plugin prints its GL vendor and version strings
        plugin = pb.loadPlugin(spec.origin, "_eglRendererPlugin", physicsClientId=cid)
    if plugin < 0:
        raise ConfigError(
            "the EGL renderer: its plugin did not load (no EGL driver on this machine?); use the tiny renderer",
            "--renderer egl: the EGL plugin did not load (no EGL driver on this machine?); use --renderer tiny",
        )
