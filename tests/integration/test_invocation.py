"""Hints name a command that works where the user is.

Its integration tests (several layers, in-process or one process started); the others are in tests/unit/test_invocation.py."""

from __future__ import annotations

import re
import subprocess
import sys

from tests.helpers import ROOT
from tests.unit.test_invocation import clone  # noqa: F401 (a fixture)


def _one_line(result: subprocess.CompletedProcess) -> str:
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert result.stdout == ""
    return lines[0]


def test_main_py_in_an_isolated_python_says_it_too(clone):
    """`python3 -S -I main.py`: no site-packages, and no script folder on sys.path (-I)."""
    result = subprocess.run(
        [sys.executable, "-S", "-I", "main.py", "check", "recordings/"], capture_output=True, text=True, cwd=clone
    )
    line = _one_line(result)
    assert "lacks quadsim's dependencies" in line and line.endswith(".venv/bin/python main.py check recordings/")


def test_the_recover_hint_names_the_command_that_started_it(tmp_path):
    """`info` of a cut-short file, from a clone: run recover as main.py, not as `quadsim`."""
    data = (ROOT / "tests" / "recordings" / "square_cascade.mcap").read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    result = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "info", str(cut)], capture_output=True, text=True, cwd=ROOT
    )
    line = _one_line(result)
    assert re.search(rf"Run '\S*python\S* {re.escape(str(ROOT / 'main.py'))} recover {re.escape(str(cut))}'", line), (
        line
    )
    assert "'quadsim recover" not in line
