"""A key a world, vehicle-parameter or gains file does not know is refused, never ignored.

Its integration tests (several layers, in-process or one process started); the others are in tests/unit/test_unknown_keys.py."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from quadsim.vehicle.params import DEFAULT_URDF
from tests.helpers import ROOT
from tests.unit.test_unknown_keys import FLEET, LANDMARK, _vehicle_copy

CLI_CASES = [
    ("landmarks", "world", "[[landmarks]]\n" + LANDMARK, "w.toml: unknown table [[landmarks]]"),
    ("fricton", "world", "[floor]\nfricton = 0.1\n", "w.toml: [floor]: unknown key 'fricton' (did you mean"),
    ("colour", "world", "[[landmark]]\n" + LANDMARK + "colour = [1, 0, 0, 1]\n", "unknown key 'colour'"),
    ("fleet_as_world", "world", FLEET.read_text(), "w.toml: unknown table [[vehicle]]"),
    # params and gains: the line put under the shipped file's table
    ("params", "params", "[limits]\nbogus_key = 3\n", "mine.params.toml: [limits]: unknown key 'bogus_key'"),
    ("gains", "gains", "[cascade]\nbogus_key = 3\n", "mine.gains.toml: [cascade]: unknown gains bogus_key"),
]


@pytest.mark.parametrize(("kind", "text", "says"), [c[1:] for c in CLI_CASES], ids=[c[0] for c in CLI_CASES])
def test_the_command_line_says_an_unknown_key_in_one_line_and_exits_2(tmp_path, kind, text, says):
    argv = ["run", "--script", "takeoff", "--no-record", "--cameras", "none"]
    if kind == "world":
        (tmp_path / "w.toml").write_text(text)
        argv += ["--world", "w.toml"]
    else:
        urdf = _vehicle_copy(tmp_path)
        shutil.copy(DEFAULT_URDF.with_suffix(".gains.toml"), urdf.with_suffix(".gains.toml"))
        target = urdf.with_suffix(f".{kind}.toml")
        header = text.splitlines()[0] + "\n"
        target.write_text(target.read_text().replace(header, text, 1))
        argv += ["--urdf", "mine.urdf"]
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}
    done = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), *argv],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    lines = done.stderr.splitlines()
    assert done.returncode == 2, done.stderr
    assert len(lines) == 1, done.stderr
    assert "Traceback" not in done.stderr
    assert says in lines[0], lines[0]
