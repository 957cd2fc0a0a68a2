"""Fleet files: what they may say, and one line naming the file, the vehicle and the key when
they say it wrong.

Its integration tests (several layers, in-process or one process started); the others are in tests/unit/test_fleet_file.py."""

from __future__ import annotations

from tests.integration.test_cli import cli
from tests.unit.test_fleet_file import VEHICLE, _write


def test_the_command_line_says_a_bad_fleet_file_in_one_line(tmp_path):
    path = _write(tmp_path, VEHICLE.format(name="alpha", x=0) + VEHICLE.format(name="alpha", x=3))
    out = cli("run", "--fleet", str(path), "--no-record")
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr.strip().splitlines() == [
        f"quadsim: error: {path}: vehicle 2 ('alpha'): name: another vehicle is named 'alpha'; each name must be unique"
    ]


def test_a_folder_given_as_a_fleet_file_is_said_as_one(tmp_path):
    out = cli("run", "--fleet", str(tmp_path), "--no-record")
    assert out.returncode == 2 and out.stderr.strip().splitlines() == [
        f"quadsim: error: {tmp_path}: a folder, not a fleet file"
    ]
