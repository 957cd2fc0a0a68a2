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
