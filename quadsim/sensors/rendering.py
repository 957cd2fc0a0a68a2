"""Rendering the onboard cameras with PyBullet (TinyRenderer or EGL), and their JPEG coding."""

from __future__ import annotations

import importlib.util

import cv2
import numpy as np

from quadsim.errors import ConfigError
from quadsim.physics.pybullet_quiet import pb
from quadsim.sensors.camera import CameraPose, CameraSpec, RendererKind


def view_matrix(pose: CameraPose) -> tuple[float, ...]:
    target = (pose.eye[0] + pose.forward[0], pose.eye[1] + pose.forward[1], pose.eye[2] + pose.forward[2])
    return pb.computeViewMatrix(pose.eye, target, pose.up)


def projection_matrix(spec: CameraSpec) -> tuple[float, ...]:
    return pb.computeProjectionMatrixFOV(spec.vertical_fov_deg, spec.width_px / spec.height_px, spec.near_m, spec.far_m)


def render_rgb(
    spec: CameraSpec,
    pose: CameraPose,
    cid: int,
    renderer: RendererKind = RendererKind.TINY,
    projection: tuple[float, ...] | None = None,
) -> np.ndarray:
    """Render one RGB image (height x width x 3, uint8, row 0 at the top). No segmentation mask."""
    flags = pb.ER_NO_SEGMENTATION_MASK
    engine = pb.ER_TINY_RENDERER if renderer is RendererKind.TINY else pb.ER_BULLET_HARDWARE_OPENGL
    _, _, rgba, _, _ = pb.getCameraImage(
        spec.width_px,
        spec.height_px,
        view_matrix(pose),
        projection or projection_matrix(spec),
        renderer=engine,
        flags=flags,
        physicsClientId=cid,
    )
    return np.reshape(np.asarray(rgba, dtype=np.uint8), (spec.height_px, spec.width_px, 4))[:, :, :3]


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
        raise ConfigError("--renderer egl: this pybullet build has no eglRenderer plugin; use --renderer tiny")
    plugin = pb.loadPlugin(spec.origin, "_eglRendererPlugin", physicsClientId=cid)
    if plugin < 0:
        raise ConfigError(
            "--renderer egl: the EGL plugin did not load (no EGL driver on this machine?); use --renderer tiny"
        )
