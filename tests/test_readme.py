"""The README and the docs tell the truth: their example output is what the code prints."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import ROOT

README = (ROOT / "README.md").read_text()
COMMAND_LINE_PAGE = (ROOT / "docs" / "command-line.md").read_text()

#: what differs from machine to machine and from run to run
VARIABLE = [
    (re.compile(r"^(wall time\s+)[\d.]+ s$"), r"\1<wall> s"),
    (re.compile(r"^(real-time factor )[\d.]+x$"), r"\1<rtf>x"),
    (re.compile(r"(recording to |recording\s+)\S+\.mcap"), r"\1<file>.mcap"),
]


def _normalise(lines: list[str]) -> list[str]:
    out = []
    for line in lines:
        for pattern, replacement in VARIABLE:
            line = pattern.sub(replacement, line)
        out.append(line.rstrip())
    return out


def _block_after(text: str, marker: str) -> str:
    intro = text.index(marker) + len(marker)
    start = text.index("```\n", intro) + 4
    return text[start : text.index("\n```", start)]


FLEETS_PAGE = (ROOT / "docs" / "fleets.md").read_text()
SQUARE = ("run", "--script", "square", "--cameras", "none")
FLEET = ("run", "--fleet", "examples/fleet.toml")


@pytest.mark.parametrize(
    ("text", "marker", "command"),
    [
        (README, "```sh\n.venv/bin/python main.py run --script square --cameras none\n```", SQUARE),
        (COMMAND_LINE_PAGE, "`.venv/bin/python main.py run --script square\n--cameras none` prints", SQUARE),
        (FLEETS_PAGE, "```sh\n.venv/bin/python main.py run --fleet examples/fleet.toml\n```", FLEET),
    ],
    ids=["README", "docs/command-line.md", "docs/fleets.md"],
)
def test_the_run_example_is_what_run_prints(tmp_path, text, marker, command):
    block = _block_after(text, marker)
    result = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), *command, "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr
    assert _normalise(result.stdout.splitlines()) == _normalise(block.splitlines())


def test_what_the_readme_says_of_the_example_fleet_holds():
    """The README said `fly --fleet` flies one of the example's vehicles from the keyboard: the
    example has none (`run --fleet` refuses one, and the example is what `run --fleet` flies).
    It says which input a vehicle needs and which of the example's to change."""
    from quadsim.core.toml_files import read_toml

    example = read_toml(ROOT / "examples" / "fleet.toml", "fleet file")
    inputs = {vehicle["name"]: vehicle["input"] for vehicle in example["vehicle"]}
    assert not {"keyboard", "gamepad"} & set(inputs.values())  # so the README must say what to set
    said = " ".join(README.split("`fly --fleet", 1)[1].split("\n\n", 1)[0].split())
    assert 'whose input is `"keyboard"` or `"gamepad"`' in said
    assert 'set `delta`\'s input to `"keyboard"`' in said and inputs["delta"] == "idle"


def test_the_readmes_code_runs_twice_in_a_row(tmp_path):
    """The README's "In your code" example, run twice in the same folder as a newcomer would: each
    run records a new file (it recorded to a fixed name, and the second run stopped on it)."""
    code = README.split("## In your code", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    runs = [
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=300)
        for _ in range(2)
    ]
    assert all(run.returncode == 0 for run in runs), runs[-1].stderr
    paths = [Path(run.stdout.splitlines()[-1]) for run in runs]
    assert paths[0] != paths[1] and all(p.is_file() and p.suffix == ".mcap" for p in paths), paths
    assert float(runs[0].stdout.splitlines()[0].strip("()").split(",")[2]) > 1.5  # it climbed
