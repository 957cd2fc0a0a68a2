"""The flight core's arithmetic gives the same results to the bit compiled (numba, the `fast`
extra) and as plain Python (without numba, or NUMBA_DISABLE_JIT=1).

Its e2e tests (real processes, signals, windows or peers); the others are in tests/unit/test_compiled.py."""

import ast
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from quadsim.core import compiled
from tests.helpers import ROOT, default_core

# every scenario flown both ways: turns, climbs, holds after the dead-man, take-off and landing
# near the ground (ground effect), wind with turbulence, the seed controller, six rotors
FLIGHTS = r"""
import json, sys
from quadsim.apps.flight_quality import fly
from quadsim.control import ControllerKind
from quadsim.core import compiled
from quadsim.physics.wind import Turbulence, WindSettings
from quadsim.sim.config import SimConfig
from quadsim.vehicle.params import SHIPPED_VEHICLES
sys.path.insert(0, sys.argv[1])
from tests.e2e.test_determinism import digest
windy = SimConfig(wind=WindSettings(6.0, 135.0, Turbulence.MODERATE), seed=7)
flights = {
    "figure8": fly("figure8"),
    "square, windy": fly("square", config=windy),
    "takeoff": fly("takeoff"),
    "yaw": fly("yaw"),
    "climb": fly("climb"),
    "square, seed": fly("square", ControllerKind.SEED),
    "figure8, hexa": fly("figure8", config=SimConfig(urdf=SHIPPED_VEHICLES["hexa"])),
}
print(json.dumps({"compiled": compiled.COMPILED, **{k: [len(f.states), digest(f.states)] for k, f in flights.items()}}))
"""


def _flown(disable_jit: bool) -> dict:
    env = {k: v for k, v in default_core(os.environ).items() if k != "NUMBA_DISABLE_JIT"}
    if disable_jit:
        env["NUMBA_DISABLE_JIT"] = "1"
    done = subprocess.run(
        [sys.executable, "-c", FLIGHTS, str(ROOT)], capture_output=True, text=True, env=env, cwd=ROOT, timeout=600
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_every_flight_is_the_same_to_the_bit_compiled_and_as_python():
    fast, plain = _flown(disable_jit=False), _flown(disable_jit=True)
    assert fast.pop("compiled") is True, "numba is in the test extras: the compiled path must be the one tried"
    assert plain.pop("compiled") is False
    assert all(n >= 360 for n, _ in fast.values())  # states at 60 Hz: 6 s of flight or more
    assert fast == plain


EDITED = r"""
from quadsim.control.cascade import CascadeController
from quadsim.core.types import ActiveCommand, Twist, VehicleState, ZMode
from quadsim.vehicle.params import load_vehicle
state = VehicleState(0, (0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0), (0.0,) * 3, (0.0,) * 3, (0.0,) * 4, (0.0, 0.0, 9.81))
command = ActiveCommand(Twist(), ZMode.VELOCITY, True, False)
print(repr(CascadeController(load_vehicle()).update(state, command, 1 / 240)))
"""


def test_an_edit_to_a_compiled_function_another_one_calls_is_not_hidden_by_the_cache(tmp_path):
    """numba's cache checks only a function's own file; the cascade's update has the mixer built
    in. An edit to the mixer must reach the next run (quadsim.core.compiled.jit)."""
    package = tmp_path / "quadsim"
    shutil.copytree(ROOT / "quadsim", package, ignore=shutil.ignore_patterns("__pycache__"))

    def forces() -> tuple[float, ...]:
        env = {k: v for k, v in default_core(os.environ).items() if k != "NUMBA_DISABLE_JIT"}
        env["PYTHONPATH"] = str(tmp_path)
        done = subprocess.run(
            [sys.executable, "-c", EDITED], capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300
        )
        assert done.returncode == 0, done.stderr[-2000:]
        return ast.literal_eval(done.stdout.strip())

    before = forces()
    assert forces() == before  # from the cache
    mixer = package / "vehicle" / "mixer.py"
    text = mixer.read_text()
    assert "        out[i] = g\n" in text
    mixer.write_text(text.replace("        out[i] = g\n", "        out[i] = 2.0 * g\n"))
    assert forces() == tuple(2.0 * f for f in before)
    assert len(list((package / "control" / "__pycache__").glob("cascade_step.cascade_update*.nbi"))) == 2


ORDER = r"""
import sys
exec(sys.argv[1])
from quadsim.control.cascade_step import cascade_update
from quadsim.vehicle.mixer import mix
from quadsim.vehicle.wrench import airframe_wrench
from tests.helpers.sim import body_alone
print(cascade_update.py_func.__qualname__, mix.py_func.__qualname__, airframe_wrench.py_func.__qualname__)
"""


def test_the_cache_names_do_not_depend_on_what_was_imported_first():
    """A cache named after what had been imported so far made a user's script that imported the
    mixer first compile everything again (3 s) and keep a second copy of the cache."""
    names = set()
    for first in (
        "",
        "import quadsim.vehicle.mixer",
        "from quadsim.vehicle.aero import drag_body",
        "import quadsim.control.cascade",
    ):
        done = subprocess.run(
            [sys.executable, "-c", ORDER, first],
            capture_output=True,
            text=True,
            cwd=ROOT,
            env=default_core(os.environ),
            timeout=120,
        )
        assert done.returncode == 0, done.stderr[-2000:]
        names.add(done.stdout.strip())
    assert len(names) == 1, names
    assert compiled.flight_core_digest() in names.pop()


@pytest.mark.skipif(not compiled.COMPILED, reason="numba is not installed: nothing is compiled")
def test_a_first_compile_is_said_once_before_its_wait_and_never_before_a_bad_file(tmp_path: Path) -> None:
    """With no cached flight core (a fresh install: an empty NUMBA_CACHE_DIR), a run says on
    stderr that it compiles, before its headline; a run whose vehicle file is bad says only the
    file's error (it never reaches the compile); the next run, compiled code cached, says nothing."""
    env = {**default_core(os.environ), "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    shipped = ROOT / "quadsim" / "assets" / "urdf"
    for name in ("quadsim_x.urdf", "quadsim_x.params.toml", "quadsim_x.gains.toml"):
        shutil.copy(shipped / name, tmp_path / name)
    bad = tmp_path / "quadsim_x.params.toml"
    bad.write_text(bad.read_text().replace("max_thrust_n =", "max_thrust_n = 'x' #", 1))

    def run(*args: str) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, str(ROOT / "main.py"), "run", "--script", "hover", "--duration", "0.5"]
        return subprocess.run([*command, "--no-record", *args], capture_output=True, text=True, env=env, cwd=tmp_path)

    refused = run("--urdf", str(tmp_path / "quadsim_x.urdf"))
    assert refused.returncode == 2 and len(refused.stderr.splitlines()) == 1, refused.stderr
    assert "max_thrust_n must be a number" in refused.stderr
    first = run()
    assert first.returncode == 0, first.stderr
    notes = [line for line in first.stderr.splitlines() if line.startswith("quadsim: compiling the flight core")]
    assert len(notes) == 1, first.stderr
    assert first.stdout.startswith("flying 'hover'"), first.stdout  # the note came before the run opened
    again = run()
    assert again.returncode == 0 and "compiling" not in again.stderr, again.stderr
