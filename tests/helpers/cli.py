"""`main.py` as a command runs it: in its own process, from the clone. Not a test module."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

from tests.helpers import ROOT

MAIN = ROOT / "main.py"


def run_main(
    *args: object, cwd: Path | None = None, env: Mapping[str, str] | None = None, timeout: float | None = None
) -> subprocess.CompletedProcess[str]:
    """`python main.py ARGS...` to its end, its output captured as text; `env` replaces the
    environment (None: this process's), `cwd` None: this process's."""
    return subprocess.run(
        [sys.executable, str(MAIN), *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=None if env is None else dict(env),
        timeout=timeout,
    )


def bare_env(**extra: str) -> dict[str, str]:
    """An environment with nothing of this one's in it but the system's PATH and the clone on
    PYTHONPATH (what a user's shell in a clone would at least have), plus `extra`."""
    return {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), **extra}
