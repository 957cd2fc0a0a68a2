"""`fly --fleet`: the teleop window flies one vehicle of a fleet among the others (SDL dummy
video, synthetic key events; tests/e2e/test_window_x11.py has the real window).

Its integration tests (several layers, in-process or one process started); the others are in tests/e2e/test_fleet_window.py."""

from __future__ import annotations

from tests.e2e.test_fleet_window import FLEET
from tests.integration.test_cli import cli


def test_fly_fleet_without_a_display_says_what_to_do(tmp_path):
    (tmp_path / "f.toml").write_text(FLEET)
    out = cli("fly", "--fleet", str(tmp_path / "f.toml"))
    assert out.returncode == 2 and "fly --fleet needs a display" in out.stderr and "run --fleet" in out.stderr
