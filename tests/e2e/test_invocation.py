"""Hints name a command that works where the user is.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/unit/test_invocation.py."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tests.integration.test_invocation import _one_line
from tests.unit.test_invocation import clone  # noqa: F401 (a fixture)


def _bare_python(folder: Path) -> Path:
    """A Python with nothing installed: a fresh virtual environment without even pip."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(folder)], check=True)
    return folder / "bin" / "python"


def test_main_py_without_the_dependencies_says_to_set_up_the_clone(clone, tmp_path):
    """No .venv yet (a fresh clone, `python3 main.py run ...`): `make fly` sets it up, then the
    environment's python runs what was asked."""
    python = _bare_python(tmp_path / "bare")
    result = subprocess.run(
        [str(python), "main.py", "run", "--script", "square"], capture_output=True, text=True, cwd=clone
    )
    line = _one_line(result)
    assert line.startswith("quadsim: error: this Python") and "lacks quadsim's dependencies (no pybullet" in line
    assert "'make fly'" in line and line.endswith("then: .venv/bin/python main.py run --script square")


def test_main_py_without_the_dependencies_names_the_clones_environment(clone, tmp_path):
    """A .venv there (set up before, the user typed python3): the command with its python."""
    _bare_python(clone / ".venv")
    python = _bare_python(tmp_path / "bare")
    result = subprocess.run(
        [str(python), "main.py", "fly", "--cameras", "none"], capture_output=True, text=True, cwd=clone
    )
    line = _one_line(result)
    assert line.endswith("use the clone's environment: .venv/bin/python main.py fly --cameras none"), line
    # from another folder, the paths that work from there
    elsewhere = subprocess.run(
        [str(python), str(clone / "main.py"), "info", "x.mcap"], capture_output=True, text=True, cwd=tmp_path
    )
    assert _one_line(elsewhere).endswith(f"environment: clone/.venv/bin/python {clone}/main.py info x.mcap")
