"""The documentation: the command-line reference is what `--help` prints, every block marked
runnable runs, the pictures show something, and the README stays a front door.

Its integration tests (several layers, in-process or one process started); the others are in tests/unit/test_docs.py."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import ROOT
from tests.unit.test_docs import _runnable_commands

COMMANDS = ["run", "fly", "scenarios", "info", "recover", "replay", "check", "sweep", "evaluate", "bench", "examples"]


def _hooks():
    spec = importlib.util.spec_from_file_location("mkdocs_hooks", ROOT / "tools" / "mkdocs_hooks.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("command", COMMANDS)
def test_the_cli_reference_is_what_help_prints(command, monkeypatch):
    """What `--help` prints in a terminal as wide as the site's code blocks (at 1280 px)."""
    monkeypatch.setenv("COLUMNS", "100")  # the page's width is its own, whatever the terminal's
    hooks = _hooks()
    page = hooks.cli_reference()
    block = page.split(f"## quadsim {command}\n\n```text\n", 1)[1].split("\n```", 1)[0]
    installed = Path(sys.executable).with_name("quadsim")  # the console script: it calls itself quadsim
    shown = subprocess.run(
        [str(installed), command, "--help"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "COLUMNS": str(hooks.COLUMNS)},
    )
    assert shown.returncode == 0, shown.stderr
    assert block == shown.stdout.rstrip()


@pytest.mark.parametrize(("page", "command"), _runnable_commands())
def test_every_runnable_command_in_the_docs_runs(page, command, tmp_path):
    argv = command.split()
    assert argv[:2] == [".venv/bin/python", "main.py"], command
    done = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), *argv[2:]],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
        env={**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy", "QUADSIM_RECORDINGS": str(tmp_path)},
    )
    assert done.returncode == 0, f"{page}: {command}\n{done.stderr}"
