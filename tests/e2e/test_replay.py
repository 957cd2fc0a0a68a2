"""Replay: playback (window and headless), re-simulation, and recordings as regression tests.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_replay.py."""

import re
import signal
import subprocess
import sys
from pathlib import Path

import cv2
import pytest

from tests.helpers import RECORDINGS as RECORDINGS_DIR
from tests.helpers import ROOT
from tests.helpers.cli import MAIN, bare_env, file_size_limit, wait_for_line, without_caches
from tests.helpers.fleets import under
from tests.helpers.recording import copy_recording, record_flight
from tests.integration.test_replay import (
    RECORDINGS,
    _frame_count,
    cli,
    with_cameras,  # noqa: F401 (a fixture)
)


def _with_changed_attachment(src: Path, dst: Path, name: str, edit) -> None:
    """Copy a recording, editing one attachment (as if the vehicle file had changed)."""
    copy_recording(src, dst, attachment=lambda n, data: edit(data) if n == name else data)


def test_check_passes_the_shipped_recordings_at_zero():
    """Every shipped recording re-flies to the bit (position and attitude), not just within the
    default millimetre: a change to the flight that moves a last bit shows here."""
    out = cli("check", "--tolerance-m", "0", "--tolerance-rad", "0", *RECORDINGS)  # by name: not a user's flights
    assert out.returncode == 0, out.stdout + out.stderr
    assert f"{len(RECORDINGS)} of {len(RECORDINGS)} recordings re-fly within 0 m and 0 rad" in out.stdout
    identical = [
        line
        for line in out.stdout.splitlines()
        if line.endswith("flies again identically (position and attitude as recorded, to the bit)")
    ]
    assert len(identical) == len(RECORDINGS), out.stdout


#: a shipped recording of each shape, the vehicles in it that fly the quadrotor (they stray when
#: its rotor drag changes), and the others (they fly as recorded)
CHANGED = {
    "alone": ("square_cascade.mcap", [""], []),
    "fleet of 3": ("fleet_trio_wind.mcap", ["alpha", "bravo"], ["charlie"]),  # charlie: the hexacopter
}


def _said_of(report: str, name: str) -> str:
    """The lines of check's report about vehicle `name` (a fleet's are under "  NAME:"; alone, all of them)."""
    if not name:
        return report
    lines = report.splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip() == f"{name}:") + 1
    end = next((i for i in range(start, len(lines)) if lines[i].strip().endswith(":")), len(lines))
    return "\n".join(lines[start:end])


@pytest.mark.parametrize("shape", list(CHANGED))
def test_check_fails_a_changed_airframe_with_a_readable_report(shape, tmp_path):
    """The quadrotor's rotor drag changed since the recording: check fails it, and the report
    says which vehicle strayed, on which topic, when and how far, and which did not."""
    recording, strayed, as_recorded = CHANGED[shape]
    changed = tmp_path / "heavier_drag.mcap"
    _with_changed_attachment(
        RECORDINGS_DIR / recording,
        changed,
        "quadsim_x.params.toml",
        lambda d: d.replace(b"rotor_drag_ns_per_m_rad = 1.7e-4", b"rotor_drag_ns_per_m_rad = 4.0e-4"),
    )
    out = cli("check", changed)
    assert out.returncode == 1, out.stdout + out.stderr
    names = strayed + as_recorded
    fleet = f" (a fleet of {len(names)})" if names != [""] else ""
    assert f"FAIL  {changed}{fleet}: position off by up to" in out.stdout, out.stdout
    for name in strayed:
        said, pose = _said_of(out.stdout, name), under(name, "quad/pose")
        assert f"{pose} position: max" in said and f"{pose} position: max 0 m" not in said, said
        assert "first beyond tolerance at t=" in said  # which topic, when, how far
    for name in as_recorded:
        assert f"{under(name, 'quad/pose')} position: max 0 m" in _said_of(out.stdout, name)  # flies as recorded


def test_ctrl_c_while_encoding_ends_soon_with_whole_videos(tmp_path):
    """A real SIGINT to `replay --mp4` on a longer recording: it does not wait for the encoding
    to end, exits 130 without a traceback, and leaves videos every player opens."""
    recording = tmp_path / "long.mcap"
    record_flight(recording, size=(320, 240), script="12.0 linear.x=0.5 angular.z=0.3\n")
    proc = subprocess.Popen(
        [sys.executable, str(ROOT / "main.py"), "replay", "--headless", "--mp4", str(tmp_path / "v"), str(recording)],
        cwd=ROOT,
        env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), "SDL_VIDEODRIVER": "dummy"},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        # mid-encoding: once the encoding says it has done a quarter of the frames
        outs, errs, readers = wait_for_line(proc, "encoding video:", 1)
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=60)
        for reader in readers:
            reader.join(timeout=30)
        out, err = "".join(outs), "".join(errs)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "each video is whole and ends where the encoding stopped" in err, err
    said = re.findall(r"video +(\S+) \(VP9, the first (\d+) of (\d+) frames: stopped\)", out)
    assert len(said) == 2, out
    for path, frames, of in said:
        assert 0 < int(frames) < int(of) == 360 and _frame_count(Path(path)) == int(frames)


def test_mp4_given_a_file_name_writes_each_camera_beside_it(with_cameras, tmp_path):
    """`--mp4 flight.mp4` (a name, not a folder): flight_floor.mp4 and flight_front.mp4 beside
    it, not a folder called flight.mp4."""
    (tmp_path / "out").mkdir()
    out = cli("replay", with_cameras, "--headless", "--mp4", tmp_path / "out" / "flight.mp4")
    assert out.returncode == 0, out.stdout + out.stderr
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["flight_floor.mp4", "flight_front.mp4"]
    cap = cv2.VideoCapture(str(tmp_path / "out" / "flight_front.mp4"))
    ok, frame = cap.read()
    assert ok and frame.mean() > 20  # a picture, not black
    # a second export to the same name is refused before anything is encoded: nothing is overwritten
    size = (tmp_path / "out" / "flight_front.mp4").stat().st_size
    again = cli("replay", with_cameras, "--headless", "--mp4", tmp_path / "out" / "flight.mp4")
    assert again.returncode == 2 and "flight_floor.mp4 already exists" in again.stderr, again.stderr
    assert "duration" not in again.stdout  # refused before the summary
    assert (tmp_path / "out" / "flight_front.mp4").stat().st_size == size


def test_a_video_the_disk_refuses_is_an_error_and_no_cut_file_is_left(with_cameras, tmp_path):
    """On a full disk, OpenCV wrote cut MP4s that do not play, said nothing, and the export ended
    with exit 0. A file size limit below each video's size refuses writes as a full disk does."""
    whole = cli("replay", with_cameras, "--headless", "--mp4", tmp_path / "whole")
    assert whole.returncode == 0, whole.stderr
    limit = min(p.stat().st_size for p in (tmp_path / "whole").iterdir()) // 2
    out = subprocess.run(
        [sys.executable, str(MAIN), "replay", str(with_cameras), "--headless", "--mp4", str(tmp_path / "cut")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=bare_env(SDL_VIDEODRIVER="dummy", **without_caches(tmp_path)),
        preexec_fn=file_size_limit(limit),
        timeout=300,
    )
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
    assert re.search(r"cannot write the video \S+cams_f\w+\.mp4: the disk took \d+ bytes of it", out.stderr), out.stderr
    assert list((tmp_path / "cut").iterdir()) == []  # the cut videos were removed: a retry is not refused


def test_replay_refuses_options_it_would_ignore(tmp_path):
    recording = ROOT / "tests" / "recordings" / "climb_cascade.mcap"  # recorded without cameras
    out = cli("replay", recording, "--headless", "--mp4", tmp_path / "videos")
    assert out.returncode == 2 and "recorded no camera images" in out.stderr, out.stderr
    assert not (tmp_path / "videos").exists()  # no empty folder left behind
    for options, said in (
        (["--resim", "--mp4", tmp_path / "v"], "--mp4 exports the recording as it is"),
        (["--resim", "--plot", tmp_path / "p.png"], "--plot exports the recording as it is"),
        (["--out", tmp_path / "new"], "--out is for the new flight of --resim"),
        (["--no-record"], "--no-record is for the new flight of --resim"),
    ):
        out = cli("replay", recording, "--headless", *options)
        assert out.returncode == 2 and said in out.stderr and len(out.stderr.splitlines()) == 1, out.stderr
    fleet = ROOT / "tests" / "recordings" / "fleet_trio_wind.mcap"
    out = cli("replay", fleet, "--headless", "--vehicle", "bravo", "--mp4", tmp_path / "v")
    assert out.returncode == 2 and "vehicle bravo recorded no camera images" in out.stderr, out.stderr
