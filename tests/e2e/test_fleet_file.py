"""Fleet files: what they may say, and one line naming the file, the vehicle and the key when
they say it wrong.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/unit/test_fleet_file.py."""

from __future__ import annotations

from tests.integration.test_cli import cli
from tests.unit.test_fleet_file import VEHICLE, _write


def test_run_refuses_what_a_fleet_file_says_per_vehicle_and_a_held_input(tmp_path):
    path = _write(tmp_path, VEHICLE.format(name="alpha", x=0) + 'input = "gamepad"\n')
    out = cli("run", "--fleet", str(path), "--no-record")
    assert out.returncode == 2, out.stderr
    assert "vehicle 'alpha' takes input = 'gamepad'" in out.stderr and "window" in out.stderr
    idle = _write(tmp_path, VEHICLE.format(name="alpha", x=0))
    for extra, word in (
        (("--vehicle", "hexa"), "--vehicle with --fleet"),
        (("--cameras", "front"), "--cameras with --fleet"),
        (("--camera-depth-colormap", "front"), "--camera-depth-colormap with --fleet: each vehicle's images"),
        (("--input", "ros2"), "--input ros2 with --fleet"),
        ((), "no vehicle flies a script: say how long"),
    ):
        out = cli("run", "--fleet", str(idle), "--no-record", *extra)
        assert out.returncode == 2 and word in out.stderr, (extra, out.stderr)
    out = cli("run", "--fleet", str(idle), "--script", "square")
    assert out.returncode == 2 and "not allowed with argument" in out.stderr
    near = _write(tmp_path, VEHICLE.format(name="alpha", x=0) + VEHICLE.format(name="bravo", x=0.3))
    out = cli("run", "--fleet", str(near), "--no-record", "--duration", "1")
    assert out.returncode == 2 and f"{near}: vehicles 'alpha' and 'bravo' start 0.30 m apart" in out.stderr


def test_a_missing_fleet_file_named_like_the_shipped_example_says_how_to_copy_it(tmp_path):
    out = cli("run", "--fleet", str(tmp_path / "fleet.toml"), "--no-record")
    assert out.returncode == 2 and "examples --copy . fleet.toml" in out.stderr, out.stderr
    other = cli("run", "--fleet", str(tmp_path / "mine.toml"), "--no-record")
    assert (
        other.returncode == 2
        and other.stderr.strip() == f"quadsim: error: fleet file not found: {tmp_path / 'mine.toml'}"
    )
