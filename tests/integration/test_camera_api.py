"""Camera images in the Python API (quadsim.Cameras): arrays, stamps, intrinsics, depth and
segmentation, the two modes, and recording with either."""

from __future__ import annotations

import numpy as np
import pytest

from quadsim import CameraMode, Cameras, CameraSpec, QuadsimError, SimConfig, Simulator, Twist, ZMode, record
from quadsim.recording.flight import load_flight
from quadsim.sensors.rendering import decode_jpeg

FRONT = CameraSpec("front", "front_camera_link", 96, 72, rate_hz=30)
FLOOR = CameraSpec("floor", "floor_camera_link", 64, 48, rate_hz=10, near_m=0.01)


def _climb(sim: Simulator, steps: int = 240) -> None:
    sim.send(Twist(linear_z=1.0))
    sim.step(steps)


def test_sync_images_are_arrays_of_the_current_step_with_their_intrinsics():
    with Simulator(SimConfig(z_mode=ZMode.VELOCITY)) as sim, Cameras(sim, (FRONT, FLOOR)) as cams:
        first = cams.latest("front")
        assert first is not None and first.step == 0  # there from the start
        assert first.rgb.shape == (72, 96, 3) and first.rgb.dtype == np.uint8
        assert first.depth_m is None and first.segmentation is None  # not asked for
        assert first.info == FRONT.camera_info()
        assert (first.info.width_px, first.info.height_px, first.info.frame_id) == (96, 72, "front_camera_optical")
        assert first.info.cx == pytest.approx(47.5) and first.info.fx == pytest.approx(36.0 / np.tan(np.pi / 6))
        _climb(sim, 243)
        # each camera at its own rate, captured before step() returned
        assert cams.latest("front").step == 240  # every 8 steps
        assert cams.latest("floor").step == 240  # every 24 steps
        assert cams.frame_age_steps("front") == 3
        sim.step(5)
        assert cams.latest("front").step == 248 and cams.latest("floor").step == 240
        with pytest.raises(QuadsimError, match="no camera 'rear'"):
            cams.latest("rear")


def test_sync_images_are_deterministic_and_see_the_tower_with_depth_and_labels():
    images = []
    for _ in range(2):
        with (
            Simulator(SimConfig(z_mode=ZMode.VELOCITY)) as sim,
            Cameras(sim, (FRONT,), depth=True, segmentation=True) as cams,
        ):
            _climb(sim, 360)
            images.append(cams.latest("front"))
            x_m = sim.state.position_m[0]
    a, b = images
    assert a.step == b.step == 360
    assert np.array_equal(a.rgb, b.rgb) and np.array_equal(a.depth_m, b.depth_m)
    tower = cams.segment_names.index("red_tower")
    on_tower = a.segmentation == tower
    assert on_tower.sum() > 50
    red = a.rgb[on_tower].astype(int)
    assert (red[:, 0] > 2 * red[:, 1]).mean() > 0.95  # the pixels labelled tower are red
    # the tower's face is 5.6 m ahead of the start; the camera sits a little ahead of the centre
    face_m = 5.6 - x_m
    assert float(np.median(a.depth_m[on_tower])) == pytest.approx(face_m, abs=0.15)
    assert np.isinf(a.depth_m[a.segmentation == -1]).all()  # sky: nothing drawn


def test_pipelined_frames_match_the_synchronous_ones_and_are_recorded(tmp_path):
    with Simulator(SimConfig(z_mode=ZMode.VELOCITY)) as sim, Cameras(sim, (FRONT,)) as sync_cams:
        _climb(sim, 240)
        reference = sync_cams.latest("front")
    out = tmp_path / "pipelined.mcap"
    with (
        Simulator(SimConfig(z_mode=ZMode.VELOCITY)) as sim,
        Cameras(sim, (FRONT,), mode=CameraMode.PIPELINED, render_workers=1) as cams,
        record(sim, out, cams),
    ):
        sim.send(Twist(linear_z=1.0))
        for _ in range(30):  # a frame at a time, each rendered before the simulator goes on: however
            sim.step(8)  # busy the machine, no capture finds the worker busy and no frame comes late
            cams.wait()
            got = cams.latest("front")
            assert got is not None and got.step == sim.step_count
        assert cams.frames_dropped == 0
        assert np.array_equal(got.rgb, reference.rgb)  # the image a synchronous camera gives
    frames = load_flight(out).frames["front"]
    assert [round(ns * 240 / 1e9) for ns, _ in frames] == list(range(0, 241, 8))  # every one recorded
    through_jpeg = np.abs(decode_jpeg(frames[-1][1]).astype(int) - reference.rgb).mean()
    a_second_before = np.abs(decode_jpeg(frames[0][1]).astype(int) - reference.rgb).mean()
    assert through_jpeg < 6 and 2 * through_jpeg < a_second_before, (through_jpeg, a_second_before)


def test_a_recording_with_sync_cameras_holds_the_images_code_saw(tmp_path):
    out = tmp_path / "sync.mcap"
    with Simulator(SimConfig(z_mode=ZMode.VELOCITY)) as sim, Cameras(sim, (FRONT,)) as cams:
        with record(sim, out, cams):
            _climb(sim, 80)
            seen = cams.latest("front")
        sim.step(16)  # after the recording closed, the cameras go on
        assert cams.latest("front").step == 96
    frames = load_flight(out).frames["front"]
    assert [round(ns * 240 / 1e9) for ns, _ in frames] == list(range(8, 81, 8))
    decoded = decode_jpeg(frames[-1][1]).astype(int)
    assert np.abs(decoded - seen.rgb.astype(int)).mean() < 4  # the same image, through JPEG
