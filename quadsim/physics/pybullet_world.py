"""A vehicle's body in the PyBullet world: its motors and the forces applied to it each step.

Holds no controller and no gains: it takes N commanded rotor forces per step and returns
the vehicle's state. It is the only flight module that imports pybullet.
"""

from __future__ import annotations

import functools
import math
from typing import Any, NamedTuple

import numpy as np

from quadsim.core.compiled import float_tuple, floats, specialize, table
from quadsim.core.kinematics import Vec3, known_matrix, matrix_from_quaternion
from quadsim.core.types import RotorForces, StartPose, Stepping, VehicleState
from quadsim.errors import ConfigError
from quadsim.physics.base_link import base_link_state
from quadsim.physics.client import WorldClient
from quadsim.physics.free_flight import STATE_SIZE, clear_step
from quadsim.physics.pybullet_quiet import pb
from quadsim.physics.scene import inertial_offset, load_vehicle_body
from quadsim.physics.wind import ModelWind, WindField, WindModel, WindSettings
from quadsim.vehicle.motors import MotorBank
from quadsim.vehicle.params import VehicleParams
from quadsim.vehicle.wrench import airframe_constants, airframe_wrench, hub_table

#: Clearance above the ground the vehicle is placed at, so it starts just resting on the floor.
_SPAWN_CLEARANCE_M = 0.001
#: How far the vehicle's bounding sphere must be from all the scenery for the contact query to be
#: skipped: far beyond PyBullet's contact breaking threshold (0.02 m) and collision margins. Two
#: steps' travel at the vehicle's speed is added on top (contacts are found before a step moves it).
_CONTACT_CLEARANCE_M = 0.5
#: more than the rounding of a clearance measured (m)
_ROUNDING_M = 1e-9


#: the clearance from other vehicles of a vehicle alone in its world
_NOTHING_NEAR: tuple[Vec3, float] = ((0.0, 0.0, 0.0), math.inf)


class Contact(NamedTuple):
    """The vehicle touching one other body after a physics step."""

    other: str  # what it touches: 'floor' or a landmark's name
    normal_z: float  # world z of the contact normal, pointing at the vehicle (1: resting on it; 0: a wall)


def _near_others(client: WorldClient) -> set[PhysicsWorld]:
    """The vehicles of `client`'s world that another one could reach within two steps: the
    bounding spheres of a pair, at their speeds (1-norms), less than the clearance apart.

    Every pair is measured only when needed: a measurement keeps, for each vehicle, where it was
    and half its slack (the least gap to any other sphere, less the clearance). While every
    vehicle has since moved less than its half slack, counting two steps ahead at its speed, no
    pair can be that close (the gap of a pair shrinks by at most the two vehicles' moves, and
    their half slacks add up to at most the gap): no vehicle is near, and no pair is looked at.
    Otherwise every pair is measured again, as it was on every step before (the same set)."""
    bodies, apart = client.bodies, client.apart
    if len(apart) == len(bodies):
        for body in bodies:
            measured = apart.get(body)
            if measured is None or not body._within_slack(measured):
                break
        else:
            return set()
    near: set[PhysicsWorld] = set()
    reach = [(b, b._position, sum(map(abs, b._linear_velocity)), b.reach_m) for b in bodies]
    rooms = [math.inf] * len(reach)
    for i, (a, (x, y, z), speed, radius) in enumerate(reach):
        two_steps = 2.0 * a.dt_s
        for j, (b, (ox, oy, oz), other_speed, other_radius) in enumerate(reach[i + 1 :], i + 1):
            gap = radius + other_radius + _CONTACT_CLEARANCE_M
            apart_m = gap + two_steps * (speed + other_speed)
            dx, dy, dz = x - ox, y - oy, z - oz
            squared = dx * dx + dy * dy + dz * dz
            if squared <= apart_m * apart_m:
                near.add(a)
                near.add(b)
            half = 0.5 * (math.sqrt(squared) - gap) - 1e-9  # rounding of the bound's terms
            rooms[i], rooms[j] = min(rooms[i], half), min(rooms[j], half)
    client.apart = {b: (position, room) for (b, position, _, _), room in zip(reach, rooms)}
    return near


class PhysicsWorld:
    """One vehicle's body in a PyBullet world (a WorldClient, shared by every vehicle of the run).
    Composition, not inheritance: the client is private, and only what the simulator needs is
    exposed.

    Every step: the wind advances; the motors move toward the commanded forces; each rotor's
    force, times its ground-effect ratio, acts at its hub along body z, with its yaw reaction
    torque; body and rotor drag through the airspeed (quadsim.vehicle.aero) acts at the centre
    of mass. All of it is summed into one force and one torque about base_link's origin, turned
    into the world frame with the attitude the step starts from, and applied to the base in
    WORLD_FRAME (a LINK_FRAME force on a rotor link would be turned with that link's pose of the
    step before; a LINK_FRAME torque on the base is applied in the world frame, a known PyBullet
    pitfall); then one `stepSimulation`. PyBullet clears external forces after each step, so both are
    re-applied. The ground effect sees the floor (z = 0) only, not the landmarks. The torque
    also carries what makes PyBullet's explicit gyroscopic step an exact, energy-keeping one
    (quadsim.core.rigid_body), for the merged body.

    While the body is clear of everything it could touch (the scenery, and the world's other
    vehicles), the same force and torque are stepped by quadsim's own copy of PyBullet's step
    instead (quadsim.physics.free_flight; `stepping`), with no PyBullet call at all; PyBullet's
    copy of the body is posed again when something reads the scene (WorldClient.posed) or before
    PyBullet steps it.

    The body is the URDF with its fixed links merged into one rigid body (scene.load_vehicle_body),
    whose pose PyBullet keeps at the centre of mass; what this class reads, sets and reports is
    base_link's origin, as the URDF and the recording contract have it.

    It keeps no clock: the simulation loop (quadsim.sim.loop.SimLoop) is the only caller of
    `_step` and owns the step count, which it hands to `state`.
    """

    # base_link's state after the last step (quadsim.physics.base_link), set by every read
    _position: Vec3
    _orientation: tuple[float, float, float, float]
    _linear_velocity: Vec3
    _angular_velocity: Vec3
    _rotation: tuple[Vec3, Vec3, Vec3]
    _body_rates: Vec3
    _specific_force: Vec3

    def __init__(
        self,
        vehicle: VehicleParams,
        client: WorldClient,
        start: StartPose = StartPose(),
        wind: WindSettings = WindSettings(),
        wind_seed: np.random.SeedSequence | None = None,
        name: str = "vehicle",
        far_index: int = 0,
        wind_model: WindModel | None = None,
        stepping: Stepping = Stepping.QUADSIM,
    ) -> None:
        """`client`: the world to fly in, which every vehicle of the run shares (its owner
        closes it); `name`: what other vehicles' contacts call this one; `far_index`: where
        `reset` parks the body for a moment, apart from the others'; `wind_model`: a wind of
        the user's own, in place of `wind`'s; `stepping`: who steps the body while it touches
        nothing."""
        self.vehicle = vehicle
        self.dt_s = client.dt_s
        self._inv_dt = 1.0 / self.dt_s
        if client.gravity_mps2 != vehicle.gravity_mps2:
            raise ConfigError(f"{name}: a vehicle's gravity must be its world's")
        self.client = client
        self._cid = client.cid
        self.landmark_ids = client.landmark_ids
        self._far = (100.0 * far_index, 0.0, 1e4)
        self.start = start
        #: the base's state (quadsim.physics.free_flight: its inertial frame, world frame), as
        #: PyBullet last reported it or as quadsim's own step left it
        self._body = floats([0.0] * STATE_SIZE)
        #: the base's state as PyBullet last reported it, when that is newer than `_body`
        self._from_pybullet: tuple[Vec3, tuple[float, float, float, float], Vec3, Vec3] | None = None
        self._gravity = client.gravity_mps2
        self._previous_velocity: Vec3 = (0.0, 0.0, 0.0)
        self._base_link_state: Any = specialize(base_link_state, *[0.0] * 19, True, 0.0, 0.0)
        self._load_body(name)
        self.stepping = stepping
        client.bodies.append(self)
        #: the static scenery's planes and boxes, found at the first contact query (once every
        #: vehicle of a fleet is in the world); None: something else can move, always ask
        self._scenery: tuple[tuple[float, ...], tuple[tuple[Vec3, Vec3], ...]] | bool | None = False
        self._clear_from: Vec3 = (math.inf, math.inf, math.inf)
        self._others: tuple[PhysicsWorld, ...] = ()
        self._clear_slack_m = 0.0
        self.wind_settings = wind
        self._wind_model = wind_model
        self._wind_seed = wind_seed if wind_seed is not None else np.random.SeedSequence(0)
        self._wind: WindField | ModelWind | None = None
        self._reset_wind()
        self.motors = MotorBank(len(vehicle.rotors), vehicle.motor_time_constant_s, vehicle.max_thrust_n, self.dt_s)
        self._prepare_steps()
        self._read_kinematics()
        self._previous_velocity = self._linear_velocity

    def _prepare_steps(self) -> None:
        """The constants, rotor table and output `airframe_wrench` takes each step (applied in
        PyBullet), what quadsim's own step of the body takes (quadsim.physics.free_flight) and
        whether it may take it: one rigid body (no joints), no PyBullet window showing it; and
        both functions made for their arguments (without numba's type dispatch:
        quadsim.core.compiled.specialize)."""
        vehicle, xyz, forces = self.vehicle, (0.0, 0.0, 0.0), (0.0,) * len(self.vehicle.rotors)
        self._airframe = floats(airframe_constants(vehicle, self.motors.alpha, self.dt_s, self.merged))
        self._hub_table = table(hub_table(vehicle))
        self._wrench = floats([0.0] * 6)
        self._airframe_wrench = specialize(
            airframe_wrench,
            self._airframe,
            self._hub_table,
            self.motors.thrusts,
            forces,
            (xyz, xyz, xyz),
            0.0,
            xyz,
            xyz,
            self._wrench,
        )
        mass, _, inertia = pb.getDynamicsInfo(self.body_id, -1, physicsClientId=self._cid)[:3]
        self._mass_kg, self._inertia = float(mass), floats(inertia)
        self._free = (
            self.stepping is Stepping.QUADSIM
            and self.merged
            and not self.client.gui
            and pb.getNumJoints(self.body_id, physicsClientId=self._cid) == 0
        )
        #: the last step was quadsim's own: PyBullet neither moved the body nor found its contacts
        self._flew_free = False
        #: PyBullet's copy of the body is older than `_body` (posed again when the scene is read)
        self._stale = False
        #: the body's state is to be read from PyBullet before the next step (`client_id`)
        self._reread = False
        #: what quadsim's step takes that stays the same from step to step
        self._clear_constants = (
            self._airframe, self._hub_table, self.motors.thrusts, self._wrench, self._body, self._mass_kg,
            self._inertia, self._gravity, self.dt_s, self._inv_dt, self._offset,
        )  # fmt: skip
        self._clear_step: Any = specialize(
            clear_step, *self._clear_constants, forces, (xyz, xyz, xyz), xyz, xyz, xyz, xyz
        )
        self._after_step: Any = None

    def reseed(self, wind_seed: np.random.SeedSequence) -> None:
        """The turbulence's random stream from `wind_seed` from the next reset on."""
        self._wind_seed = wind_seed

    def _reset_wind(self) -> None:
        if self._wind_model is not None:
            self._wind = ModelWind(self._wind_model, self.dt_s)
        elif self.wind_settings.enabled:
            rng = np.random.Generator(np.random.PCG64(self._wind_seed))
            self._wind = WindField(self.wind_settings, self.dt_s, rng)

    @property
    def wind_mps(self) -> Vec3 | None:
        """The wind at the vehicle over the last step, world frame (None: no wind in this run)."""
        return None if self._wind is None else self._wind.wind_mps

    # --- building ---------------------------------------------------------------------------

    def _spawn_position(self) -> tuple[float, float, float]:
        return (self.start.x_m, self.start.y_m, self.rest_height_m + _SPAWN_CLEARANCE_M)

    def _spawn_orientation(self) -> tuple[float, float, float, float]:
        return pb.getQuaternionFromEuler((0.0, 0.0, self.start.yaw_rad))

    @functools.cached_property
    def rest_height_m(self) -> float:
        """Height of base_link above the floor when the vehicle rests on its collision shape."""
        probe = pb.loadURDF(str(self.vehicle.pybullet_urdf_path), (0, 0, 10.0), physicsClientId=self._cid)
        lo = min(low[2] for low, _ in self._collision_boxes(probe))
        pb.removeBody(probe, physicsClientId=self._cid)
        return 10.0 - lo

    def _collision_boxes(self, body: int) -> list[tuple[Vec3, Vec3]]:
        """The bounding boxes (world frame) of `body`'s links that have a collision shape."""
        cid = self._cid
        return [
            pb.getAABB(body, link, physicsClientId=cid)
            for link in range(-1, pb.getNumJoints(body, physicsClientId=cid))
            if pb.getCollisionShapeData(body, link, physicsClientId=cid)
        ]

    def _load_body(self, name: str) -> None:
        """The vehicle's body at its start pose, its links by name and its reach."""
        cid = self._cid
        at, facing = self._spawn_position(), self._spawn_orientation()
        self.body_id = load_vehicle_body(self.vehicle, cid, at, facing, merged=True)
        offset = inertial_offset(self.body_id, cid)
        #: one rigid body with the URDF's principal inertia, whose rotation is stepped exactly
        #: (quadsim.core.rigid_body); a tree of links keeps PyBullet's own gyroscopic term
        self.merged = offset is not None
        if offset is None:  # a merge that turned the inertial frame: the URDF's tree as it is
            pb.removeBody(self.body_id, physicsClientId=cid)
            self.body_id = load_vehicle_body(self.vehicle, cid, at, facing)
            offset = inertial_offset(self.body_id, cid) or (0.0, 0.0, 0.0)
        #: base_link's origin to the base's inertial frame, where PyBullet has the body's pose
        self._offset: Vec3 = offset
        self.client.body_names[self.body_id] = name
        self.link_index = {
            pb.getJointInfo(self.body_id, i, physicsClientId=cid)[12].decode(): i
            for i in range(pb.getNumJoints(self.body_id, physicsClientId=cid))
        }
        self._read_kinematics()
        corners = [
            (x, y, z)
            for lo, hi in self._collision_boxes(self.body_id)
            for x in (lo[0], hi[0])
            for y in (lo[1], hi[1])
            for z in (lo[2], hi[2])
        ]
        #: the radius of a sphere about base_link's origin that holds the vehicle in any attitude:
        #: to the farthest corner of the links' collision boxes as loaded
        self.reach_m = max((math.dist(self._position, corner) for corner in corners), default=0.0)
        self._check_start_is_clear(name)

    def _check_start_is_clear(self, name: str) -> None:
        """Refuse a start pose whose spot on the floor is taken by a landmark (the vehicle would
        start inside it, stuck), naming both."""
        x, y = self.start.x_m, self.start.y_m
        reach = self.reach_m
        boxes = self.client.scenery[1] if self.client.scenery is not None else {}
        for landmark, ((lx, ly, _), (hx, hy, _)) in boxes.items():
            if lx - reach < x < hx + reach and ly - reach < y < hy + reach:
                raise ConfigError(
                    f"{name}: the start pose ({x:g}, {y:g}) is on the {landmark} landmark's spot "
                    f"(x {lx:g} .. {hx:g}, y {ly:g} .. {hy:g}, and the vehicle's {reach:.2f} m reach): "
                    "start elsewhere"
                )

    # --- stepping ---------------------------------------------------------------------------

    def _static_scenery(self) -> tuple[tuple[float, ...], tuple[tuple[Vec3, Vec3], ...]] | None:
        """The heights of the horizontal planes and the boxes of the scenery, or None when some
        other body that can touch the vehicle is in the world and is neither scenery nor one
        of the run's vehicles (a body added from outside: it may move; then the contacts are
        always asked). The other vehicles are kept, to keep clear of (`_clear_of_others`)."""
        cid, scenery = self._cid, self.client.scenery
        if scenery is None:
            return None
        self._others = tuple(body for body in self.client.bodies if body is not self)
        known = {*self.landmark_ids.values(), *(body.body_id for body in self.client.bodies)}
        for index in range(pb.getNumBodies(physicsClientId=cid)):
            other = pb.getBodyUniqueId(index, physicsClientId=cid)
            if other not in known and pb.getCollisionShapeData(other, -1, physicsClientId=cid):
                return None
        planes, boxes = scenery
        return planes, tuple(boxes.values())

    def _clear_of_scenery(self) -> bool:
        """True when the vehicle cannot be touching anything: its bounding sphere is more than
        the clearance away from every plane and box of the scenery. The distance measured is
        kept, so the next steps only check how far the vehicle has gone since (a few float
        operations) until it is used up. A slack measured below zero (the vehicle near something,
        on the floor) is kept the same way: the vehicle cannot be clear before it has gone that
        far (less a nanometre, for rounding) from where it was measured."""
        if self._scenery is None:
            return False
        if self._scenery is False:
            self._scenery = self._static_scenery()
            self._clear_slack_m = 0.0  # measured again, from the scenery as it is now
            return self._clear_of_scenery()
        if self._within_slack():
            return True
        slack = self._clear_slack_m
        if slack < 0.0:
            (x, y, z), (cx, cy, cz) = self._position, self._clear_from
            if abs(x - cx) + abs(y - cy) + abs(z - cz) < -slack - _ROUNDING_M:
                return False
        clear, self._clear_slack_m = self.clearance_at(self._position, self._linear_velocity)
        self._clear_from = self._position
        return clear

    def clearance_at(self, position: Vec3, velocity: Vec3) -> tuple[bool, float]:
        """Measured at `position` and `velocity` from the static scenery (`_clear_of_scenery`):
        whether two steps ahead at that speed stay clear, and the slack, how far the vehicle
        may go from there before it might touch anything."""
        (x, y, z), (vx, vy, vz) = position, velocity
        ahead = 2.0 * self.dt_s * (abs(vx) + abs(vy) + abs(vz))
        planes, boxes = self._scenery  # type: ignore[misc]
        nearest = min((z - h for h in planes), default=math.inf)
        for (lx, ly, lz), (hx, hy, hz) in boxes:
            dx, dy, dz = max(lx - x, 0.0, x - hx), max(ly - y, 0.0, y - hy), max(lz - z, 0.0, z - hz)
            nearest = min(nearest, math.sqrt(dx * dx + dy * dy + dz * dz))
        slack = nearest - self.reach_m - _CONTACT_CLEARANCE_M
        return ahead < slack, slack

    def _within_slack(self, clearance: tuple[Vec3, float] | None = None) -> bool:
        """Whether the vehicle is still within a clearance measured before (where it was, and the
        slack then; default: the scenery's, last measured): how far it went since, plus two steps
        at its speed (1-norms: never less), short of the slack. (quadsim.sim.clear_flight.within
        is the same test, compiled.)"""
        (x, y, z), (vx, vy, vz) = self._position, self._linear_velocity
        (cx, cy, cz), slack = (self._clear_from, self._clear_slack_m) if clearance is None else clearance
        ahead = 2.0 * self.dt_s * (abs(vx) + abs(vy) + abs(vz))
        return abs(x - cx) + abs(y - cy) + abs(z - cz) + ahead < slack

    def _clear_of_others(self) -> bool:
        """True when no other vehicle of the world can reach this one within two steps: their
        bounding spheres, at their speeds, stay more than the clearance apart. Every pair of the
        world's vehicles is measured once a step, at the first vehicle's asking (`_near_others`)."""
        near = self.client.near_others
        if near is None:
            near = self.client.near_others = _near_others(self.client)
        return self not in near

    def contacts(self) -> tuple[Contact, ...]:
        """What the vehicle touches after the last physics step, one entry per other body (with
        the most upward of its contact normals). Not asked of PyBullet while the vehicle is clear
        of all the scenery (the query costs about a tenth of a step), nor after a step quadsim
        took itself (it was clear when the step began, by far more than the step's travel)."""
        if self._flew_free or (not self._others and self._clear_of_scenery()):
            return ()
        points = self.client.touching(self.body_id)  # asked of PyBullet once a step for every vehicle
        if not points:
            return ()
        normal_z: dict[int, float] = {}
        for other, nz in points:
            if nz > normal_z.get(other, -2.0):
                normal_z[other] = nz
        return tuple(Contact(self.client.body_names.get(b, f"body {b}"), nz) for b, nz in normal_z.items())

    @property
    def body_z_up(self) -> float:
        """World z component of the body's z axis (1: level, 0: on its side, -1: upside down)."""
        return self._rotation[2][2]

    @property
    def velocity_before_step_mps(self) -> tuple[float, float, float]:
        """The world-frame velocity before the last physics step (an impact's speed)."""
        return self._previous_velocity

    def reset(self) -> None:
        """Put the vehicle back at its start pose, at rest, rotors stopped."""
        # away from everything first, so that PyBullet forgets the contacts it had (their cached
        # impulses warm-start the solver): a reset then flies the same whatever came before it
        self._put(self._far, (0.0, 0.0, 0.0, 1.0))
        pb.performCollisionDetection(physicsClientId=self._cid)
        self._reset_wind()
        self.place(self._spawn_position())

    def place(
        self,
        position_m: Vec3,
        orientation_xyzw: tuple[float, float, float, float] | None = None,
        thrusts_n: tuple[float, ...] | None = None,
    ) -> None:
        """Put the vehicle at `position_m` (base_link origin), at rest, in `orientation_xyzw`
        (default: level, facing its start heading), the motors producing `thrusts_n` (default:
        stopped). For drop tests, measurements and tests that start in the air; the loop's clock
        is not touched."""
        orientation = orientation_xyzw if orientation_xyzw is not None else self._spawn_orientation()
        self._put(position_m, orientation)
        pb.resetBaseVelocity(self.body_id, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=self._cid)
        self.motors.reset(thrusts_n)
        self._read_kinematics()
        self._previous_velocity = self._linear_velocity

    def _step(self, command_n: RotorForces) -> None:
        """Advance one physics step with the given commanded rotor forces (N).

        Private to the simulation loop, which counts the steps: stepping from anywhere else
        would move the vehicle without moving the clock. (A fleet steps its world once for
        every vehicle: `_apply` for each, one world step if any of them needs it, then
        `_finish_step` for each.)"""
        if not self._apply(command_n):
            self.client.step()
        self._finish_step()

    def _apply(self, command_n: RotorForces) -> bool:
        """The motors move toward `command_n`, and this step's force and torque act on the body:
        stepped at once by quadsim's own copy of PyBullet's step (quadsim.physics.free_flight)
        when the body is clear of everything (True), or applied in PyBullet for the world's next
        step (False)."""
        # the hot path: the arithmetic is one function (quadsim.vehicle.wrench), and PyBullet's
        # calls get positional arguments (parsing the keyword physicsClientId costs about a
        # quarter of a microsecond a call). The force and torque are turned into the world frame
        # with this step's attitude (the class's docstring says why).
        if self._reread:  # code of the user's own had the scene (client_id)
            self._reread = False
            self._read_kinematics(at_rest_before=False)
        motors = self.motors
        if len(command_n) != motors.motor_count:
            motors.check_count(command_n)
        air = self._linear_velocity
        if self._wind is not None:  # drag acts through the airspeed: velocity minus wind
            (vx, vy, vz), (wx, wy, wz) = air, self._wind.advance(self._position)
            air = (vx - wx, vy - wy, vz - wz)
        rotation, spin = self._rotation, self._angular_velocity
        if self._free and self._clear_of_scenery() and (not self._others or self._clear_of_others()):
            if self._from_pybullet is not None:  # PyBullet stepped it last: its state is the newer
                position, orientation, velocity, turn = self._from_pybullet
                self._body[0:STATE_SIZE] = (*position, *orientation, *velocity, *turn)
                self._from_pybullet = None
            try:
                self._after_step = self._clear_step(
                    *self._clear_constants, command_n, rotation, air, spin, self._position, self._linear_velocity
                )
            except (TypeError, ValueError):  # forces given as a list, or as integers: as a tuple of floats
                forces = float_tuple(command_n)
                self._after_step = self._clear_step(
                    *self._clear_constants, forces, rotation, air, spin, self._position, self._linear_velocity
                )
            self._flew_free = self._stale = True
            return True
        out, constants, hubs, thrusts, z = (
            self._wrench,
            self._airframe,
            self._hub_table,
            motors.thrusts,
            self._position[2],
        )
        try:
            self._airframe_wrench(constants, hubs, thrusts, command_n, rotation, z, air, spin, out)
        except (TypeError, ValueError):  # forces given as a list, or as integers: as a tuple of floats
            forces = float_tuple(command_n)
            self._airframe_wrench(constants, hubs, thrusts, forces, rotation, z, air, spin, out)
        self._flew_free = False
        if self._stale:
            self._pose_pybullet()
        fx, fy, fz, tx, ty, tz = out
        world, body, cid = pb.WORLD_FRAME, self.body_id, self._cid
        pb.applyExternalForce(body, -1, (fx, fy, fz), self._position, world, cid)
        pb.applyExternalTorque(body, -1, (tx, ty, tz), world, cid)
        return False

    @property
    def steps_itself(self) -> bool:
        """Whether quadsim may step the body itself while it is clear of everything (else PyBullet
        steps it every step: physics = "pybullet", a PyBullet window, a body with joints)."""
        return self._free

    def _clear_flight(self) -> tuple[Any, ...] | None:
        """What quadsim.sim.clear_flight.fly_clear takes of the body (`clear_flight_arguments`),
        or None when it may not be flown that way now: quadsim does not step it, it is not alone
        in its world, a wind blows on it, PyBullet holds its newer state, or the scenery's
        clearance, as measured, does not cover its next step (a step by the loop measures it
        again)."""
        if (
            not self._free
            or self._wind is not None
            or self._from_pybullet is not None
            or self._reread
            or not isinstance(self._scenery, tuple)
            or not self._within_slack()
        ):
            return None
        arguments = self.clear_flight_arguments
        apart, client = arguments[3], self.client
        if self._others and (  # every pair measured, and this vehicle within its slack of them
            len(client.apart) != len(client.bodies) or apart is _NOTHING_NEAR or not self._within_slack(apart)
        ):
            return None
        return arguments

    @property
    def clear_flight_arguments(self) -> tuple[Any, ...]:
        """The body's step's constants, base_link's state, the clearance kept from the scenery and
        the one from the other vehicles, as quadsim.sim.clear_flight takes them."""
        apart = self.client.apart.get(self, _NOTHING_NEAR) if self._others else _NOTHING_NEAR
        return self._clear_constants, self._kinematics, (self._clear_from, self._clear_slack_m), apart

    def _flown_clear(self, kinematics: Any, previous: Vec3) -> None:
        """After steps fly_clear took: base_link's state after them (`kinematics`, as
        base_link_state gives it) and the velocity before the last one."""
        self.client.near_others = None
        self._previous_velocity = previous
        self._flew_free = self._stale = True
        self._after_step = kinematics
        self._take_kinematics(kinematics)

    def _finish_step(self) -> None:
        """After the step: the vehicle's new pose and velocities."""
        self.client.near_others = None  # measured again for the next step
        self._previous_velocity = self._linear_velocity
        if self._flew_free:  # (a world step for the others may have moved PyBullet's copy)
            self._stale = True
            self._take_kinematics(self._after_step)
        else:
            self._read_kinematics(at_rest_before=False)

    def _pose_pybullet(self) -> None:
        """PyBullet's copy of the body brought up to quadsim's own steps (pose and velocities)."""
        b, body, cid = self._body, self.body_id, self._cid
        pb.resetBasePositionAndOrientation(body, (b[0], b[1], b[2]), (b[3], b[4], b[5], b[6]), cid)
        pb.resetBaseVelocity(body, (b[7], b[8], b[9]), (b[10], b[11], b[12]), cid)
        self._stale = False

    def _put(self, position_m: Vec3, orientation_xyzw: tuple[float, float, float, float]) -> None:
        """base_link's origin at `position_m`, in `orientation_xyzw` (PyBullet sets the base's
        inertial frame). A fleet's vehicles keep the contacts of the step they were asked in:
        one vehicle put back after a crash leaves the vehicle it hit that step its contact."""
        (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = matrix_from_quaternion(orientation_xyzw)
        ox, oy, oz = self._offset
        x, y, z = position_m
        at = (
            x + m00 * ox + m01 * oy + m02 * oz,
            y + m10 * ox + m11 * oy + m12 * oz,
            z + m20 * ox + m21 * oy + m22 * oz,
        )
        pb.resetBasePositionAndOrientation(self.body_id, at, orientation_xyzw, physicsClientId=self._cid)

    def _read_kinematics(self, at_rest_before: bool = True) -> None:
        """The body's state as PyBullet has it (newer than `_body`, which takes it if quadsim
        steps the body next), then base_link's origin's from it."""
        body, cid = self.body_id, self._cid
        position, orientation = pb.getBasePositionAndOrientation(body, cid)
        velocity, spin = pb.getBaseVelocity(body, cid)
        self._from_pybullet = (position, orientation, velocity, spin)
        self._stale = False
        # base_link's state from the base's and the velocity before the step (`at_rest_before`:
        # none, as after a reset or a placing)
        (ux, uy, uz), (ox, oy, oz) = self._previous_velocity, self._offset
        base = (*position, *orientation, *velocity, *spin)
        self._take_kinematics(
            self._base_link_state(*base, ox, oy, oz, ux, uy, uz, at_rest_before, self._gravity, self._inv_dt)
        )

    def _take_kinematics(self, kinematics: Any) -> None:
        """base_link's state as quadsim.physics.base_link.base_link_state gives it."""
        self._kinematics = kinematics
        (
            self._position,
            self._orientation,
            self._linear_velocity,
            self._angular_velocity,
            self._rotation,
            self._body_rates,
            self._specific_force,
        ) = kinematics
        known_matrix(self._orientation, self._rotation)  # the controller turns the same tuple

    @property
    def pose(self) -> tuple[Vec3, tuple[float, float, float, float]]:
        """base_link's origin and orientation after the last physics step (world frame)."""
        return self._position, self._orientation

    def state(self, step: int) -> VehicleState:
        """The vehicle's state after the last physics step, which the loop counts as `step`
        (body rates in base_link)."""
        return VehicleState(
            step,
            self._position,
            self._orientation,
            self._linear_velocity,
            self._body_rates,
            self.motors.thrusts_n,
            self._specific_force,
            self.wind_mps,
        )

    # --- lifetime ---------------------------------------------------------------------------

    @property
    def client_id(self) -> int:
        """The PyBullet client, for code of the user's own that reads the scene or changes it,
        with every vehicle in it posed where it flew to (quadsim.physics.client.WorldClient.posed).
        What is taken to change the scene: before its next step every vehicle takes its state
        from PyBullet (as that code may have set it) and looks at the world's bodies again (a
        body added from outside may move: PyBullet then steps the vehicle)."""
        if self._cid < 0:
            return self._cid
        cid = self.client.posed()
        for body in self.client.bodies:
            body._scenery = False
            body._reread = True  # and takes its state from PyBullet, where that code may have put it
        return cid

    @property
    def closed(self) -> bool:
        """Whether `close` was called."""
        return self._cid < 0

    def close(self) -> None:
        """Forget the world (its owner, the run's fleet, disconnects it)."""
        self._cid = -1
