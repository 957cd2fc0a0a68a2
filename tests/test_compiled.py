"""The flight core's arithmetic gives the same results to the bit compiled (numba, the `fast`
extra) and as plain Python (without numba, or NUMBA_DISABLE_JIT=1)."""

import ast
import json
import math
import os
import random
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from quadsim.control.cascade import CascadeController
from quadsim.control.cascade_step import cascade_update
from quadsim.core import compiled
from quadsim.core.invocation import install_extra
from quadsim.core.kinematics import matrix_from_quaternion
from quadsim.core.types import ActiveCommand, Twist, VehicleState, ZMode
from quadsim.vehicle.mixer import Mixer, mix
from quadsim.vehicle.params import SHIPPED_VEHICLES, load_vehicle
from quadsim.vehicle.wrench import airframe_wrench
from tests.helpers import ROOT
from tests.helpers.sim import body_alone

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
from tests.test_determinism import digest
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
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DISABLE_JIT"}
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


def _random_state(rng: random.Random, rotors: int) -> VehicleState:
    q = [rng.gauss(0.0, 1.0) for _ in range(4)]
    norm = math.sqrt(sum(c * c for c in q))
    return VehicleState(
        0,
        (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(0.0, 4.0)),
        tuple(c / norm for c in q),
        tuple(rng.uniform(-6, 6) for _ in range(3)),
        tuple(rng.uniform(-8, 8) for _ in range(3)),
        (0.0,) * rotors,
        (0.0, 0.0, 9.81),
    )


def _random_command(rng: random.Random) -> ActiveCommand:
    def pick(spread: float) -> float:
        return rng.choice([0.0, rng.uniform(-spread, spread)])

    twist = Twist(pick(4.0), pick(4.0), pick(3.0), 0.0, 0.0, pick(2.0))
    return ActiveCommand(twist, rng.choice([ZMode.VELOCITY, ZMode.HEIGHT]), True, rng.random() < 0.2)


@pytest.mark.parametrize("airframe", ["quad", "hexa"])
def test_the_controller_update_is_the_same_to_the_bit_compiled_and_as_python(airframe):
    """Random states and commands, saturating ones included, through the controller compiled and
    through the same function run as Python, the holds and integrators carried along."""
    assert compiled.COMPILED
    vehicle = load_vehicle(SHIPPED_VEHICLES[airframe])
    controller = CascadeController(vehicle)
    rng = random.Random(1)
    controller.update(_random_state(rng, vehicle.rotor_count), _random_command(rng), 1 / 240)  # armed
    s_fast = controller._s
    s_plain = s_fast.copy()
    saturated = 0
    for _ in range(3000):
        state, command = _random_state(rng, vehicle.rotor_count), _random_command(rng)
        fast = controller.update(state, command, 1 / 240)
        tw = command.twist
        wanted = (0.0,) * 4 if command.hold else (tw.linear_x, tw.linear_y, tw.linear_z, tw.angular_z)
        out = np.zeros(vehicle.rotor_count)
        cascade_update.py_func(
            controller._k,
            controller._rows,
            s_plain,
            state.position_m,
            matrix_from_quaternion(state.orientation_xyzw),
            state.linear_velocity_mps,
            state.angular_velocity_body_rps,
            wanted,
            command.z_mode is ZMode.HEIGHT,
            command.hold,
            1 / 240,
            out,
        )
        assert fast == tuple(out.tolist())
        assert s_fast.tobytes() == s_plain.tobytes()  # NaN holds compare as bytes
        saturated += any(f in (0.0, vehicle.max_thrust_n) for f in fast)
    assert saturated > 100  # the mixer's yaw-giving-up branch was taken


def test_the_mixer_and_the_airframe_forces_are_the_same_to_the_bit_compiled_and_as_python():
    vehicle = load_vehicle()
    mixer = Mixer(vehicle)
    rng = np.random.default_rng(3)
    for _ in range(2000):
        wrench = rng.normal(0.0, [10.0, 0.5, 0.5, 0.3])
        a, b = np.zeros(4), np.zeros(4)
        mix(mixer.rows, vehicle.max_thrust_n, *wrench.tolist(), a)
        mix.py_func(mixer.rows, vehicle.max_thrust_n, *wrench.tolist(), b)
        assert a.tobytes() == b.tobytes()
    with body_alone(vehicle) as physics:
        constants, hubs = physics._airframe, physics._hub_table
    for _ in range(2000):
        thrusts = rng.uniform(0.0, vehicle.max_thrust_n, 4)
        thrusts_plain = thrusts.copy()
        command = tuple(rng.uniform(-1.0, vehicle.max_thrust_n + 1.0, 4).tolist())
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        rotation = matrix_from_quaternion(tuple(q.tolist()))
        pz, air = float(rng.uniform(-0.1, 1.0)), tuple(rng.uniform(-10, 10, 3).tolist())
        spin = tuple(rng.normal(0.0, 10.0, 3).tolist())
        a, b = np.zeros(6), np.zeros(6)
        airframe_wrench(constants, hubs, thrusts, command, rotation, pz, air, spin, a)
        airframe_wrench.py_func(constants, hubs, thrusts_plain, command, rotation, pz, air, spin, b)
        assert a.tobytes() == b.tobytes() and thrusts.tobytes() == thrusts_plain.tobytes()


@pytest.mark.filterwarnings("error::numba.NumbaPendingDeprecationWarning")
def test_a_state_built_by_hand_with_lists_and_integers_is_still_taken():
    """The compiled update is made for tuples of floats (what the loop builds); a state with lists
    and integers is made tuples of floats first (numba's reflected lists are deprecated), and gives the
    same forces, with no warning (numba's deprecation warnings are errors here)."""
    vehicle = load_vehicle()
    by_hand = VehicleState(0, [0, 0, 2], [0, 0, 0, 1], [0, 0, 0], [0, 0, 0], [0.0] * 4, [0, 0, 9.81])
    as_loop = VehicleState(
        0, (0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0), (0.0,) * 3, (0.0,) * 3, (0.0,) * 4, (0.0, 0.0, 9.81)
    )
    command = ActiveCommand(Twist(linear_x=1.0), ZMode.VELOCITY, True, False)
    a, b = CascadeController(vehicle), CascadeController(vehicle)
    assert a.update(by_hand, command, 1 / 240) == b.update(as_loop, command, 1 / 240)
    assert a.update(by_hand, command, 1 / 240)[0] > 0.0
    given_lists = [
        types for types in cascade_update.overloads if any(isinstance(t, compiled.numba.types.List) for t in types)
    ]
    assert not given_lists  # the compiled code never saw the lists (numba's reflected lists)


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
        env = {k: v for k, v in os.environ.items() if k != "NUMBA_DISABLE_JIT"}
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


def test_with_nowhere_to_write_its_cache_the_flight_core_is_still_compiled(monkeypatch):
    """numba refuses `cache=True` when neither the package's folder nor the user's cache folder
    can be written (a read-only install run by a user without a home); quadsim then compiles
    each run instead of failing to import."""

    real = compiled.numba.njit

    def no_cache(*args, **kwargs):
        if kwargs.get("cache"):
            raise RuntimeError("cannot cache function 'f': no locator available for file 'f.py'")
        return real(*args, **kwargs)

    monkeypatch.setattr(compiled.numba, "njit", no_cache)

    def twice(x: float) -> float:
        return 2.0 * x

    made = compiled.jit(twice)
    assert made(1.5) == 3.0
    assert made.overloads  # compiled, not the Python function


@pytest.mark.filterwarnings("error::numba.NumbaPendingDeprecationWarning")
def test_rotor_forces_given_as_a_list_of_integers_fly_as_a_tuple_of_floats():
    vehicle = load_vehicle()
    poses = []
    for forces in ([3, 3, 3, 3], (3.0, 3.0, 3.0, 3.0)):
        with body_alone(vehicle) as physics:
            physics.place((0.0, 0.0, 2.0))
            for _ in range(24):
                physics._step(forces)
            poses.append(physics.pose)
    assert poses[0] == poses[1] and poses[0][0][2] != 2.0
    with (
        body_alone(vehicle) as physics,
        pytest.raises(ValueError, match="expected 4 rotor forces"),
    ):
        physics._step([3.0, 3.0])


def test_every_module_with_compiled_functions_is_in_the_cache_digest():
    package = ROOT / "quadsim"
    with_jit = sorted(
        str(path.relative_to(package))
        for path in package.rglob("*.py")
        if "@jit\n" in path.read_text(encoding="utf-8") and path.name != "compiled.py"
    )
    assert with_jit == sorted(compiled.FLIGHT_CORE)


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
            [sys.executable, "-c", ORDER, first], capture_output=True, text=True, cwd=ROOT, timeout=120
        )
        assert done.returncode == 0, done.stderr[-2000:]
        names.add(done.stdout.strip())
    assert len(names) == 1, names
    assert compiled.flight_core_digest() in names.pop()


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
    env = {**os.environ, "PYTHONPATH": str(tmp_path) if mode == "broken" else ""}
    done = subprocess.run(
        [sys.executable, "-c", STATUS, mode], capture_output=True, text=True, env=env, cwd=ROOT, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    monkeypatch.chdir(ROOT)  # where it ran: the hint is the clone's install command there
    assert done.stdout.strip().splitlines()[-1] == f"False {said.format(install=install_extra('fast'))}"


@pytest.mark.skipif(not compiled.COMPILED, reason="numba is not installed: nothing is compiled")
def test_a_first_compile_is_said_once_before_its_wait_and_never_before_a_bad_file(tmp_path: Path) -> None:
    """With no cached flight core (a fresh install: an empty NUMBA_CACHE_DIR), a run says on
    stderr that it compiles, before its headline; a run whose vehicle file is bad says only the
    file's error (it never reaches the compile); the next run, compiled code cached, says nothing."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
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
