"""Steps of a vehicle flying alone and clear of everything, one after another in one compiled call.

Between two moments the loop must act in Python (a driver's poll, a state to publish, a camera's
capture, a flight event, the dead-man firing), a vehicle that is flying, alone in its world and
clear of the scenery does the same few things each step: the landing layer's command, the
cascade's update, the motors and forces, quadsim's own step of the body and base_link's state
after it. `fly_clear` does those steps in one call, with the very functions the loop calls one
step at a time (quadsim.control.landing.landing_command, quadsim.control.cascade_step,
quadsim.physics.free_flight.clear_step), so the flight is the same to the bit; it stops before a
step that would bring the vehicle near the scenery (the clearance kept by the body, as
PhysicsWorld checks it), and the loop takes that step as usual. quadsim.sim.loop decides when it
applies (SimLoop.run).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from quadsim.control.cascade_step import cascade_update
from quadsim.control.landing import landing_command
from quadsim.core.compiled import Floats, jit, set_item, specialize, typed_list
from quadsim.core.types import Twist, ZMode
from quadsim.drivers.programmatic import ProgrammaticDriver
from quadsim.physics.free_flight import ClearConstants, clear_step
from quadsim.sensors.imu import walked

#: the command the cascade takes while the dead-man holds (quadsim.control.cascade)
_NO_COMMAND = (0.0, 0.0, 0.0, 0.0)


@jit
def fly_clear(
    steps: int,
    command: tuple[tuple[float, float, float, float], bool, bool],
    landing: Floats,
    cascade: Any,
    body: ClearConstants,
    kinematics: Any,
    clearance: tuple[tuple[float, float, float], float],
    sampling: tuple[bool, int, int],
    walk: Any,
) -> tuple[int, Any, tuple[float, float, float], Any]:
    """Up to `steps` steps of a flying vehicle under the gate's `command` (its twist, whether its
    z is a height, whether the dead-man holds), each as the loop takes it: the landing layer's
    command (`landing`: its numbers), the cascade's update (`cascade`: its gains, mixer rows,
    state and rotor forces out, CascadeController.compiled_state, and the control step) and the body's step clear of
    everything (quadsim.physics.free_flight.clear_step; `body`: its constants). `kinematics`:
    base_link's state now, as clear_step gives it. Stops before a step the body's `clearance`
    does not cover (its travel since where it was measured, and two steps ahead at its speed,
    within the slack). With `sampling` (the IMU sampled, the loop's step count now, the steps
    between two samples), the IMU noise's biases walk at each step count that is a sample's, taking
    the next sample of `walk` (quadsim.sensors.imu.ImuNoise.walk: the samples, the next one's
    index, the gyro's and the accelerometer's biases), as the loop's samples of it would, no one
    taking the reading; it stops before a step whose sample is not there. Returns the steps
    taken, base_link's state after them, the velocity before the last one and the walk after."""
    twist, height, hold = command
    imu, count, state_every = sampling
    samples, next_sample, gyro_bias, accel_bias = walk
    step_s = body[8]  # the physics step (PhysicsWorld._clear_constants)
    previous = kinematics[2]
    done = 0
    for _ in range(steps):
        if not within(kinematics, clearance, step_s):
            break
        count += 1
        sampled = imu and count % state_every == 0
        if sampled and next_sample >= len(samples):
            break
        previous = kinematics[2]
        kinematics = step_once(twist, height, hold, landing, cascade, body, kinematics)
        done += 1
        if sampled:
            gyro_bias, accel_bias = walked(samples[next_sample], gyro_bias, accel_bias)
            next_sample += 1
    return done, kinematics, previous, (samples, next_sample, gyro_bias, accel_bias)


@jit
def within(kinematics: Any, clearance: tuple[tuple[float, float, float], float], step_s: float) -> bool:
    """Whether the vehicle at `kinematics` is within a `clearance` measured before (where, and the
    slack then): its travel since, and two steps ahead at its speed (1-norms), short of the slack."""
    (x, y, z), (vx, vy, vz) = kinematics[0], kinematics[2]
    (cx, cy, cz), slack = clearance
    ahead = 2.0 * step_s * (abs(vx) + abs(vy) + abs(vz))
    return abs(x - cx) + abs(y - cy) + abs(z - cz) + ahead < slack


@jit
def step_once(
    twist: tuple[float, float, float, float],
    height: bool,
    hold: bool,
    landing: Floats,
    cascade: Any,
    body: ClearConstants,
    kinematics: Any,
) -> Any:
    """One step of a flying vehicle clear of everything: the landing layer's command, the
    cascade's update and the body's step; base_link's state after it."""
    position, _, velocity, spin, rotation, rates, _ = kinematics
    k, rows, s, out, control_dt_s = cascade
    fx, fy, fz, fw, flown_height, flown_hold, _, _ = landing_command(position[2], twist, height, hold, landing)
    wanted = _NO_COMMAND if flown_hold else (fx, fy, fz, fw)
    cascade_update(k, rows, s, position, rotation, velocity, rates, wanted, flown_height, flown_hold, control_dt_s, out)
    return clear_step(*body, out, rotation, velocity, spin, position, velocity)


@jit
def fly_clear_together(steps: int, vehicles: Any, count: int, state_every: int) -> int:
    """Up to `steps` steps of a fleet's vehicles together, each step of each vehicle as
    `fly_clear` takes it. `vehicles`: for each, its landing numbers, cascade, body constants, IMU
    samples and its `now` (quadsim.sim.fleet's QuietFleet: the command, whether its z is a height,
    whether it holds, whether its IMU noise walks, its kinematics, its clearances from the
    scenery and from the others, its walk; written before, read after). Every vehicle's
    clearances (and IMU sample) are checked before any of them takes a step, so all stop before
    the same one. Returns the steps taken; each `now` then holds the state after them and the
    velocity before the last one."""
    done = 0
    for _ in range(steps):
        count += 1
        sampled = count % state_every == 0
        clear = True
        for vehicle in vehicles:
            now = vehicle[4]
            kinematics = unpacked(now[NOW_KINEMATICS:])
            step_s = vehicle[2][8]
            scenery = ((now[NOW_CLEAR], now[NOW_CLEAR + 1], now[NOW_CLEAR + 2]), now[NOW_CLEAR + 3])
            others = ((now[NOW_APART], now[NOW_APART + 1], now[NOW_APART + 2]), now[NOW_APART + 3])
            if not (within(kinematics, scenery, step_s) and within(kinematics, others, step_s)) or (
                now[NOW_FLAGS + 2] != 0.0 and sampled and now[NOW_WALK] >= len(vehicle[3])
            ):
                clear = False
        if not clear:
            break
        for vehicle in vehicles:
            now = vehicle[4]
            kinematics = unpacked(now[NOW_KINEMATICS:])
            twist = (now[0], now[1], now[2], now[3])
            height, hold = now[NOW_FLAGS] != 0.0, now[NOW_FLAGS + 1] != 0.0
            now[NOW_PREVIOUS], now[NOW_PREVIOUS + 1], now[NOW_PREVIOUS + 2] = kinematics[2]
            pack(now[NOW_KINEMATICS:], step_once(twist, height, hold, vehicle[0], vehicle[1], vehicle[2], kinematics))
            if now[NOW_FLAGS + 2] != 0.0 and sampled:
                w = now[NOW_WALK:]
                gyro, accel = walked(vehicle[3][int(w[0])], (w[1], w[2], w[3]), (w[4], w[5], w[6]))
                w[0] += 1.0
                w[1], w[2], w[3] = gyro
                w[4], w[5], w[6] = accel
        done += 1
    return done


@jit
def fly_clear_apart(
    steps: Any, vehicles: Any, counts: Any, flying: Any, state_every: int, fresh: bool, flown: Any
) -> tuple[int, int]:
    """Up to steps[i] steps of each vehicle i whose `flying` is set, each alone in a world of its
    own (a vector env's envs), each vehicle's steps as `fly_clear` takes them. `vehicles`: as
    fly_clear_together takes them, each `now` a row of QuietApart's (APART_* past the NOW_*
    columns); counts[i]: its loop's step count, moved on by the steps it takes. A vehicle stops
    where its clearance ends or its IMU samples do, the others go on; flown[i]: the steps it
    took (its `now` changed only if some). `fresh`: at the start of an agent step, whose command
    each vehicle takes with its first step (unless its gate would clamp it: then it takes no
    step, flown[i] is -1). Returns how many stopped short and how many were not flown for
    their command."""
    short = odd = 0
    for i in range(len(vehicles)):
        flown[i] = 0
        if not flying[i]:
            continue
        landing, cascade, constants, samples, now = vehicles[i]
        if fresh:
            now[APART_STARTED], now[APART_CLAMPED] = counts[i], 0.0
            vx, vy, vz, wz = now[0], now[1], now[2], now[3]
            limits = now[APART_LIMITS:]
            if vx * vx + vy * vy > limits[0] or vz > limits[1] or vz < limits[2] or abs(wz) > limits[3]:
                flown[i] = -1
                odd += 1
                continue
        command = ((now[0], now[1], now[2], now[3]), now[NOW_FLAGS] != 0.0, now[NOW_FLAGS + 1] != 0.0)
        clearance = ((now[NOW_CLEAR], now[NOW_CLEAR + 1], now[NOW_CLEAR + 2]), now[NOW_CLEAR + 3])
        w = now[NOW_WALK:]
        walk = (samples, int(w[0]), (w[1], w[2], w[3]), (w[4], w[5], w[6]))
        sampling = (now[NOW_FLAGS + 2] != 0.0, counts[i], state_every)
        kinematics = unpacked(now[NOW_KINEMATICS:])
        done, kinematics, previous, walk = fly_clear(
            steps[i], command, landing, cascade, constants, kinematics, clearance, sampling, walk
        )
        if done:
            pack(now[NOW_KINEMATICS:], kinematics)
            now[NOW_PREVIOUS], now[NOW_PREVIOUS + 1], now[NOW_PREVIOUS + 2] = previous
            w[0] = walk[1]
            w[1], w[2], w[3] = walk[2]
            w[4], w[5], w[6] = walk[3]
            if counts[i] == now[APART_STARTED]:  # the agent step's first step: its command taken
                given = now[APART_GIVEN:]
                taken = now[APART_TAKEN:]
                taken[0], taken[1], taken[2], taken[3] = given[0], given[1], given[2], given[3]
                now[APART_TAKEN_AT] = now[APART_STARTED]
                now[APART_CLAMPS] += now[APART_CLAMPED]
            counts[i] += done
        flown[i] = done
        if done < steps[i]:
            short += 1
    return short, odd


#: where a fleet vehicle's `now` (fly_clear_together) holds what: the twist (0-3), the flags
#: (height, hold, IMU walking), base_link's state (`pack`), the clearance from the scenery (where
#: and the slack), the one from the others, the velocity before the last step, the walk (the next
#: sample, the gyro's and the accelerometer's biases)
NOW_FLAGS, NOW_KINEMATICS, NOW_CLEAR, NOW_APART, NOW_PREVIOUS, NOW_WALK, NOW_SIZE = 4, 7, 35, 39, 43, 46, 53


def kinematics_of(values: list[float]) -> Any:
    """base_link's state from the values of a row `pack` filled, as Python floats (the loop's own state)."""
    return getattr(unpacked, "py_func", unpacked)(values)


class QuietFleet:
    """A fleet's vehicles as fly_clear_together takes them, in a list made once (each vehicle's
    constant parts and its `now`, written before each call and read after), remade for a
    vehicle only when its controller or its IMU noise's block of samples changes."""

    def __init__(self, loops: list[Any]) -> None:
        self.loops = loops
        self._now = [np.zeros(NOW_SIZE) for _ in loops]
        parts = [loop.quiet_vehicle(loop.physics.clear_flight_arguments) for loop in loops]
        self._made = [(loop.landing.controller, part[8][0]) for loop, part in zip(loops, parts)]
        self._vehicles = typed_list((part[1], part[2], part[3], part[8][0], now) for part, now in zip(parts, self._now))
        self._fly: Any = specialize(fly_clear_together, 0, self._vehicles, 0, 1)  # compiled as the fleet is built

    def fly(self, steps: int) -> int:
        """Up to `steps` steps of every vehicle in one call, where each one's next steps are quiet
        (SimLoop._quiet_steps) and each is clear of the scenery and of the others; the steps
        taken (0: not now)."""
        loops = self.loops
        quiet = steps
        for loop in loops:
            quiet = loop._quiet_steps(quiet)
            if not quiet:
                return 0
        for i, loop in enumerate(loops):
            body = loop.physics._clear_flight()
            if body is None:
                return 0
            (twist, height, hold), landing, cascade, constants, kinematics, clearance, apart, imu, walk = (
                loop.quiet_vehicle(body)
            )
            samples, next_sample, gyro_bias, accel_bias = walk
            made = self._made[i]
            if made[0] is not loop.landing.controller or made[1] is not samples:
                set_item(self._vehicles, i, (landing, cascade, constants, samples, self._now[i]))
                self._made[i] = (loop.landing.controller, samples)
            position, orientation, velocity, spin, (r0, r1, r2), rates, specific = kinematics
            self._now[i][:] = (
                *twist, height, hold, imu, *position, *orientation, *velocity, *spin, *r0, *r1, *r2, *rates,
                *specific, *clearance[0], clearance[1], *apart[0], apart[1], 0.0, 0.0, 0.0, next_sample,
                *gyro_bias, *accel_bias,
            )  # fmt: skip
        flown = int(self._fly(quiet, self._vehicles, loops[0].step_count, loops[0]._state_every))
        for loop, now in zip(loops, self._now if flown else ()):
            values = now.tolist()
            walked = (values[NOW_WALK], values[NOW_WALK + 1 : NOW_WALK + 4], values[NOW_WALK + 4 : NOW_WALK + 7])
            previous = tuple(values[NOW_PREVIOUS : NOW_PREVIOUS + 3])
            loop.took_quiet_steps(flown, kinematics_of(values[NOW_KINEMATICS:NOW_CLEAR]), previous, walked)
        return flown


#: where a QuietApart row holds, past a fleet vehicle's `now` (NOW_*): the limits of its gate (the
#: horizontal speed squared, a little under it, the climb and descent rates as the z range, the
#: yaw rate), the command given this agent step (as given to the gate), the command last taken
#: (as given), the step it was taken at (-1: none taken in the rows), the step this agent step
#: started at, whether the gate clamped this step's command, and how many taken were clamped
APART_LIMITS, APART_GIVEN, APART_TAKEN, APART_TAKEN_AT = NOW_SIZE, NOW_SIZE + 4, NOW_SIZE + 8, NOW_SIZE + 12
APART_STARTED, APART_CLAMPED, APART_CLAMPS, APART_SIZE = NOW_SIZE + 13, NOW_SIZE + 14, NOW_SIZE + 15, NOW_SIZE + 16


class QuietApart:
    """Vehicles each alone in a world of its own, each given one command at the start of each
    agent step of `steps` steps (a programmatic driver's, polled at the input rate): a vector
    env's envs. Those flying clear of everything are kept in rows of one array between agent
    steps and flown together in one call (fly_clear_apart). Their loops, gates and drivers are
    left as they were until `leave` brings them up to date: the state is the same to the bit
    as if each loop had flown its own steps."""

    def __init__(self, loops: list[Any], steps: int) -> None:
        self.loops = loops
        self.steps = steps
        n = len(loops)
        self.rows = np.zeros((n, APART_SIZE))
        #: each loop's step count as flown here
        self.counts = np.zeros(n, np.int64)
        #: which vehicles are in the rows (their loops are behind)
        self.inside = np.zeros(n, np.bool_)
        #: the steps each took in the last `fly`
        self.flown = np.zeros(n, np.int64)
        self._all_steps = np.full(n, steps, np.int64)
        self._state_every = loops[0]._state_every
        parts = [loop.quiet_vehicle(loop.physics.clear_flight_arguments) for loop in loops]
        self._parts = [(p[1], p[2], p[3]) for p in parts]
        self._made = [(loop.landing.controller, part[8][0]) for loop, part in zip(loops, parts)]
        self._vehicles = typed_list((p[1], p[2], p[3], p[8][0], self.rows[i]) for i, p in enumerate(parts))
        self._fly: Any = specialize(
            fly_clear_apart, self.flown, self._vehicles, self.counts, self.inside, 1, True, self.flown
        )  # compiled as the envs are built

    def enter(self, i: int) -> bool:
        """Vehicle i into the rows, if its next agent step can be flown there: at the start of
        one, flying clear of everything with nothing else to do in Python (SimLoop._quiet_steps),
        commanded by a programmatic driver in velocity z-mode (the limits `fly` checks commands
        against are a climb rate's), with no goal and a dead-man that cannot fire in it."""
        loop = self.loops[i]
        steps, gate = self.steps, loop.gate
        if (
            self.inside[i]
            or gate.z_mode is not ZMode.VELOCITY
            or loop.step_count % loop._input_every
            or not isinstance(loop.driver, ProgrammaticDriver)
            or loop.pilot.goal is not None
            or loop._next_goal is not None
            or (gate.timeout_steps is not None and gate.timeout_steps < steps)
            or loop._quiet_steps(steps) != steps
        ):
            return False
        physics = loop.physics
        body = physics._clear_flight()
        if body is None or physics._others:
            return False
        _, landing, cascade, constants, kinematics, clearance, _, imu, walk = loop.quiet_vehicle(body)
        samples, next_sample, gyro_bias, accel_bias = walk
        self._parts[i] = (landing, cascade, constants)
        self._take_samples(i, samples)
        position, orientation, velocity, spin, (r0, r1, r2), rates, specific = kinematics
        limits = gate.limits
        self.rows[i] = (
            0.0, 0.0, 0.0, 0.0, False, False, imu, *position, *orientation, *velocity, *spin, *r0, *r1, *r2,
            *rates, *specific, *clearance[0], clearance[1], 0.0, 0.0, 0.0, 0.0,
            *physics.velocity_before_step_mps, next_sample, *gyro_bias, *accel_bias,
            limits.max_horizontal_speed_mps**2 * (1.0 - 1e-9), limits.max_climb_rate_mps,
            -limits.max_descent_rate_mps, limits.max_yaw_rate_radps,
            0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0,
        )  # fmt: skip
        self.counts[i] = loop.step_count
        self.inside[i] = True
        return True

    def fly(self, commands: np.ndarray) -> np.ndarray:
        """Each vehicle in the rows given its row of `commands` (forward, left, climb and yaw
        rate, finite) at the start of its agent step, as its gate would take it (clamped by the
        gate's own arithmetic where it would be), and flown up to `steps` steps; the steps each
        took. A vehicle whose clearance ends at once takes none, nor its command: `leave` it and
        fly its agent step in Python."""
        inside, rows, steps, flown = self.inside, self.rows, self.steps, self.flown
        rows[:, 0:4] = commands
        rows[:, APART_GIVEN : APART_GIVEN + 4] = commands
        short, odd = self._fly(self._all_steps, self._vehicles, self.counts, inside, self._state_every, True, flown)
        if not (short or odd):
            return flown
        total = np.maximum(flown, 0)
        pending = inside & (total < steps)
        for i in np.flatnonzero(pending).tolist():
            if flown[i] < 0:  # clamped as the gate clamps it, then flown
                x, y, z, w = commands[i].tolist()
                given = Twist(linear_x=x, linear_y=y, linear_z=z, angular_z=w)
                taken = self.loops[i].gate.clamp(given)
                rows[i, 0:4] = (taken.linear_x, taken.linear_y, taken.linear_z, taken.angular_z)
                rows[i, APART_CLAMPED] = taken != given
            else:
                pending[i] = self._resume(i)
        while pending.any():  # on where it can, from where it stopped
            self._fly(steps - total, self._vehicles, self.counts, pending, self._state_every, False, flown)
            total += flown
            pending &= total < steps
            for i in np.flatnonzero(pending).tolist():
                pending[i] = self._resume(i)
        flown[:] = total
        return flown

    def _resume(self, i: int) -> bool:
        """Whether vehicle i, stopped short, may fly on: the IMU noise's next block of samples
        drawn where the block ran out (as ImuNoise.measure draws it), or its clearance measured
        again where it ran out (as PhysicsWorld._clear_of_scenery measures it); False where the
        vehicle is near something (its loop then takes the step: `leave` it first)."""
        loop, row = self.loops[i], self.rows[i]
        walk = row[NOW_WALK : NOW_WALK + 7].tolist()
        sampled = row[NOW_FLAGS + 2] != 0.0 and (int(self.counts[i]) + 1) % self._state_every == 0
        if sampled and walk[0] >= len(self._made[i][1]):
            imu = loop.imu
            imu.walked(int(walk[0]), tuple(walk[1:4]), tuple(walk[4:7]))
            imu.refill()
            self._take_samples(i, imu.walk[0])
            row[NOW_WALK] = 0.0
            return True
        kinematics = row[NOW_KINEMATICS : NOW_KINEMATICS + 10].tolist()
        position = (kinematics[0], kinematics[1], kinematics[2])
        clear, slack = loop.physics.clearance_at(position, kinematics[7:10])
        if clear:
            row[NOW_CLEAR : NOW_CLEAR + 4] = (*position, slack)
        return bool(clear)

    def _take_samples(self, i: int, samples: np.ndarray) -> None:
        """Vehicle i's entry of the list the compiled call takes, made again if its controller
        or its block of IMU samples is not the one it was made with."""
        loop = self.loops[i]
        if self._made[i][0] is not loop.landing.controller or self._made[i][1] is not samples:
            set_item(self._vehicles, i, (*self._parts[i], samples, self.rows[i]))
            self._made[i] = (loop.landing.controller, samples)

    def leave(self, i: int) -> None:
        """Vehicle i out of the rows, its loop, gate and driver brought up to date."""
        if not self.inside[i]:
            return
        self.inside[i] = False
        loop, values = self.loops[i], self.rows[i].tolist()
        if values[APART_TAKEN_AT] >= 0:
            x, y, z, w = values[APART_TAKEN : APART_TAKEN + 4]
            given = Twist(linear_x=x, linear_y=y, linear_z=z, angular_z=w)
            loop.driver.send(given)
            gate = loop.gate
            clamped = gate.clamped_count + int(values[APART_CLAMPS])
            gate.receive(given, int(values[APART_TAKEN_AT]))
            gate.clamped_count = clamped
        flown = int(self.counts[i]) - loop.step_count
        if flown:
            physics = loop.physics
            physics._clear_from, physics._clear_slack_m = (
                tuple(values[NOW_CLEAR : NOW_CLEAR + 3]),
                values[NOW_CLEAR + 3],
            )
            walked = (values[NOW_WALK], values[NOW_WALK + 1 : NOW_WALK + 4], values[NOW_WALK + 4 : NOW_WALK + 7])
            previous = tuple(values[NOW_PREVIOUS : NOW_PREVIOUS + 3])
            loop.took_quiet_steps(flown, kinematics_of(values[NOW_KINEMATICS:NOW_CLEAR]), previous, walked)


#: base_link's state packed in a row: position, orientation, velocity, spin, rotation, body rates, specific force
KINEMATICS_SIZE = 28


@jit
def pack(row: Any, kinematics: Any) -> None:
    """base_link's state (as clear_step gives it) into `row`."""
    (px, py, pz), (qx, qy, qz, qw), (vx, vy, vz), (wx, wy, wz), rotation, (rx, ry, rz), (fx, fy, fz) = kinematics
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = rotation
    row[0], row[1], row[2], row[3], row[4], row[5], row[6] = px, py, pz, qx, qy, qz, qw
    row[7], row[8], row[9], row[10], row[11], row[12] = vx, vy, vz, wx, wy, wz
    row[13], row[14], row[15], row[16], row[17], row[18], row[19], row[20], row[21] = (
        m00,
        m01,
        m02,
        m10,
        m11,
        m12,
        m20,
        m21,
        m22,
    )
    row[22], row[23], row[24], row[25], row[26], row[27] = rx, ry, rz, fx, fy, fz


@jit
def unpacked(row: Any) -> Any:
    """base_link's state from a row `pack` filled, as clear_step gives it."""
    rotation = ((row[13], row[14], row[15]), (row[16], row[17], row[18]), (row[19], row[20], row[21]))
    return (
        (row[0], row[1], row[2]),
        (row[3], row[4], row[5], row[6]),
        (row[7], row[8], row[9]),
        (row[10], row[11], row[12]),
        rotation,
        (row[22], row[23], row[24]),
        (row[25], row[26], row[27]),
    )
