"""`check --jobs N` and `check --ray` re-fly recordings in parallel with the same report, in the
same order, and the same exit codes as one after another."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import ROOT
from tests.helpers.cli import run_main
from tests.helpers.recording import SHIPPED_RECORDINGS


def _check(*args: str) -> subprocess.CompletedProcess:
    return run_main("check", *args, timeout=600)


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The regression recordings plus a damaged file, so every kind of line is in the report."""
    out = tmp_path_factory.mktemp("check")
    for f in SHIPPED_RECORDINGS:
        shutil.copy(f, out / f.name)
    (out / "broken.mcap").write_bytes(b"\x89MCAP0\r\nnot really")
    return out


def test_jobs_gives_the_serial_report(folder: Path) -> None:
    serial = _check(str(folder))
    parallel = _check(str(folder), "--jobs", "2")
    assert serial.returncode == parallel.returncode == 2  # the broken file is unusable
    assert parallel.stdout == serial.stdout
    lines = parallel.stdout.splitlines()
    assert [line.split()[1].rstrip(":") for line in lines[:-1] if not line.startswith(" ")] == [
        str(p) for p in sorted(folder.glob("*.mcap"))
    ]
    count = len(SHIPPED_RECORDINGS)
    assert lines[-1] == f"{count} of {count + 1} recordings re-fly within 0.001 m and 0.001 rad; 1 unusable"


def test_a_recording_named_twice_is_checked_once(folder: Path) -> None:
    """A folder and a file in it: the file was reported twice and the summary said '1 not checked
    (stopped)' though nothing had stopped."""
    square = folder / "square_cascade.mcap"
    done = _check(str(square), str(folder / ".." / folder.name / "square_cascade.mcap"), str(square))
    assert done.returncode == 0 and done.stdout.count("square_cascade.mcap") == 1, done.stdout
    assert done.stdout.splitlines()[-1] == "1 of 1 recordings re-fly within 0.001 m and 0.001 rad"
    empty = square.parent / "empty"  # a folder with no recording is named as one (it counted as a recording)
    empty.mkdir()
    done = _check(str(empty), str(square))
    assert done.returncode == 2 and f"ERROR {empty}: no .mcap recordings in this folder" in done.stdout
    assert done.stdout.splitlines()[-1] == (
        "1 of 1 recordings re-fly within 0.001 m and 0.001 rad; 1 folder with no recording"
    )
    empty.rmdir()


def test_ray_gives_the_serial_report(folder: Path) -> None:
    pytest.importorskip("ray", reason="Ray (the ray extra) is not installed")
    good = [str(p) for p in sorted(folder.glob("*_cascade.mcap"))]
    serial = _check(*good)
    on_ray = _check(*good, "--ray", "--jobs", "2")
    assert serial.returncode == on_ray.returncode == 0, on_ray.stderr[-2000:]
    assert on_ray.stdout == serial.stdout


def test_check_stopped_part_way_says_so_and_exits_130(tmp_path):
    """Ctrl-C part-way through: the files not reached are counted, and the exit code is 130 (it
    was 0, with a line saying the signal came once the command had finished)."""
    for i in range(4):
        for src in SHIPPED_RECORDINGS:
            shutil.copy(src, tmp_path / f"{i}_{src.name}")
    proc = subprocess.Popen(
        [sys.executable, str(ROOT / "main.py"), "check", str(tmp_path), "--jobs", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    first = proc.stdout.readline()  # the first recording is reported: the signal comes part-way through
    proc.send_signal(signal.SIGINT)
    rest, err = proc.communicate(timeout=120)
    out = first + rest
    assert first.startswith("ok "), first  # a shipped recording, re-flown
    assert proc.returncode == 130, (out, err)
    assert "not checked (stopped)" in out and "nothing was cut short" not in err and "Traceback" not in err


def test_check_says_when_the_gains_or_parameter_files_changed_since_the_recording(tmp_path: Path) -> None:
    """A recording keeps the gains and parameters it flew with and re-flies with them, so a tuned
    gains file passed check unnoticed (velocity_p_xy_per_s 4.5 -> 0.5 flew the square 4.3 m off).
    check still passes it, and says the files differ and what it does not test."""
    shipped = ROOT / "quadsim" / "assets" / "urdf"
    for f in shipped.glob("quadsim_x.*"):
        shutil.copy(f, tmp_path / f.name)
    recording = tmp_path / "mine.mcap"
    flown = subprocess.run(
        [
            sys.executable,
            str(ROOT / "main.py"),
            "run",
            "--script",
            "hover",
            "--duration",
            "2",
            "--cameras",
            "none",
            "--urdf",
            str(tmp_path / "quadsim_x.urdf"),
            "--out",
            str(recording),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert flown.returncode == 0, flown.stderr
    same = _check(str(recording))
    assert same.returncode == 0 and "note:" not in same.stdout, same.stdout
    gains = tmp_path / "quadsim_x.gains.toml"
    gains.write_text(gains.read_text().replace("velocity_p_xy_per_s = 4.5", "velocity_p_xy_per_s = 0.5"))
    params = tmp_path / "quadsim_x.params.toml"
    params.write_text(params.read_text().replace("rotor_drag_ns_per_m_rad = 1.7e-4", "rotor_drag_ns_per_m_rad = 2e-4"))
    tuned = _check(str(recording))
    assert tuned.returncode == 0, tuned.stdout  # it re-flies what was recorded, as it should
    notes = [line.strip() for line in tuned.stdout.splitlines() if "note:" in line]
    tail = "it re-flies with its own, so this check does not test the file's (a flight recorded again does)"
    assert notes == [
        f"note: this recording's vehicle differs from quadsim_x.params.toml (or its URDF) as it is now, in aero: {tail}",
        "note: this recording's cascade gains differ from quadsim_x.gains.toml as it is now (velocity_p_xy_per_s "
        f"4.5 recorded, 0.5 in the file): {tail}",
    ], tuned.stdout
    gains.write_text(gains.read_text() + "bogus_gain = 1.0\n")  # run refuses it: check says so, and still passes
    broken = _check(str(recording))
    (note,) = [line.strip() for line in broken.stdout.splitlines() if "note:" in line]
    assert broken.returncode == 0 and note.startswith("note: the vehicle's files as they are now cannot be flown (")
    assert "bogus_gain" in note and note.endswith(tail), note
