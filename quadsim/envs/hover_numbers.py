"""Hover-v0's numbers of a vehicle's state: its observation, its reward, and whether it failed by
leaving the arena or tipping over. Compiled where the flight core is (quadsim.core.compiled).

One env (quadsim.envs.quad) and the PettingZoo fleet (quadsim.envs.fleet) call these functions
from Python, state by state. The vector env (quadsim.envs.vector) calls `hover_batch` once for
every env flown clear in its step. Both run the same arithmetic, so they agree to the bit.
"""

from __future__ import annotations

import math
from typing import Any

from quadsim.core.compiled import jit

#: the arena: a vehicle beyond ARENA_HALF_M of the origin in x or y, or above ARENA_TOP_M, is out
ARENA_HALF_M = 20.0
ARENA_TOP_M = 10.0
#: tilted further than this from level, a vehicle has tipped over
MAX_TILT_DEG = 80.0
_TILT_COS = math.cos(math.radians(MAX_TILT_DEG))
#: an observation's length: position, velocity, roll, pitch, yaw, body rates, target
HOVER_ROW = 15


@jit
def hover_row(position: Any, orientation: Any, velocity: Any, rates: Any, target: Any, row: Any) -> tuple[float, float]:
    """Hover-v0's observation of base_link's state before clipping, into `row` (HOVER_ROW
    numbers): position, velocity, roll, pitch and yaw (ZYX Euler angles, as
    VehicleState.roll_pitch_rad and yaw_rad give them), body rates, target. Returns roll and pitch."""
    x, y, z, w = orientation
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    sine = 2.0 * (w * y - z * x)
    pitch = math.asin(-1.0 if sine < -1.0 else (1.0 if sine > 1.0 else sine))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    row[0], row[1], row[2] = position
    row[3], row[4], row[5] = velocity
    row[6], row[7], row[8] = roll, pitch, yaw
    row[9], row[10], row[11] = rates
    row[12], row[13], row[14] = target[0], target[1], target[2]
    return roll, pitch


@jit
def hover_reward(position: Any, velocity: Any, target: Any) -> float:
    """Minus the distance to the target (m) and a little of the speed."""
    (x, y, z), (vx, vy, vz) = position, velocity
    dx, dy, dz = x - target[0], y - target[1], z - target[2]
    return -math.sqrt(dx * dx + dy * dy + dz * dz) - 0.1 * math.sqrt(vx * vx + vy * vy + vz * vz)


@jit
def outside_arena(position: Any) -> bool:
    """Whether a vehicle at `position` has left the arena."""
    x, y, z = position
    return abs(x) > ARENA_HALF_M or abs(y) > ARENA_HALF_M or z > ARENA_TOP_M


@jit
def tipped_over(roll: float, pitch: float) -> bool:
    """Whether a vehicle at this roll and pitch is tilted past MAX_TILT_DEG."""
    return math.cos(roll) * math.cos(pitch) < _TILT_COS


@jit
def hover_batch(
    rows: Any, at: int, targets: Any, which: Any, low: Any, high: Any, observations: Any, rewards: Any, failed: Any
) -> None:
    """For each env i with `which[i]` set: its observation (into observations[i], float32,
    clipped to `low` and `high` as HoverEnv clips it), reward and whether it failed. They are
    judged as QuadEnv.judge judges an agent step with no crash in it. rows[i][at:] holds
    base_link's state, as quadsim.sim.clear_flight.pack lays it out; targets[i] holds the env's
    target."""
    for i in range(len(which)):
        if not which[i]:
            continue
        k, observation = rows[i], observations[i]
        position = (k[at], k[at + 1], k[at + 2])
        velocity = (k[at + 7], k[at + 8], k[at + 9])
        orientation = (k[at + 3], k[at + 4], k[at + 5], k[at + 6])
        rates = (k[at + 22], k[at + 23], k[at + 24])
        target = targets[i]
        roll, pitch = hover_row(position, orientation, velocity, rates, target, observation)  # rounded to float32
        for j in range(HOVER_ROW):
            observation[j] = min(max(observation[j], low[j]), high[j])
        reward = hover_reward(position, velocity, target)
        failed[i] = outside_arena(position) or tipped_over(roll, pitch)
        rewards[i] = reward - 10.0 if failed[i] else reward
