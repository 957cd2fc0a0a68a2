"""The flight core's arithmetic gives the same results to the bit compiled (numba, the `fast`
extra) and as plain Python (without numba, or NUMBA_DISABLE_JIT=1).

Its integration tests (several layers, in-process or one process started); the others are in tests/unit/test_compiled.py."""

import os
import subprocess
import sys

import pytest

from quadsim.core.compiled import NUMBA_VERSION as numba_version
from quadsim.core.invocation import install_extra
from tests.helpers import ROOT, default_core

STATUS = r"""
import sys
mode = sys.argv[1]
if mode == "missing":
    sys.modules["numba"] = None  # as if the fast extra were not installed
from quadsim.core import compiled
from quadsim.sim.config import SimConfig
from quadsim.sim.simulator import Simulator
with Simulator(SimConfig()) as sim:
    sim.run_for(0.5)
print(compiled.COMPILED, compiled.status())
print("numba imported" if "numba" in sys.modules else "numba not imported")
"""


@pytest.mark.parametrize(
    ("mode", "said"),
    [
        ("missing", "flight core as plain Python: {install} (numba) to compile it"),
        (
            "broken",
            "flight core as plain Python: numba is installed but did not import "
            "(ImportError: Numba needs NumPy 2.3 or less)",
        ),
    ],
)
def test_without_a_working_numba_it_flies_as_python_and_says_why(tmp_path, mode, said, monkeypatch):
    """A numba that is installed but fails to import (a NumPy it does not support) was reported as
    not installed, with advice to install it."""
    (tmp_path / "numba").mkdir()
    (tmp_path / "numba" / "__init__.py").write_text('raise ImportError("Numba needs NumPy 2.3 or less")\n')
    env = {**default_core(os.environ), "PYTHONPATH": str(tmp_path) if mode == "broken" else ""}
    done = subprocess.run(
        [sys.executable, "-c", STATUS, mode], capture_output=True, text=True, env=env, cwd=ROOT, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    monkeypatch.chdir(ROOT)  # where it ran: the hint is the clone's install command there
    assert done.stdout.strip().splitlines()[-2] == f"False {said.format(install=install_extra('fast'))}"


@pytest.mark.parametrize(
    ("value", "compiled", "said"),
    [
        ("python", False, "flight core as plain Python: QUADSIM_FLIGHT_CORE=python is set"),
        ("compiled", True, "flight core compiled by numba {version}"),
        (
            "fast",
            True,
            "flight core compiled by numba {version} (QUADSIM_FLIGHT_CORE=fast is neither python nor compiled: ignored)",
        ),
    ],
)
def test_quadsim_flight_core_python_flies_without_importing_numba(value, compiled, said):
    """A short run gains less from the compiled core than importing numba and loading its cached
    code costs (0.7 CPU-s): QUADSIM_FLIGHT_CORE=python skips both, and the status says so."""
    env = {**default_core(os.environ), "QUADSIM_FLIGHT_CORE": value}
    done = subprocess.run(
        [sys.executable, "-c", STATUS, "installed"], capture_output=True, text=True, env=env, cwd=ROOT, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    status, imported = done.stdout.strip().splitlines()[-2:]
    assert status == f"{compiled} {said.format(version=numba_version)}"
    assert imported == ("numba imported" if compiled else "numba not imported")
