"""Hundreds of damaged fleet files (bytes flipped, cut, lines lost or doubled, values swapped for
hostile ones): each is read or refused with one line naming the file, never another exception,
and the command line ends with exit 2 and that line."""

from __future__ import annotations

import random
import re

import pytest

from quadsim.apps.plans import fleet_drivers
from quadsim.errors import QuadsimError
from quadsim.sim.config import SimConfig
from quadsim.sim.fleet import Fleet
from quadsim.sim.fleet_file import FleetFile, load_fleet_file
from tests.helpers import ROOT
from tests.integration.test_cli import cli

EXAMPLE = (ROOT / "examples" / "fleet.toml").read_text()
HOSTILE_VALUES = [
    "nan",
    "inf",
    "-inf",
    "1e400",
    "-0.0",
    "9223372036854775808",
    "true",
    '""',
    '"\\u0000"',
    "[]",
    "[[[[]]]]",
    "{}",
    "{ a = 1 }",
    '"../../../etc/passwd"',
    '"/etc/passwd"',
    '"script:../../../etc/passwd"',
    '"script:"',
    '"script:/dev/zero"',
    '"x" ',
    "[1, 2]",
    "[0, 0, 0, 0, 0]",
    '["0", "0", "0", "0"]',
    "[nan, 0, 0, 0]",
    "[1e9, 0, 0, 0]",
    "1979-05-27T07:32:00Z",
    '"ALPHA"',
    '"a-b"',
    '"quad "',
    '"hexa.urdf"',
]


def _damaged(rng: random.Random) -> str:
    """The example fleet file, damaged one of several ways."""
    text = EXAMPLE
    way = rng.randrange(6)
    if way == 0:  # bytes flipped
        data = bytearray(text.encode())
        for _ in range(rng.randint(1, 8)):
            data[rng.randrange(len(data))] = rng.randrange(256)
        return data.decode("utf-8", "replace")
    if way == 1:  # cut short
        return text[: rng.randrange(len(text))]
    lines = text.splitlines()
    if way == 2:  # lines lost
        for _ in range(rng.randint(1, 4)):
            del lines[rng.randrange(len(lines))]
    elif way == 3:  # lines doubled or moved
        for _ in range(rng.randint(1, 3)):
            lines.insert(rng.randrange(len(lines)), lines[rng.randrange(len(lines))])
    else:  # a value swapped for a hostile one, or a key renamed
        for _ in range(rng.randint(1, 3)):
            at = rng.choice([i for i, line in enumerate(lines) if re.match(r"^\w+ = ", line)])
            key, _, _ = lines[at].partition(" = ")
            if way == 4:
                lines[at] = f"{key} = {rng.choice(HOSTILE_VALUES)}"
            else:
                lines[at] = lines[at].replace(key, rng.choice(["nmae", "Name", "start_pose", "inputs", "x"]), 1)
    return "\n".join(lines) + "\n"


CASES = 400


def _fly_briefly(fleet_file: FleetFile) -> None:
    """A fleet file that was read builds its fleet (whose own checks may still refuse it, in one
    line) and flies a tenth of a second."""
    try:
        fleet = Fleet(fleet_file.fleet_vehicles(fleet_drivers(fleet_file)), SimConfig())
    except QuadsimError as exc:
        assert "\n" not in str(exc), str(exc)
        return
    with fleet:
        fleet.run_for(0.1)
        assert fleet.step_count == 24


def test_hundreds_of_damaged_fleet_files_are_read_or_refused_in_one_line(tmp_path):
    rng = random.Random(2026)
    refused = read = 0
    for i in range(CASES):
        path = tmp_path / f"damaged_{i}.toml"
        path.write_text(_damaged(rng), errors="surrogateescape")
        try:
            fleet = load_fleet_file(path)
        except QuadsimError as exc:
            message = str(exc)
            assert "\n" not in message and str(path) in message and len(message) < 400, (i, message)
            refused += 1
        else:  # what it read is a fleet it can fly: names unique, and it flies
            names = [v.name for v in fleet.vehicles]
            assert len(set(names)) == len(names) and all(re.fullmatch(r"[a-z][a-z0-9_]*", n) for n in names), i
            _fly_briefly(fleet)
            read += 1
    print(f"{refused} refused, {read} read")
    assert refused > CASES // 2 and read > 10, (refused, read)  # both ways were tried


@pytest.mark.parametrize("seed", [3, 17, 41])
def test_a_damaged_fleet_file_on_the_command_line_is_one_line_and_exit_2(tmp_path, seed):
    rng = random.Random(seed)
    while True:  # the first damaged file of this seed that is refused
        text = _damaged(rng)
        path = tmp_path / "fleet.toml"
        path.write_text(text)
        try:
            load_fleet_file(path)
        except QuadsimError:
            break
    out = cli("run", "--fleet", str(path), "--duration", "0.5", "--no-record")
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and str(path) in out.stderr, out.stderr
