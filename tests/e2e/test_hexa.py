"""A second airframe: the shipped hexacopter flies with the cascade controller and re-flies exactly.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/unit/test_hexa.py."""

import subprocess
import sys

from tests.helpers import ROOT
from tests.unit.test_hexa import HEXA


def test_cli_flies_the_hexa_and_checks_its_recording(tmp_path):
    def cli(*args):
        return subprocess.run(
            [sys.executable, str(ROOT / "main.py"), *map(str, args)], capture_output=True, text=True, cwd=tmp_path
        )

    out = cli(
        "run", "--script", "hover", "--vehicle", "hexa", "--duration", "3", "--cameras", "none", "--out", "h.mcap"
    )
    assert out.returncode == 0, out.stderr
    assert "vehicle quadsim_hexa" in cli("info", "h.mcap").stdout
    checked = cli("check", "h.mcap")
    assert checked.returncode == 0 and "flies again identically" in checked.stdout
    both = cli("run", "--script", "hover", "--vehicle", "hexa", "--urdf", str(HEXA))
    assert both.returncode == 2 and "not allowed with" in both.stderr
