"""The cameras show the world, their CameraInfo matches the projection used, and they are
deterministic whether rendered in-process or by worker processes; in a fleet, a vehicle's cameras
see the other vehicles, and only the vehicles given cameras record them.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_cameras.py."""

import json
from pathlib import Path

import pytest

from quadsim import Twist
from quadsim.recording.flight import load_flight
from quadsim.sensors.rendering import decode_jpeg
from tests.helpers import ROOT
from tests.helpers.fleets import fleet_toml, vehicle
from tests.helpers.mcap import decoded_recording
from tests.integration.test_cameras import _hovering_with_cameras, _red_mask
from tests.integration.test_cli import cli


def test_workers_render_the_same_images_as_in_process():
    results = []
    for workers in (0, 2):
        sim, pipe, keep = _hovering_with_cameras(workers=workers)
        sim.send(Twist(linear_x=1.0, angular_z=0.4))
        sim.run_for(1.0)
        pipe.drain()
        results.append([(f.camera, f.step, f.jpeg) for f in keep.frames])
        pipe.close(), sim.close()
    assert len(results[0]) == 2 * 30 * 1.2  # two cameras at 30 Hz: the hover's last 0.2 s, then 1 s
    assert results[0] == results[1]


def _egl_renders_here() -> str | None:
    """None if PyBullet's EGL plugin renders on this machine, else why not."""
    import subprocess
    import sys

    probe = (
        "from quadsim.physics.pybullet_quiet import pb\n"
        "from quadsim.sensors.rendering import enable_egl\n"
        "cid = pb.connect(pb.DIRECT)\n"
        "enable_egl(cid)\n"
    )
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    if result.returncode != 0:
        return (result.stderr.strip().splitlines() or [f"exit {result.returncode}"])[-1]
    return None


def test_egl_renders_the_scene_where_a_driver_exists(tmp_path):
    """With an EGL driver (a GPU's, or Mesa's llvmpipe on the CPU), --renderer egl renders the
    same scene, in workers and in-process, and nothing of the plugin's chatter reaches stdout."""
    import subprocess
    import sys

    why = _egl_renders_here()
    if why is not None:
        pytest.skip(f"no EGL rendering on this machine: {why}")
    root = ROOT
    for workers in ("2", "0"):
        out = tmp_path / f"egl{workers}.mcap"
        result = subprocess.run(
            [
                sys.executable,
                str(root / "main.py"),
                "run",
                "--script",
                "hover",
                "--duration",
                "1",
                "--renderer",
                "egl",
                "--render-workers",
                workers,
                "--out",
                str(out),
            ],
            capture_output=True,
            text=True,
            cwd=root,
        )
        assert result.returncode == 0, result.stderr
        assert "GL_VENDOR" not in result.stdout and "ven =" not in result.stdout and "EGL" not in result.stdout
        from quadsim.recording.flight import load_flight

        front = decode_jpeg(load_flight(out).frames["front"][-1][1])
        assert _red_mask(front).sum() > 500  # the red tower ahead, drawn by EGL


ALPHA = vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="script:takeoff", cameras=["front", "floor"])
BRAVO = vehicle("bravo", (2.5, 0.0, 0.0, 180.0), input="script:climb")


def _front_frames(folder: Path, with_bravo: bool) -> tuple[Path, list]:
    import cv2
    import numpy as np

    (folder / "pair.toml").write_text(fleet_toml(ALPHA, BRAVO) if with_bravo else fleet_toml(ALPHA))
    out = cli("run", "--fleet", str(folder / "pair.toml"), "--camera-size", "160x120", "--out", str(folder / "p.mcap"))
    assert out.returncode == 0, out.stderr
    assert "control 240 Hz, cameras alpha (front, floor)" in out.stdout.splitlines()[0]  # whose it records
    flight = load_flight(folder / "p.mcap", "alpha")
    frames = [cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_GRAYSCALE) for _, jpeg in flight.frames["front"]]
    return folder / "p.mcap", frames


def test_a_vehicles_cameras_see_the_other_vehicles_and_only_it_records_them(tmp_path):
    """alpha records its cameras and bravo none; alpha's front camera sees bravo, 2.5 m ahead:
    the same flight without bravo differs only where bravo stands in the picture."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    path, with_bravo = _front_frames(tmp_path / "a", True)
    _, alone = _front_frames(tmp_path / "b", False)
    topics, metadata, _ = decoded_recording(path)
    cameras = {t for t in topics if "camera" in t}
    assert cameras == {
        "/alpha/quad/front_camera/image_raw/compressed",
        "/alpha/quad/front_camera/camera_info",
        "/alpha/quad/floor_camera/image_raw/compressed",
        "/alpha/quad/floor_camera/camera_info",
    }
    assert topics["/alpha/quad/front_camera/camera_info"][0][1].header.frame_id == "alpha/front_camera_optical"
    assert len(alone) == 180 and len(with_bravo) > 180  # 30 Hz, for 6 s (takeoff) or climb's 10.5 s
    params = json.loads(metadata["quadsim"]["parameters"])
    assert [len(v["cameras"]) for v in params["fleet"]] == [2, 0]
    # 3 s in: bravo has climbed 3 m / 2.5 m ahead, alpha hovers at 2 m (its front camera on the horizon)
    diff = abs(with_bravo[90].astype(int) - alone[90].astype(int)) > 40
    rows, cols = diff.nonzero()
    assert 15 < diff.sum() < 2000, diff.sum()
    assert abs(cols.mean() - 80) < 15 and rows.mean() < 60  # ahead of it, and above the horizon
    assert not (abs(with_bravo[0].astype(int) - alone[0].astype(int)) > 40)[:, :10].any()  # the rest: the same
