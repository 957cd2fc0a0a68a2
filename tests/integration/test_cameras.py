"""The cameras show the world, their CameraInfo matches the projection used, and they are
deterministic whether rendered in-process or by worker processes."""

import math

import cv2
import numpy as np
import pytest

from quadsim import SimConfig, Simulator, StartPose, Twist, ZMode
from quadsim.core.kinematics import matrix_from_quaternion
from quadsim.physics.world_spec import load_world
from quadsim.recording.contract import optical_rotation
from quadsim.sensors.camera import CameraSpec, RendererKind, default_cameras
from quadsim.sensors.pipeline import CameraPipeline
from quadsim.sensors.rendering import decode_jpeg
from quadsim.sensors.rig import CameraRig
from quadsim.vehicle.params import load_vehicle


class Frames:
    def __init__(self):
        self.frames = []

    def on_camera_frame(self, frame):
        self.frames.append(frame)

    def last(self, camera):
        return next(f for f in reversed(self.frames) if f.camera == camera)


def _hovering_with_cameras(start=StartPose(), workers=0):
    sim = Simulator(SimConfig(z_mode=ZMode.HEIGHT, start=start))
    pipe = CameraPipeline(
        sim.vehicle, sim.world, 240, default_cameras(), workers=workers, scene_client=sim.scene_client
    )
    keep = Frames()
    pipe.sinks.append(keep)
    sim.send(Twist())
    _filmed_last(sim, pipe, 4.0)
    return sim, pipe, keep


def _filmed_last(sim, pipe, seconds):
    """Fly `seconds`, the cameras rendering only the last 0.2 s (six frames each): what the tests
    look at, without a whole flight's frames."""
    sim.remove_tap(pipe.capture)  # no error when it was not added
    sim.run_for(seconds - 0.2)
    sim.add_tap(pipe.tap_interval_steps, pipe.capture)
    sim.run_for(0.2)


def _red_mask(rgb):
    region = rgb.astype(int)
    return (region[..., 0] > 140) & (region[..., 1] < 60) & (region[..., 2] < 60)


def test_front_camera_sees_the_landmark_ahead():
    # the red tower (0.8 m square, 3 m tall) stands 6 m ahead of the start pose; from 2 m up its
    # near face should fill rows v = cy - f*1.0/5.6 .. cy + f*2.0/5.6 and 30 px around the centre
    sim, pipe, keep = _hovering_with_cameras()
    spec = default_cameras()[0]
    rgb = decode_jpeg(keep.last("front").jpeg)
    # the largest red blob (the floor texture has small red dots too)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(_red_mask(rgb).astype(np.uint8))
    tower = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    rows, cols = np.nonzero(labels == tower)
    f, (cx, cy) = spec.focal_px, spec.principal_point_px
    camera_z = sim.state.position_m[2]
    distance = 6.0 - 0.4 - 0.108 - sim.state.position_m[0]
    assert rows.min() == pytest.approx(cy - f * (3.0 - camera_z) / distance, abs=3)
    assert rows.max() == pytest.approx(cy + f * camera_z / distance, abs=3)
    assert cols.min() == pytest.approx(cx - f * 0.4 / distance, abs=3)
    assert cols.max() == pytest.approx(cx + f * 0.4 / distance, abs=3)
    pipe.close(), sim.close()
    # ...and it is gone when the vehicle faces the other way
    sim, pipe, keep = _hovering_with_cameras(StartPose(yaw_rad=math.pi))
    assert _red_mask(decode_jpeg(keep.last("front").jpeg)).mean() < 0.001
    pipe.close(), sim.close()


def test_floor_camera_sees_the_floor_move():
    sim, pipe, keep = _hovering_with_cameras()
    still = [decode_jpeg(f.jpeg) for f in keep.frames if f.camera == "floor"][-2:]
    sim.send(Twist(linear_x=1.0))
    _filmed_last(sim, pipe, 3.0)
    moving = [f for f in keep.frames if f.camera == "floor"][-2:]
    a, b = (cv2.cvtColor(decode_jpeg(f.jpeg), cv2.COLOR_RGB2GRAY).astype(np.float32) for f in moving)
    # a Hann window: without it the floor entering and leaving at the image edges can outweigh
    # the shift (the floor's grid lines are strong edges)
    window = cv2.createHanningWindow(a.shape[::-1], cv2.CV_32F)
    (dx, dy), _ = cv2.phaseCorrelate(a, b, window)
    # forward is image-up for the floor camera, so the floor slides down the image by
    # v * dt * f / height pixels between two frames
    height = sim.state.position_m[2] - 0.034
    expected = sim.state.linear_velocity_mps[0] * (1 / 30) * default_cameras()[1].focal_px / height
    assert dy == pytest.approx(expected, rel=0.25) and abs(dx) < 1.0
    (sx, sy), _ = cv2.phaseCorrelate(*(cv2.cvtColor(i, cv2.COLOR_RGB2GRAY).astype(np.float32) for i in still), window)
    assert abs(sx) < 0.3 and abs(sy) < 0.3  # hovering: the floor stays put
    pipe.close(), sim.close()


def test_camera_info_matches_the_rendered_projection(tmp_path):
    # a magenta ball at a known place, seen from a known, tilted pose: CameraInfo's K and the
    # optical frame of /tf_static must put it where the renderer drew it
    world = tmp_path / "marker.toml"
    world.write_text(
        "[floor]\nsize_m = 40.0\ntexture_tile_m = 4.0\n"
        '[[landmark]]\nname = "ball"\nshape = "sphere"\nposition_m = [4.0, 0.9, 2.7]\n'
        "size_m = [0.12, 0.12, 0.12]\ncolor_rgba = [1.0, 0.0, 1.0, 1.0]\n"
    )
    vehicle = load_vehicle()
    spec = CameraSpec("front", "front_camera_link", 320, 240, 60.0, 30)
    rig = CameraRig.standalone(vehicle, load_world(world), (spec,), RendererKind.TINY)
    from quadsim.physics.pybullet_quiet import pb

    position = (0.3, -0.2, 2.0)
    orientation = tuple(pb.getQuaternionFromEuler((0.08, -0.05, 0.25)))
    frame = rig.render(("front",), 0, position, orientation)[0]
    rig.close()
    rgb = decode_jpeg(frame.jpeg).astype(int)
    mask = (rgb[..., 0] - rgb[..., 1] > 80) & (rgb[..., 2] - rgb[..., 1] > 80)  # magenta, lit or shaded
    assert mask.sum() > 40
    vs, us = np.nonzero(mask)
    seen = (us.mean(), vs.mean())
    # project with the recorded calibration: world -> base_link -> optical -> pixels
    mount = vehicle.camera_mount("front_camera_link")
    r_wb = np.array(matrix_from_quaternion(orientation))
    r_bo = np.array(optical_rotation(mount))
    p_world = np.array([4.0, 0.9, 2.7])
    p_body = r_wb.T @ (p_world - np.array(position)) - np.array(mount.position_m)
    x, y, z = r_bo.T @ p_body
    k = spec.k_matrix()
    predicted = (k[0] * x / z + k[2], k[4] * y / z + k[5])
    assert math.dist(seen, predicted) < 1.0, (seen, predicted)


def test_unknown_camera_link_is_a_clear_error():
    from quadsim import ConfigError

    with Simulator(SimConfig()) as sim:
        with pytest.raises(ConfigError, match="no camera link named 'belly_camera_link'"):
            CameraPipeline(sim.vehicle, sim.world, 240, (CameraSpec("belly", "belly_camera_link"),), workers=0)
        with pytest.raises(ConfigError, match="does not divide"):
            CameraPipeline(
                sim.vehicle, sim.world, 240, (CameraSpec("front", "front_camera_link", rate_hz=25),), workers=0
            )


def test_images_look_like_a_cameras_sky_and_haze(tmp_path):
    """The front camera shows a blue sky above the horizon (not TinyRenderer's white) and a far
    floor without white speckle; the floor camera, looking down, has no sky."""
    sim, pipe, keep = _hovering_with_cameras()
    try:
        front = decode_jpeg(keep.last("front").jpeg).astype(int)
        floor = decode_jpeg(keep.last("floor").jpeg).astype(int)
        cv2.imwrite(str(tmp_path / "front.png"), cv2.cvtColor(front.astype(np.uint8), cv2.COLOR_RGB2BGR))
    finally:
        pipe.close()
        sim.close()
    top = front[:20]  # well above the horizon at 2 m of altitude
    assert (top[..., 2] > top[..., 0] + 40).mean() > 0.95  # blue, not white
    assert top[..., 2].mean() < 235 and top[:5, ..., 2].mean() < top[15:20, ..., 2].mean() + 5  # a gradient
    horizon_band = front[118:128]  # the far floor near the horizon (cy = 119.5)
    white = (horizon_band.min(axis=-1) > 235).mean()
    assert white < 0.01, f"{white:.1%} white speckle in the far floor"
    assert (floor[..., 2] > floor[..., 0] + 40).mean() < 0.05  # the floor camera sees no sky


def test_a_renderer_that_draws_nothing_is_refused(monkeypatch):
    """No blank frames recorded without a word: the first frame of each camera is checked."""
    from quadsim import ConfigError
    from quadsim.sensors import rig as rig_module
    from quadsim.sensors.camera import RendererKind
    from quadsim.sensors.rig import CameraRig

    def blank(spec, *args, **kwargs):
        shape = (spec.height_px, spec.width_px)
        return np.full((*shape, 3), 178, np.uint8), np.ones(shape, np.float32), None

    monkeypatch.setattr(rig_module, "render_raw", blank)
    with Simulator(SimConfig()) as sim:
        rig = CameraRig(
            sim.vehicle, default_cameras(), RendererKind.EGL, sim.scene_client.cid, None, scene=sim.scene_client
        )
        state = sim.state
        with pytest.raises(ConfigError, match="drew nothing in the front camera"):
            rig.render(("front",), 0, state.position_m, state.orientation_xyzw)
