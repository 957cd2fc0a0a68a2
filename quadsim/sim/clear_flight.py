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

from quadsim.control.cascade_step import cascade_update
from quadsim.control.landing import landing_command
from quadsim.core.compiled import Floats, jit
from quadsim.physics.free_flight import ClearConstants, clear_step

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
    (cx, cy, cz), clear_slack_m = clearance
    twist, height, hold = command
    imu, count, state_every = sampling
    k, rows, s, out, control_dt_s = cascade
    samples, next_sample, gyro_bias, accel_bias = walk
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
    return done, kinematics, previous, (samples, next_sample, gyro_bias, accel_bias)
