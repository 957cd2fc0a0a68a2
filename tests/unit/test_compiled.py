"""The flight core's arithmetic gives the same results to the bit compiled (numba, the `fast`
extra) and as plain Python (without numba, or NUMBA_DISABLE_JIT=1)."""

import math
import random

import numpy as np
import pytest

from quadsim.control.cascade import CascadeController
from quadsim.control.cascade_step import cascade_update
from quadsim.core import compiled
from quadsim.core.kinematics import matrix_from_quaternion
from quadsim.core.types import ActiveCommand, Twist, VehicleState, ZMode
from quadsim.vehicle.mixer import Mixer, mix
from quadsim.vehicle.params import SHIPPED_VEHICLES, load_vehicle
from quadsim.vehicle.wrench import airframe_wrench
from tests.helpers import ROOT
from tests.helpers.sim import body_alone


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
