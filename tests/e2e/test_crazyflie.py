"""The second airframe preset, a Crazyflie 2.x sized quadrotor (27 g): data files only, flying
the scenarios with gains from its own file. And gains as data in general.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/unit/test_crazyflie.py."""

import re
import subprocess
import sys

import pytest

from tests.helpers import ROOT


def test_the_cli_flies_it(tmp_path):
    out = tmp_path / "cf.mcap"
    args = ["run", "--script", "takeoff", "--vehicle", "crazyflie", "--cameras", "none", "--out", str(out)]
    done = subprocess.run([sys.executable, str(ROOT / "main.py"), *args], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    z = float(re.search(r"final pose .* z=([-+0-9.]+) m", done.stdout).group(1))
    assert z == pytest.approx(2.0, abs=0.05)  # took off to 2 m
    info = subprocess.run([sys.executable, str(ROOT / "main.py"), "info", str(out)], capture_output=True, text=True)
    assert "vehicle crazyflie (4 rotors), mass 0.027 kg" in info.stdout
