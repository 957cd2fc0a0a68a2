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

from collections.abc import Sequence
from typing import Any

from quadsim.control.cascade_step import cascade_update
from quadsim.control.landing import landing_command
from quadsim.core.compiled import Floats, MutableFloats, jit
from quadsim.physics.free_flight import ClearConstants, clear_step

#: the command the cascade takes while the dead-man holds (quadsim.control.cascade)
_NO_COMMAND = (0.0, 0.0, 0.0, 0.0)


@jit
def fly_clear(
    steps: int,
    twist: tuple[float, float, float, float],
    height: bool,
    hold: bool,
    landing: Floats,
    k: Floats,
    rows: Sequence[Floats],
    s: MutableFloats,
    out: MutableFloats,
    control_dt_s: float,
    body: ClearConstants,
    kinematics: Any,
    clear_from: tuple[float, float, float],
    clear_slack_m: float,
    imu: bool,
    count: int,
    state_every: int,
    samples: Any,
    next_sample: int,
    gyro_bias: tuple[float, float, float],
    accel_bias: tuple[float, float, float],
) -> tuple[int, Any, tuple[float, float, float], int, tuple[float, float, float], tuple[float, float, float]]:
    """Up to `steps` steps of a flying vehicle under the gate's command `twist` (`height`: its z
    is a height; `hold`: the dead-man holds), each as the loop takes it: the landing layer's
    command (`landing`: its numbers), the cascade's update (gains `k`, mixer `rows`, state `s`,
    rotor forces into `out`) and the body's step clear of everything (quadsim.physics.free_flight.
    clear_step; `body`: its constants, the same every step). `kinematics`: base_link's state now,
    as clear_step gives it.
    Stops before a step the body's clearance does not cover (its travel since `clear_from` and
    two steps ahead at its speed, within `clear_slack_m`). With `imu`, the IMU noise's biases walk
    at each step count (from `count`, the loop's now) that is a multiple of `state_every`, taking
    the next of `samples` (quadsim.sensors.imu: from `next_sample`, the biases `gyro_bias` and
    `accel_bias`), as the loop's samples of it would, no one taking the reading; it stops before
    a step whose sample is not in `samples`. Returns the steps taken, base_link's state after
    them, the velocity before the last one, the next sample and the biases."""
    cx, cy, cz = clear_from
    step_s = body[8]  # the physics step (PhysicsWorld._clear_constants)
    position, orientation, velocity, spin, rotation, rates, specific = kinematics
    previous = velocity
    done = 0
    for _ in range(steps):
        x, y, z = position
        vx, vy, vz = velocity
        ahead = 2.0 * step_s * (abs(vx) + abs(vy) + abs(vz))
        if not abs(x - cx) + abs(y - cy) + abs(z - cz) + ahead < clear_slack_m:
            break
        count += 1
        sampled = imu and count % state_every == 0
        if sampled and next_sample >= len(samples):
            break
        fx, fy, fz, fw, flown_height, flown_hold, _, _ = landing_command(z, twist, height, hold, landing)
        wanted = _NO_COMMAND if flown_hold else (fx, fy, fz, fw)
        cascade_update(
            k, rows, s, position, rotation, velocity, rates, wanted, flown_height, flown_hold, control_dt_s, out
        )
        previous = velocity
        position, orientation, velocity, spin, rotation, rates, specific = clear_step(
            *body, out, rotation, velocity, spin, position, velocity
        )
        done += 1
        if sampled:
            n = samples[next_sample]
            gyro_bias = (gyro_bias[0] + n[3], gyro_bias[1] + n[4], gyro_bias[2] + n[5])
            accel_bias = (accel_bias[0] + n[9], accel_bias[1] + n[10], accel_bias[2] + n[11])
            next_sample += 1
    kinematics = (position, orientation, velocity, spin, rotation, rates, specific)
    return done, kinematics, previous, next_sample, gyro_bias, accel_bias
