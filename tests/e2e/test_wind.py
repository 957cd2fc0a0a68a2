"""Wind: a constant wind (meteorological FROM direction), Dryden turbulence of MIL-F-8785C
intensity, one seed per run; what it does to the vehicle, what is recorded, and re-flying it.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/unit/test_wind.py."""

import subprocess
import sys
from pathlib import Path

from mcap.reader import make_reader

from tests.helpers import ROOT


def _flown(tmp_path: Path, seed: int, name: str) -> tuple[Path, dict]:
    out = tmp_path / f"{name}.mcap"
    args = ["run", "--script", "hover", "--duration", "6", "--cameras", "none", "--wind", "5,90"]
    args += ["--turbulence", "moderate", "--seed", str(seed), "--out", str(out)]
    done = subprocess.run([sys.executable, str(ROOT / "main.py"), *args], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    topics: dict = {}
    with out.open("rb") as fh:
        for _schema, channel, message in make_reader(fh).iter_messages(log_time_order=True):
            topics.setdefault(channel.topic, []).append(message.data)
    return out, topics


def test_a_windy_noisy_recording_re_flies_bit_for_bit_and_the_seed_is_recorded(tmp_path):
    path, topics = _flown(tmp_path, 11, "first")
    _, again = _flown(tmp_path, 11, "again")
    _, other = _flown(tmp_path, 12, "other")
    assert len(topics["/wind"]) == len(topics["/quad/pose"]) == 360
    # the same seed: the same gusts and the same IMU noise, byte for byte; another seed: others
    assert topics["/wind"] == again["/wind"] and topics["/quad/imu"] == again["/quad/imu"]
    assert topics["/wind"] != other["/wind"] and topics["/quad/imu"] != other["/quad/imu"]
    info = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "info", str(path)], capture_output=True, text=True, cwd=tmp_path
    )
    assert "wind 5 m/s from 90 deg, moderate turbulence, IMU noise on, seed 11" in info.stdout
    check = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "check", str(path)], capture_output=True, text=True, cwd=tmp_path
    )
    assert check.returncode == 0, check.stdout + check.stderr
    assert "flies again identically" in check.stdout
