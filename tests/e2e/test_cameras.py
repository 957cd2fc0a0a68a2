"""The cameras show the world, their CameraInfo matches the projection used, and they are
deterministic whether rendered in-process or by worker processes.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_cameras.py."""

import pytest

from quadsim import Twist
from quadsim.sensors.rendering import decode_jpeg
from tests.helpers import ROOT
from tests.integration.test_cameras import _hovering_with_cameras, _red_mask


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
