"""What the tests share: the clone's paths (here), and, in their own modules, a runner for
`main.py` (cli), /proc readers (proc), the peers the end-to-end tests start (ros2_peer,
foxglove_client, ...) and smaller helpers. Not a test module."""

from collections.abc import Mapping
from pathlib import Path

#: the clone's root: main.py, quadsim/, docs/, examples/
ROOT = Path(__file__).resolve().parents[2]
#: the folder of the project's own regression recordings (a user may add flights there: a test
#: names the ones it uses, tests.helpers.recording.SHIPPED_RECORDINGS, never globs it)
RECORDINGS = ROOT / "tests" / "recordings"
#: this folder: the peers and scripts the tests start by path (foxglove_client.py, ros2_peer.py, ...)
HELPERS = Path(__file__).resolve().parent

#: the variable that chooses the flight core (quadsim.core.compiled.CHOICE_VARIABLE): tests/conftest.py
#: sets it to `python` for every process the tests start, where importing numba and loading its
#: cached code would be half of a short run's cost
FLIGHT_CORE_VARIABLE = "QUADSIM_FLIGHT_CORE"


def default_core(env: Mapping[str, str]) -> dict[str, str]:
    """`env` without the tests' choice of the plain-Python flight core: a process started with it
    flies the core as a user's does by default (compiled, numba being in the test extras)."""
    return {k: v for k, v in env.items() if k != FLIGHT_CORE_VARIABLE}
