"""Every sign pinned: command axes in the heading frame, yaw direction, hover thrust = weight."""

import math

import pytest

from quadsim import SimConfig, Simulator, StartPose, Twist, ZMode
from quadsim.control import ControllerKind
from quadsim.physics.pybullet_quiet import pb


def _hovering(start=StartPose(), z_mode=ZMode.HEIGHT) -> Simulator:
    sim = Simulator(SimConfig(z_mode=z_mode, start=start))
    sim.send(Twist())
    sim.run_for(4.0)
    return sim


def test_rests_with_rotors_idle_before_first_command():
    with Simulator(SimConfig()) as sim:
        z0 = sim.state.position_m[2]
        state = sim.run_for(2.0)
        assert state.rotor_thrusts_n == (0.0, 0.0, 0.0, 0.0)
        assert state.position_m[2] == pytest.approx(z0, abs=0.005)
        assert math.hypot(*state.position_m[:2]) < 1e-3


def test_hover_thrust_equals_weight(vehicle):
    with _hovering() as sim:
        state = sim.run_for(2.0)
        assert state.position_m[2] == pytest.approx(2.0, abs=0.01)
        assert sum(state.rotor_thrusts_n) == pytest.approx(vehicle.weight_n, rel=0.005)


def test_plus_x_is_forward_in_heading_frame():
    # start facing +y (yaw 90 deg): "forward" must move the vehicle along world +y
    with _hovering(StartPose(yaw_rad=math.pi / 2)) as sim:
        x0, y0, _ = sim.state.position_m
        sim.send(Twist(linear_x=1.0))
        x1, y1, _ = sim.run_for(2.0).position_m
        assert y1 - y0 > 1.0 and abs(x1 - x0) < 0.05


def test_plus_y_is_left_in_heading_frame():
    with _hovering(StartPose(yaw_rad=math.pi / 2)) as sim:
        x0, y0, _ = sim.state.position_m
        sim.send(Twist(linear_y=1.0))
        x1, y1, _ = sim.run_for(2.0).position_m
        assert x1 - x0 < -1.0 and abs(y1 - y0) < 0.05  # left of +y is -x


def test_plus_z_climbs_in_velocity_mode():
    with Simulator(SimConfig(z_mode=ZMode.VELOCITY)) as sim:
        sim.send(Twist(linear_z=1.0))
        state = sim.run_for(3.0)
        assert state.position_m[2] > 2.0
        assert state.linear_velocity_mps[2] == pytest.approx(1.0, abs=0.05)
        sim.send(Twist(linear_z=-0.5))
        state = sim.run_for(1.5)
        assert state.linear_velocity_mps[2] == pytest.approx(-0.5, abs=0.05)


def test_plus_yaw_command_turns_counter_clockwise():
    with _hovering() as sim:
        sim.send(Twist(angular_z=1.0))
        state = sim.run_for(1.0)
        assert state.angular_velocity_body_rps[2] > 0.9
        assert 0.5 < state.yaw_rad() < 1.2


class _ConstantForces:
    """A stand-in controller: the same rotor forces at every control step."""

    kind = ControllerKind.CASCADE

    def __init__(self, forces):
        self.forces = forces

    def reset(self):
        pass

    def update(self, state, command, dt_s):
        return self.forces

    def describe(self):
        return {"name": "constant"}


def _spin_up(yaw_imbalance_n: float, hover_n: float) -> tuple[float, float, float]:
    with Simulator(SimConfig()) as sim:
        phys = sim.physics
        forces = (hover_n, hover_n + yaw_imbalance_n, hover_n, hover_n + yaw_imbalance_n)
        phys.place((0, 0, 5), pb.getQuaternionFromEuler((0.5236, 0, 0)), forces)
        sim.loop.controller = _ConstantForces(forces)
        return sim.step(24).angular_velocity_body_rps


def test_yaw_reaction_torque_acts_about_body_z_when_tilted(vehicle):
    # CW rotors (2, 4) faster than the CCW ones: a +yaw body torque, on a body tilted 30 degrees
    # about x. Compared with the same run without the imbalance (which isolates the small pitch
    # torque of the CoM offset), the extra spin must be about the body's own z, counter-clockwise.
    hover = vehicle.hover_thrust_per_rotor_n
    base = _spin_up(0.0, hover)
    spun = _spin_up(0.5, hover - 0.25)  # same total thrust
    dx, dy, dz = (a - b for a, b in zip(spun, base))
    assert dz > 0.1
    assert abs(dx) < 0.02 * dz and abs(dy) < 0.02 * dz


@pytest.mark.parametrize("airframe", ["quadsim_x", "quadsim_hexa", "crazyflie"])
def test_thrust_follows_the_attitude_of_the_step_it_is_applied_in(airframe):
    """Spinning at 10 rad/s about body x (2.4 degrees a step at 240 Hz) with the rotors at half
    thrust, at rest (no drag): each step's acceleration, gravity taken out, points along body z
    at the start of that step. A force in a rotor link's frame was turned with the pose of the
    step before: 2.34 degrees behind."""
    from quadsim.assets import asset_path
    from quadsim.vehicle.params import load_vehicle
    from tests.helpers.sim import body_alone

    vehicle = load_vehicle(asset_path("urdf", f"{airframe}.urdf"))
    thrusts = (0.5 * vehicle.max_thrust_n,) * len(vehicle.rotors)
    step_deg = math.degrees(10.0 / 240)
    with body_alone(vehicle) as world:
        world.place((0.0, 0.0, 20.0), thrusts_n=thrusts)
        pb.resetBaseVelocity(world.body_id, (0.0, 0.0, 0.0), (10.0, 0.0, 0.0), physicsClientId=world.client_id)
        world._read_kinematics()
        before = world.state(0)
        off_start, off_end = [], []
        for step in range(1, 13):
            world._step(thrusts)
            after = world.state(step)
            dv = [(b - a) * 240 for a, b in zip(before.linear_velocity_mps, after.linear_velocity_mps)]
            dv[2] += vehicle.gravity_mps2
            norm = math.sqrt(sum(c * c for c in dv))
            for state, out in ((before, off_start), (after, off_end)):
                z = pb.getMatrixFromQuaternion(state.orientation_xyzw)[2::3]
                out.append(math.degrees(math.acos(max(-1.0, min(1.0, sum(a * b for a, b in zip(dv, z)) / norm)))))
            before = after
    assert max(off_start) < 0.1 * step_deg, off_start  # along this step's body z
    assert min(off_end) > 0.9 * step_deg, off_end  # and not along the next one's: the measure can tell


@pytest.mark.parametrize("airframe", ["quadsim_x", "quadsim_hexa", "crazyflie"])
def test_the_flight_body_turns_with_the_urdf_inertia_and_is_placed_at_base_link(airframe):
    """The flight body is the URDF's links merged into one: a torque about each body axis turns
    it at torque / the principal inertia the URDF gives (PyBullet's own merge made the quad's
    roll and pitch inertia 8 % wrong), and the pose placed and read is base_link's origin's, in
    any attitude, not that of the centre of mass (where PyBullet keeps a merged body's pose)."""
    from quadsim.assets import asset_path
    from quadsim.vehicle.params import load_vehicle
    from tests.helpers.sim import body_alone

    vehicle = load_vehicle(asset_path("urdf", f"{airframe}.urdf"))
    with body_alone(vehicle) as world:
        cid = world.client_id
        assert pb.getNumJoints(world.body_id, physicsClientId=cid) == 0  # one body
        turned = pb.getQuaternionFromEuler((0.3, -0.2, 1.0))
        world.place((1.0, 2.0, 20.0), turned)
        placed = world.state(0)
        assert placed.position_m == pytest.approx((1.0, 2.0, 20.0), abs=1e-12)
        assert placed.orientation_xyzw == pytest.approx(turned, abs=1e-12)
        assert placed.linear_velocity_mps == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
        # PyBullet's pose of it is the centre of mass's, com_m from base_link's origin in body axes
        com = pb.getBasePositionAndOrientation(world.body_id, physicsClientId=cid)[0]
        m = pb.getMatrixFromQuaternion(turned)
        expected = [p + sum(m[3 * i + j] * vehicle.com_m[j] for j in range(3)) for i, p in enumerate((1.0, 2.0, 20.0))]
        assert com == pytest.approx(expected, abs=1e-12)
        for axis in range(3):
            world.place((0.0, 0.0, 20.0), (0.0, 0.0, 0.0, 1.0))
            inertia = vehicle.inertia_kgm2[axis][axis]
            torque = [0.0, 0.0, 0.0]
            torque[axis] = 0.1 * inertia  # 0.1 rad/s^2 about the body (and world) axis
            pb.applyExternalTorque(world.body_id, -1, torque, pb.WORLD_FRAME, physicsClientId=cid)
            pb.stepSimulation(physicsClientId=cid)
            spin = pb.getBaseVelocity(world.body_id, physicsClientId=cid)[1]
            assert spin[axis] * 240 == pytest.approx(0.1, rel=0.002), (airframe, axis)
