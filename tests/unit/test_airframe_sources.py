"""Each shipped airframe against the published figures its parameter file cites, measured open
loop through the physics (fixed rotor forces, no controller): the yaw acceleration a thrust
difference between the rotors gives, and the Crazyflie's rotor drag at Foerster's hover speed."""

import math

import pytest

from quadsim.physics.pybullet_quiet import pb
from quadsim.vehicle.mixer import Mixer
from quadsim.vehicle.params import SHIPPED_VEHICLES, Spin, VehicleParams, load_vehicle
from tests.helpers.sim import body_alone

#: J. Foerster, "System Identification of the Crazyflie 2.0 Nano Quadrocopter", ETH Zurich 2015:
#: reaction torque per newton of thrust (his torque map's slope, the firmware's THRUST2TORQUE), m
FOERSTER_TORQUE_PER_THRUST_M = 0.005964552
#: his yaw inertia, kg m^2
FOERSTER_IZZ_KGM2 = 2.926e-5
#: his drag matrix's diagonal, N per (m/s) per (rad/s) of the four rotors' summed speed
FOERSTER_DRAG_IN_PLANE = 10.2506e-7
FOERSTER_DRAG_AXIAL = 7.5530e-7
#: RotorS's AscTec Hummingbird (rotors_description/urdf/hummingbird.xacro): moment_constant, m
ROTORS_HUMMINGBIRD_MOMENT_CONSTANT_M = 0.016


def _foerster_hover_speed_radps(mass_kg: float, gravity_mps2: float) -> float:
    """One rotor's speed in hover from Foerster's thrust and speed maps of the motor command."""
    thrust = mass_kg * gravity_mps2 / 4.0
    a, b, c = 2.130295e-11, 1.032633e-6, 5.484560e-4 - thrust
    command = (-b + math.sqrt(b * b - 4.0 * a * c)) / (2.0 * a)
    return 0.04076521 * command + 380.8359


def _hover_forces(vehicle: VehicleParams, yaw_split_n: float = 0.0) -> tuple[float, ...]:
    """The rotor forces that hold the vehicle's weight with no torque about its centre of mass
    (equal forces would pitch it: the front camera puts the centre of mass off the rotors' centre,
    and base_link's origin would swing with it), the CW ones then `yaw_split_n` up and the CCW
    ones as much down."""
    hover = Mixer(vehicle).to_rotor_forces(vehicle.weight_n, 0.0, 0.0, 0.0)
    return tuple(f + (yaw_split_n if r.spin is Spin.CW else -yaw_split_n) for f, r in zip(hover, vehicle.rotors))


def _one_step_from(vehicle: VehicleParams, forces, velocity_mps=(0.0, 0.0, 0.0)):
    """The state after one physics step from level at 50 m, moving at `velocity_mps`, the motors
    already at `forces` (so they hold them)."""
    with body_alone(vehicle) as world:
        world.place((0.0, 0.0, 50.0), (0.0, 0.0, 0.0, 1.0), forces)
        pb.resetBaseVelocity(world.body_id, velocity_mps, (0.0, 0.0, 0.0), physicsClientId=world.client_id)
        world._read_kinematics()
        world._previous_velocity = world._linear_velocity
        world._step(forces)
        return world.state(1)


@pytest.mark.parametrize(
    "airframe,torque_per_thrust_m,izz_kgm2",
    [
        ("crazyflie", FOERSTER_TORQUE_PER_THRUST_M, FOERSTER_IZZ_KGM2),
        ("quad", ROTORS_HUMMINGBIRD_MOMENT_CONSTANT_M, None),
        ("hexa", ROTORS_HUMMINGBIRD_MOMENT_CONSTANT_M, None),
    ],
)
def test_a_thrust_difference_yaws_the_airframe_as_its_source_says(airframe, torque_per_thrust_m, izz_kgm2):
    """CW rotors up and CCW rotors down by the same force (total thrust unchanged): the yaw
    acceleration per newton of (CW - CCW) thrust is the source's torque per thrust over the yaw
    inertia (the source's own for the Crazyflie; the URDF's for quadsim's airframes)."""
    vehicle = load_vehicle(SHIPPED_VEHICLES[airframe])
    split = 0.1 * vehicle.hover_thrust_per_rotor_n
    forces = _hover_forces(vehicle, split)
    difference = split * vehicle.rotor_count  # sum(CW) - sum(CCW)
    yaw_accel = _one_step_from(vehicle, forces).angular_velocity_body_rps[2] * 240.0
    izz = izz_kgm2 if izz_kgm2 is not None else vehicle.inertia_kgm2[2][2]
    assert yaw_accel / difference == pytest.approx(torque_per_thrust_m / izz, rel=0.05)


@pytest.mark.parametrize(
    "axis,coefficient", [(0, FOERSTER_DRAG_IN_PLANE), (1, FOERSTER_DRAG_IN_PLANE), (2, FOERSTER_DRAG_AXIAL)]
)
def test_the_crazyflies_rotor_drag_is_foersters_at_his_hover_speed(axis, coefficient):
    """In hover, moving slowly along a body axis: the deceleration is Foerster's drag coefficient
    times his four rotors' summed hover speed over the mass (his thrust map and his rotor speed
    together), besides the bluff body's quadratic drag the file adds for a fall with stopped rotors."""
    vehicle = load_vehicle(SHIPPED_VEHICLES["crazyflie"])
    speed = 0.2
    velocity = [0.0, 0.0, 0.0]
    velocity[axis] = speed
    after = _one_step_from(vehicle, _hover_forces(vehicle), tuple(velocity))
    decel = (speed - after.linear_velocity_mps[axis]) * 240.0
    body = vehicle.aero.body_drag_quadratic_ns2_per_m2[axis] * speed * speed / vehicle.mass_kg
    rotor_speed_sum = 4.0 * _foerster_hover_speed_radps(vehicle.mass_kg, vehicle.gravity_mps2)
    expected = coefficient * rotor_speed_sum * speed / vehicle.mass_kg
    assert decel - body == pytest.approx(expected, rel=0.05)
