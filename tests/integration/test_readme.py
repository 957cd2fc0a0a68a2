"""The README and the docs tell the truth: their example output is what the code prints."""

from __future__ import annotations

import re
import subprocess
import sys

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
