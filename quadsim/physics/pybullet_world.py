"""Physics: the PyBullet world, the vehicle body, its motors and the forces applied each step.

Holds no controller and no gains: it takes N commanded rotor forces per step and returns
the vehicle's state. It is the only flight module that imports pybullet.
"""

from __future__ import annotations

import os

from quadsim.core.kinematics import matrix_from_quaternion
from quadsim.core.types import RotorForces, StartPose, VehicleState
from quadsim.errors import QuadsimError
from quadsim.physics.pybullet_quiet import pb
from quadsim.physics.scene import build_world, load_vehicle_body
from quadsim.physics.world_spec import WorldSpec
from quadsim.vehicle.motors import MotorBank
from quadsim.vehicle.params import VehicleParams

#: Clearance above the ground the vehicle is placed at, so it starts just resting on the floor.
_SPAWN_CLEARANCE_M = 0.001

_ORIGIN = (0.0, 0.0, 0.0)


class PhysicsWorld:
    """A PyBullet client with the world and one vehicle in it. Composition, not inheritance:
    the client is private, and only what the simulator needs is exposed.

    Every step: the motors move toward the commanded forces; each rotor's force is applied at
    its link along body z; the summed yaw reaction torque on a rotor link in its own frame (see
    STYLE.md on the base-link torque frame bug); linear body drag at the base; then one
    `stepSimulation`. PyBullet clears external forces after each step, so all are re-applied.

    It keeps no clock: the simulation loop (quadsim.sim.loop.SimLoop) is the only caller of
    `_step` and owns the step count, which it hands to `state`.
    """

    def __init__(
        self,
        vehicle: VehicleParams,
        world: WorldSpec,
        physics_hz: int,
        start: StartPose = StartPose(),
        gui: bool = False,
    ) -> None:
        if gui and not os.environ.get("DISPLAY") and os.name != "nt":
            raise QuadsimError("--gui needs a display (DISPLAY is not set); run without --gui")
        self.vehicle = vehicle
        self.dt_s = 1.0 / physics_hz
        self._inv_dt = 1.0 / self.dt_s
        self._cid = pb.connect(pb.GUI if gui else pb.DIRECT)
        if self._cid < 0:
            raise QuadsimError("could not start PyBullet" + (" with a GUI" if gui else ""))
        self._gui = gui
        cid = self._cid
        pb.setGravity(0.0, 0.0, -vehicle.gravity_mps2, physicsClientId=cid)
        pb.setTimeStep(self.dt_s, physicsClientId=cid)
        pb.setPhysicsEngineParameter(deterministicOverlappingPairs=1, physicsClientId=cid)
        if gui:
            pb.configureDebugVisualizer(pb.COV_ENABLE_GUI, 0, physicsClientId=cid)
        self.landmark_ids = build_world(world, cid)
        self.start = start
        self.body_id = load_vehicle_body(vehicle, cid, self._spawn_position(), self._spawn_orientation())
        links = {
            pb.getJointInfo(self.body_id, i, physicsClientId=cid)[12].decode(): i
            for i in range(pb.getNumJoints(self.body_id, physicsClientId=cid))
        }
        self.link_index = links
        self._rotor_links = tuple(links[r.link_name] for r in vehicle.rotors)
        # reaction torque per newton on each rotor, about body z (CCW rotor -> negative yaw)
        c = vehicle.yaw_torque_per_thrust_m
        self._yaw_per_n = tuple(-r.spin.sign * c for r in vehicle.rotors)
        self._drag = vehicle.drag_coefficients_ns_per_m
        self.motors = MotorBank(len(vehicle.rotors), vehicle.motor_time_constant_s, vehicle.max_thrust_n, self.dt_s)
        self._read_kinematics()
        self._previous_velocity = self._linear_velocity

    # --- building ---------------------------------------------------------------------------

    def _spawn_position(self) -> tuple[float, float, float]:
        aabb_min_z = self._resting_height()
        return (self.start.x_m, self.start.y_m, aabb_min_z + _SPAWN_CLEARANCE_M)

    def _spawn_orientation(self) -> tuple[float, float, float, float]:
        x, y, z, w = pb.getQuaternionFromEuler((0.0, 0.0, self.start.yaw_rad))
        return (x, y, z, w)

    def _resting_height(self) -> float:
        """Height of base_link above the floor when the vehicle rests on its collision shape."""
        if not hasattr(self, "_rest_z"):
            probe = pb.loadURDF(str(self.vehicle.urdf_path), (0, 0, 10.0), physicsClientId=self._cid)
            lo = min(
                pb.getAABB(probe, i, physicsClientId=self._cid)[0][2]
                for i in range(-1, pb.getNumJoints(probe, physicsClientId=self._cid))
                if pb.getCollisionShapeData(probe, i, physicsClientId=self._cid)
            )
            pb.removeBody(probe, physicsClientId=self._cid)
            self._rest_z = 10.0 - lo
        return self._rest_z

    # --- stepping ---------------------------------------------------------------------------

    def reset(self) -> None:
        """Put the vehicle back at its start pose, at rest, rotors stopped."""
        # away from everything first, so that PyBullet forgets the contacts it had (their cached
        # impulses warm-start the solver): a reset then flies the same whatever came before it
        far = (0.0, 0.0, 1e4)
        pb.resetBasePositionAndOrientation(self.body_id, far, (0.0, 0.0, 0.0, 1.0), physicsClientId=self._cid)
        pb.performCollisionDetection(physicsClientId=self._cid)
        pb.resetBasePositionAndOrientation(
            self.body_id, self._spawn_position(), self._spawn_orientation(), physicsClientId=self._cid
        )
        pb.resetBaseVelocity(self.body_id, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=self._cid)
        self.motors.reset()
        self._read_kinematics()
        self._previous_velocity = self._linear_velocity

    def _step(self, command_n: RotorForces) -> None:
        """Advance one physics step with the given commanded rotor forces (N).

        Private to the simulation loop, which counts the steps: stepping from anywhere else
        would move the vehicle without moving the clock."""
        # the hot path: PyBullet's calls get positional arguments (parsing the keyword
        # physicsClientId costs about a quarter of a microsecond a call)
        body, cid, link_frame, apply_force = self.body_id, self._cid, pb.LINK_FRAME, pb.applyExternalForce
        yaw = 0.0
        for link, thrust, yaw_per_n in zip(self._rotor_links, self.motors.advance(command_n), self._yaw_per_n):
            apply_force(body, link, (0.0, 0.0, thrust), _ORIGIN, link_frame, cid)
            yaw += yaw_per_n * thrust
        # the rotor links share base_link's axes, so a torque about rotor z is one about body z
        pb.applyExternalTorque(body, self._rotor_links[0], (0.0, 0.0, yaw), link_frame, cid)
        # drag: velocity into base_link, -c v per axis, applied at the base in its own frame
        (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = self._rotation
        vx, vy, vz = self._linear_velocity
        cx, cy, cz = self._drag
        drag = (
            -cx * (m00 * vx + m10 * vy + m20 * vz),
            -cy * (m01 * vx + m11 * vy + m21 * vz),
            -cz * (m02 * vx + m12 * vy + m22 * vz),
        )
        apply_force(body, -1, drag, _ORIGIN, link_frame, cid)
        pb.stepSimulation(cid)
        self._previous_velocity = self._linear_velocity
        self._read_kinematics()

    def _read_kinematics(self) -> None:
        body, cid = self.body_id, self._cid
        self._position, self._orientation = pb.getBasePositionAndOrientation(body, cid)
        self._linear_velocity, self._angular_velocity = pb.getBaseVelocity(body, cid)
        self._rotation = matrix_from_quaternion(self._orientation)

    def state(self, step: int) -> VehicleState:
        """The vehicle's state after the last physics step, which the loop counts as `step`
        (body rates in base_link)."""
        (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = self._rotation
        wx, wy, wz = self._angular_velocity
        (vx, vy, vz), (ux, uy, uz) = self._linear_velocity, self._previous_velocity
        inv_dt = self._inv_dt
        # specific force: (dv/dt - gravity) in world, then into base_link
        fx, fy, fz = (vx - ux) * inv_dt, (vy - uy) * inv_dt, (vz - uz) * inv_dt + self.vehicle.gravity_mps2
        return VehicleState(
            step,
            self._position,
            self._orientation,
            self._linear_velocity,
            (m00 * wx + m10 * wy + m20 * wz, m01 * wx + m11 * wy + m21 * wz, m02 * wx + m12 * wy + m22 * wz),
            self.motors.thrusts_n,
            (m00 * fx + m10 * fy + m20 * fz, m01 * fx + m11 * fy + m21 * fz, m02 * fx + m12 * fy + m22 * fz),
        )

    # --- lifetime ---------------------------------------------------------------------------

    @property
    def client_id(self) -> int:
        """The PyBullet client, for components that render from it (cameras)."""
        return self._cid

    def close(self) -> None:
        if self._cid >= 0:
            try:
                pb.disconnect(physicsClientId=self._cid)
            except pb.error:
                pass
            self._cid = -1

    def __enter__(self) -> PhysicsWorld:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
