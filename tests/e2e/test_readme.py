"""The README and the docs tell the truth: their example output is what the code prints.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_readme.py."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tests.integration.test_readme import README


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
