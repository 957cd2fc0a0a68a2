"""The controllers on synthetic states: no simulator, no PyBullet, no window.

Each test builds a VehicleState by hand, asks a controller for rotor forces, and reads them back
through physics: the mixer's wrench (collective thrust, roll, pitch and yaw torque) and the
angular acceleration that wrench gives the body, which says where the thrust is about to tip.
"""

import dataclasses
import math
import random

import numpy as np
import pytest

from quadsim.control import ControllerKind, make_controller
from quadsim.control.cascade import CascadeController
from quadsim.control.seed import SeedController
from quadsim.core.kinematics import matrix_from_quaternion, matrix_from_rpy, quaternion_from_matrix
from quadsim.core.types import ActiveCommand, Twist, VehicleState, ZMode
from quadsim.errors import ConfigError
from quadsim.vehicle.aero import ground_effect_ratio
from quadsim.vehicle.mixer import Mixer

DT_S = 1 / 240  # the default control step
BOTH = [ControllerKind.CASCADE, ControllerKind.SEED]


# --- building states and commands ---------------------------------------------------------


def state_of(
    vehicle,
    position=(0.0, 0.0, 2.0),
    rpy=(0.0, 0.0, 0.0),
    velocity=(0.0, 0.0, 0.0),
    body_rates=(0.0, 0.0, 0.0),
    step=0,
) -> VehicleState:
    """A rigid-body state: position (m), roll/pitch/yaw (rad), world velocity, body rates."""
    return VehicleState(
        step=step,
        position_m=tuple(position),
        orientation_xyzw=quaternion_from_matrix(matrix_from_rpy(*rpy)),
        linear_velocity_mps=tuple(velocity),
        angular_velocity_body_rps=tuple(body_rates),
        rotor_thrusts_n=(0.0,) * len(vehicle.rotors),
        specific_force_body_mps2=(0.0, 0.0, vehicle.gravity_mps2),
    )


def command(twist=Twist(), z_mode=ZMode.VELOCITY, armed=True, hold=False) -> ActiveCommand:
    return ActiveCommand(twist, z_mode, armed, hold)


def settle(controller, state, active, steps=2):
    """Update `steps` times on the same state, returning the last forces. The seed's difference
    terms kick on the first armed step (they start from zero); on a repeated state they vanish."""
    forces = None
    for _ in range(steps):
        forces = controller.update(state, active, DT_S)
    return forces


# --- reading forces back as physics -------------------------------------------------------


def wrench(vehicle, forces):
    """(collective thrust N, roll, pitch, yaw torque N m) the forces produce on the body."""
    assert len(forces) == len(vehicle.rotors)
    return Mixer(vehicle).to_wrench(forces)


def angular_accel_world(vehicle, state, forces):
    """The body's angular acceleration (rad/s^2) in world axes: J^-1 (tau - w x J w), rotated."""
    _, tx, ty, tz = wrench(vehicle, forces)
    inertia = np.array(vehicle.inertia_kgm2)
    w = np.array(state.angular_velocity_body_rps)
    alpha_body = np.linalg.solve(inertia, np.array([tx, ty, tz]) - np.cross(w, inertia @ w))
    return np.array(matrix_from_quaternion(state.orientation_xyzw)) @ alpha_body


def thrust_tip_direction(vehicle, state, forces):
    """Unit horizontal direction (world x, y) the thrust axis is being tipped toward.

    A body with angular acceleration alpha swings its z axis with acceleration alpha x z."""
    body_z = np.array(matrix_from_quaternion(state.orientation_xyzw))[:, 2]
    swing = np.cross(angular_accel_world(vehicle, state, forces), body_z)[:2]
    norm = np.linalg.norm(swing)
    assert norm > 1e-3, "the forces tip the thrust nowhere"
    return swing / norm


def heading_to_world(yaw, x, y):
    """A heading-frame horizontal vector (x forward, y left) in world axes, as a unit vector."""
    v = np.array([math.cos(yaw) * x - math.sin(yaw) * y, math.sin(yaw) * x + math.cos(yaw) * y])
    return v / np.linalg.norm(v)


@pytest.fixture(params=BOTH, ids=lambda k: k.value)
def kind(request):
    return request.param


# --- arming -------------------------------------------------------------------------------


def test_unarmed_rotors_idle(vehicle, kind):
    controller = make_controller(kind, vehicle)
    idle = (0.0,) * len(vehicle.rotors)
    # before the first command: idle, whatever the state and the (ignored) twist say
    assert controller.update(state_of(vehicle, position=(0, 0, 0.05)), command(armed=False), DT_S) == idle
    assert controller.update(state_of(vehicle), command(Twist(0, 0, 2.0), armed=False), DT_S) == idle
    # armed it flies; disarmed again it idles again
    assert wrench(vehicle, controller.update(state_of(vehicle), command(), DT_S))[0] > 0.5 * vehicle.weight_n
    assert controller.update(state_of(vehicle), command(armed=False), DT_S) == idle


# --- hover and attitude -------------------------------------------------------------------


def test_cascade_hover_thrust_is_weight_and_no_torque(vehicle):
    forces = settle(CascadeController(vehicle), state_of(vehicle), command())
    thrust, tx, ty, tz = wrench(vehicle, forces)
    # at 2 m the ground effect is 6.5e-5 of the thrust; the feed-forward takes it off
    hub_z = 2.0 + vehicle.com_m[2] + vehicle.rotors[0].position_m[2]
    r, cap = vehicle.aero.rotor_radius_m, vehicle.aero.ground_effect_max_ratio
    assert thrust == pytest.approx(vehicle.weight_n / ground_effect_ratio(hub_z, r, cap), rel=1e-9)
    assert thrust == pytest.approx(vehicle.weight_n, rel=1e-4)
    # one rotor diameter up, it feeds forward 63/64 of the weight
    low = settle(CascadeController(vehicle), state_of(vehicle, position=(0.0, 0.0, 2 * r - hub_z + 2.0)), command())
    assert wrench(vehicle, low)[0] == pytest.approx(vehicle.weight_n * 63 / 64, rel=1e-6)
    # the rotor centre is not the centre of mass: the forces are unequal so the torque is zero
    assert (tx, ty, tz) == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)
    assert all(0.0 < f < vehicle.max_thrust_n for f in forces)


def test_seed_hover_is_its_hover_command_on_every_rotor(vehicle):
    forces = settle(SeedController(vehicle), state_of(vehicle), command())
    thrust, tx, _, tz = wrench(vehicle, forces)
    # the original's hover command 5.335 maps to the weight shared equally by the rotors
    assert forces == pytest.approx((vehicle.hover_thrust_per_rotor_n,) * len(vehicle.rotors), rel=1e-9)
    assert thrust == pytest.approx(vehicle.weight_n, rel=1e-9)
    assert tx == pytest.approx(0.0, abs=1e-9) and tz == pytest.approx(0.0, abs=1e-9)
    # equal forces about an offset centre of mass leave only that offset's moment (the original
    # model was symmetric; its attitude loop absorbs this in flight)
    offset_x = float(np.mean([r.position_m[0] for r in vehicle.rotors]))
    assert wrench(vehicle, forces)[2] == pytest.approx(-vehicle.weight_n * offset_x, rel=1e-6)


@pytest.mark.parametrize(
    ("rpy", "axis"),
    [((0.2, 0.0, 0.0), 0), ((-0.2, 0.0, 0.0), 0), ((0.0, 0.2, 0.0), 1), ((0.0, -0.2, 0.0), 1)],
    ids=["roll+", "roll-", "pitch+", "pitch-"],
)
def test_a_tilted_body_is_levelled(vehicle, kind, rpy, axis):
    state = state_of(vehicle, rpy=rpy)
    torques = wrench(vehicle, settle(make_controller(kind, vehicle), state, command()))[1:]
    tilt = rpy[axis]
    # the torque about the tilted axis opposes the tilt, and dominates the other level axis
    assert torques[axis] * tilt < 0.0
    assert abs(torques[axis]) > 5 * abs(torques[1 - axis])
    assert abs(torques[axis]) > 0.05  # N m: a real correction, not rounding


# --- horizontal commands in the heading frame ---------------------------------------------


def test_forward_while_yawed_90_pitches_nose_down_toward_world_plus_y(vehicle, kind):
    yaw = math.pi / 2  # nose along world +y
    state = state_of(vehicle, rpy=(0.0, 0.0, yaw))
    forces = settle(make_controller(kind, vehicle), state, command(Twist(linear_x=1.0)))
    thrust, roll, pitch, _ = wrench(vehicle, forces)
    assert pitch > 0.02  # +pitch about body y: nose down
    assert abs(roll) < 0.2 * pitch
    assert thrust == pytest.approx(vehicle.weight_n, rel=0.05)
    # nose down with the nose along world +y: the thrust tips toward +y, not +x
    tip = thrust_tip_direction(vehicle, state, forces)
    assert tip == pytest.approx([0.0, 1.0], abs=0.1)


@pytest.mark.parametrize("yaw_deg", [0, 90, 180, -135])
@pytest.mark.parametrize(("ux", "uy"), [(1.0, 0.0), (0.0, 1.0), (-0.7, -0.7)], ids=["fwd", "left", "back-right"])
def test_horizontal_command_tips_thrust_its_way_in_the_heading_frame(vehicle, kind, yaw_deg, ux, uy):
    yaw = math.radians(yaw_deg)
    state = state_of(vehicle, rpy=(0.0, 0.0, yaw))
    forces = settle(make_controller(kind, vehicle), state, command(Twist(linear_x=ux, linear_y=uy)))
    tip = thrust_tip_direction(vehicle, state, forces)
    wanted = heading_to_world(yaw, ux, uy)
    assert float(tip @ wanted) > 0.98  # within about 11 degrees of the commanded direction


def test_moving_with_zero_command_brakes_against_the_velocity(vehicle, kind):
    velocity = (0.8, -0.6, 0.0)  # world frame, 1 m/s
    state = state_of(vehicle, rpy=(0.0, 0.0, math.radians(70)), velocity=velocity)
    forces = settle(make_controller(kind, vehicle), state, command())
    tip = thrust_tip_direction(vehicle, state, forces)
    assert float(tip @ -np.array(velocity[:2])) > 0.98


# --- vertical -----------------------------------------------------------------------------


@pytest.mark.parametrize(("climb_mps", "above"), [(1.0, True), (-0.5, False)], ids=["climb", "descend"])
def test_climb_rate_command_moves_thrust_off_weight(vehicle, kind, climb_mps, above):
    state = state_of(vehicle)
    # 0.1 s of control steps at the same state: the seed's height reference integrates the rate
    forces = settle(make_controller(kind, vehicle), state, command(Twist(linear_z=climb_mps)), steps=24)
    thrust = wrench(vehicle, forces)[0]
    if above:
        assert thrust > 1.01 * vehicle.weight_n
    else:
        assert thrust < 0.99 * vehicle.weight_n


@pytest.mark.parametrize(("offset_m", "above"), [(-1.0, False), (1.0, True)], ids=["below", "above"])
def test_height_mode_target_relative_to_current_altitude(vehicle, kind, offset_m, above):
    # height z-mode: altitude wanted = 2.0 + linear.z; the vehicle is at 2.0 m
    forces = settle(make_controller(kind, vehicle), state_of(vehicle), command(Twist(linear_z=offset_m), ZMode.HEIGHT))
    thrust = wrench(vehicle, forces)[0]
    if above:
        assert thrust > 1.05 * vehicle.weight_n
    else:
        assert thrust < 0.95 * vehicle.weight_n


def test_height_mode_at_the_wanted_altitude_hovers(vehicle, kind):
    # 3.5 m wanted (2.0 + 1.5), and the vehicle is there at rest
    state = state_of(vehicle, position=(0.0, 0.0, 3.5))
    forces = settle(make_controller(kind, vehicle), state, command(Twist(linear_z=1.5), ZMode.HEIGHT))
    assert wrench(vehicle, forces)[0] == pytest.approx(vehicle.weight_n, rel=1e-3)


# --- yaw ----------------------------------------------------------------------------------


@pytest.mark.parametrize("rate_radps", [1.0, -1.0])
def test_yaw_rate_command_gives_yaw_torque_of_its_sign(vehicle, kind, rate_radps):
    state = state_of(vehicle, rpy=(0.0, 0.0, 0.3))
    forces = settle(make_controller(kind, vehicle), state, command(Twist(angular_z=rate_radps)))
    thrust, roll, pitch, yaw = wrench(vehicle, forces)
    assert yaw * rate_radps > 0.02  # N m, counter-clockwise positive
    assert angular_accel_world(vehicle, state, forces)[2] * rate_radps > 1.0  # rad/s^2 about world z
    assert thrust == pytest.approx(vehicle.weight_n, rel=0.05)  # turning does not climb or sink


def test_already_turning_at_the_commanded_rate_needs_no_yaw_torque(vehicle, kind):
    state = state_of(vehicle, body_rates=(0.0, 0.0, 0.8))
    forces = settle(make_controller(kind, vehicle), state, command(Twist(angular_z=0.8)))
    assert wrench(vehicle, forces)[3] == pytest.approx(0.0, abs=1e-9)


def test_cascade_heading_hold_takes_the_short_way_across_180_degrees(vehicle):
    def yaw_torque_after(hold_deg, now_deg):
        controller = CascadeController(vehicle)
        controller.update(state_of(vehicle, rpy=(0, 0, math.radians(hold_deg))), command(), DT_S)  # latches
        forces = controller.update(state_of(vehicle, rpy=(0, 0, math.radians(now_deg))), command(), DT_S)
        return wrench(vehicle, forces)[3]

    across = yaw_torque_after(179.0, -179.0)  # 2 degrees counter-clockwise of the held heading
    plain = yaw_torque_after(1.0, 3.0)  # the same 2 degrees, away from the wrap
    assert across < 0.0  # turn back clockwise, not 358 degrees the other way
    assert across == pytest.approx(plain, rel=1e-6)


# --- dead-man hold ------------------------------------------------------------------------


def _flight(vehicle):
    """A short synthetic flight: drifting forward and climbing a little, yawed."""
    return [
        state_of(vehicle, position=(0.02 * i, 0.0, 2.0 + 0.005 * i), rpy=(0, 0, 0.4), velocity=(0.5, 0.1, 0.2))
        for i in range(20)
    ]


@pytest.mark.parametrize("z_mode", list(ZMode))
def test_dead_man_hold_is_a_zero_command(vehicle, kind, z_mode):
    flying, reference = make_controller(kind, vehicle), make_controller(kind, vehicle)
    states = _flight(vehicle)
    moving = Twist(0.5, 0.1, 0.2 if z_mode is ZMode.VELOCITY else 0.0, 0.0, 0.0, 0.0)
    for s in states[:10]:
        flying.update(s, command(moving, z_mode), DT_S)
        reference.update(s, command(moving, z_mode), DT_S)
    # the dead-man fires: the stale twist says "go fast and turn"; it must be ignored
    stale = Twist(3.0, -2.0, 0.0 if z_mode is ZMode.HEIGHT else 2.0, 0.0, 0.0, 1.5)
    for s in states[10:]:
        held = flying.update(s, command(stale, z_mode, hold=True), DT_S)
        zeroed = reference.update(s, command(Twist(), z_mode), DT_S)
        assert held == pytest.approx(zeroed, abs=1e-12)


def test_cascade_hold_returns_to_where_it_stopped(vehicle):
    controller = CascadeController(vehicle)
    stopped = state_of(vehicle, position=(1.0, 2.0, 3.0))
    controller.update(stopped, command(Twist(linear_x=1.0)), DT_S)
    controller.update(stopped, command(Twist(linear_x=1.0), hold=True), DT_S)  # latches (1, 2, 3)
    # pushed 0.5 m along world +x and 0.3 m down (by wind, say), at rest
    pushed = state_of(vehicle, position=(1.5, 2.0, 2.7))
    forces = controller.update(pushed, command(Twist(linear_x=1.0), hold=True), DT_S)
    assert thrust_tip_direction(vehicle, pushed, forces) == pytest.approx([-1.0, 0.0], abs=0.05)
    assert wrench(vehicle, forces)[0] > 1.05 * vehicle.weight_n


def test_seed_hold_keeps_its_altitude(vehicle):
    controller = SeedController(vehicle)
    controller.update(state_of(vehicle, position=(0, 0, 3.0)), command(), DT_S)  # height reference 3 m
    sunk = state_of(vehicle, position=(0, 0, 2.6))
    forces = settle(controller, sunk, command(Twist(0.0, 0.0, -1.0), hold=True))
    assert wrench(vehicle, forces)[0] > 1.05 * vehicle.weight_n


# --- saturation ---------------------------------------------------------------------------


def _extreme_cases(vehicle, count=60):
    rng = random.Random(8)
    big = [0.0, 1e3, -1e3, 50.0, -50.0]
    for i in range(count):
        tilt = rng.choice([0.0, 0.5, 1.4, 3.0])
        state = state_of(
            vehicle,
            position=(rng.uniform(-100, 100), rng.uniform(-100, 100), rng.choice([0.0, 0.3, 2.0, 80.0])),
            rpy=(rng.uniform(-tilt, tilt), rng.uniform(-tilt, tilt), rng.uniform(-math.pi, math.pi)),
            velocity=tuple(rng.choice([0.0, 30.0, -30.0]) for _ in range(3)),
            body_rates=tuple(rng.choice([0.0, 20.0, -20.0]) for _ in range(3)),
        )
        twist = Twist(rng.choice(big), rng.choice(big), rng.choice(big), 0.0, 0.0, rng.choice(big))
        yield state, command(twist, rng.choice(list(ZMode)), hold=i % 7 == 0)


def test_huge_commands_and_wild_states_keep_forces_in_range(vehicle, kind):
    controller = make_controller(kind, vehicle)
    top = vehicle.max_thrust_n
    clipped_high = clipped_low = 0
    for state, active in _extreme_cases(vehicle):
        forces = controller.update(state, active, DT_S)
        assert len(forces) == len(vehicle.rotors)
        assert all(math.isfinite(f) and 0.0 <= f <= top for f in forces), (state, active, forces)
        clipped_high += sum(f == top for f in forces)
        clipped_low += sum(f == 0.0 for f in forces)
    # the cases do reach both limits: the range is enforced, not merely never approached
    assert clipped_high > 0 and clipped_low > 0


# --- reset --------------------------------------------------------------------------------


def _winding_sequence(vehicle):
    """States that wind up integrators and holds: slow drift (inside the integrators' band)."""
    return [
        state_of(
            vehicle,
            position=(0.001 * i, -0.002 * i, 1.5 - 0.001 * i),
            rpy=(0.01, -0.02, 0.3),
            velocity=(0.1, -0.05, -0.1),
        )
        for i in range(240)
    ]


def test_reset_gives_the_same_output_as_a_fresh_controller(vehicle, kind):
    used = make_controller(kind, vehicle)
    twist = Twist(0.2, 0.0, 0.1, 0.0, 0.0, 0.0)
    for s in _winding_sequence(vehicle):
        used.update(s, command(twist), DT_S)
    probe = [state_of(vehicle, position=(0.5, 0.5, 2.5), velocity=(0.05, 0.0, 0.0), step=k) for k in range(5)]
    fresh = make_controller(kind, vehicle)

    def outputs(controller):
        return [f for s in probe for f in controller.update(s, command(twist), DT_S)]

    # without a reset the history shows (so the comparison below can fail) ...
    before = outputs(used)
    after_fresh = outputs(fresh)
    assert before != pytest.approx(after_fresh, abs=1e-9)
    # ... and after one, the controller is indistinguishable from a new one
    used.reset()
    fresh = make_controller(kind, vehicle)
    assert outputs(used) == pytest.approx(outputs(fresh), abs=1e-12)


# --- the seed's explicit time step and layout ---------------------------------------------


def test_seed_gains_do_not_depend_on_the_control_step(vehicle):
    """One smooth motion (rolling, speeding up, sinking, starting to turn) seen at 240 Hz and at
    60 Hz gives the same forces at the same time: the original's per-step difference terms are
    scaled to the step, and its integral accumulates per second."""

    def state_at(t):
        return state_of(
            vehicle,
            position=(0.5 * t + t * t, 0.0, 2.0 - 0.2 * t),
            rpy=(0.3 * t, 0.0, 0.0),
            velocity=(0.5 + 2.0 * t, 0.0, -0.2),
            body_rates=(0.3, 0.0, 0.8 * t),
        )

    def forces_at(t_s, dt_s):
        controller = SeedController(vehicle)
        forces = None
        for k in range(round(t_s / dt_s) + 1):
            forces = controller.update(state_at(k * dt_s), command(), dt_s)
        return forces

    fine, coarse = forces_at(0.25, 1 / 240), forces_at(0.25, 1 / 60)
    thrust, roll, pitch, yaw = wrench(vehicle, fine)
    # the motion is answered (roll back, brake, push up, stop the turn) ...
    assert roll < -0.05 and pitch < -0.005 and thrust > 1.02 * vehicle.weight_n and yaw < -0.01
    # ... and the same way at both steps
    assert fine == pytest.approx(coarse, rel=5e-3)


def test_seed_altitude_integral_grows_per_second_not_per_step(vehicle):
    """Held 1 m below its height reference, the seed's thrust creeps up by its integral term:
    from 5 s to 10 s by i * (5 s / 50 ms) of the original's commands, whatever the control step."""

    def thrust_after(seconds, dt_s):
        controller = SeedController(vehicle)
        controller.update(state_of(vehicle, position=(0, 0, 3.0)), command(), dt_s)  # reference 3 m
        low = state_of(vehicle, position=(0, 0, 2.0))
        forces = None
        for _ in range(round(seconds / dt_s)):
            forces = controller.update(low, command(), dt_s)
        return wrench(vehicle, forces)[0]

    newton_per_command = vehicle.weight_n / 5.335  # the original's hover command is the weight
    growth = (thrust_after(10.0, 1 / 240) - thrust_after(5.0, 1 / 240)) / newton_per_command
    assert growth == pytest.approx(0.001 * 5.0 / 0.05, rel=1e-6)  # i = 0.001 per 50 ms step
    assert thrust_after(10.0, 1 / 60) == pytest.approx(thrust_after(10.0, 1 / 240), rel=1e-3)


def test_seed_refuses_a_rotor_layout_it_cannot_fly(vehicle):
    swapped = dataclasses.replace(vehicle, rotors=tuple(reversed(vehicle.rotors)))
    with pytest.raises(ConfigError, match="rotor_4"):
        SeedController(swapped)


def test_matrix_from_quaternion_remembers_only_what_cannot_change():
    """The last tuple's matrix is kept (the physics and the controller turn the same attitude);
    another tuple, or a list changed in place, gets its own matrix."""
    level, turned = (0.0, 0.0, 0.0, 1.0), quaternion_from_matrix(matrix_from_rpy(0.1, -0.2, 0.3))
    first = matrix_from_quaternion(turned)
    assert matrix_from_quaternion(turned) is first
    assert np.allclose(matrix_from_quaternion(level), np.eye(3))
    assert np.allclose(matrix_from_quaternion(turned), matrix_from_rpy(0.1, -0.2, 0.3), atol=1e-12)
    changing = list(level)
    assert np.allclose(matrix_from_quaternion(changing), np.eye(3))  # type: ignore[arg-type]
    changing[:] = turned
    assert np.allclose(matrix_from_quaternion(changing), first, atol=0)  # type: ignore[arg-type]
