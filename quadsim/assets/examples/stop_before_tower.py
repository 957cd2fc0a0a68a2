"""Fly at the red tower and stop 1 m before it, seeing it with the 2D LiDAR alone.

    .venv/bin/python examples/stop_before_tower.py                  # straight at it, 6 m away
    .venv/bin/python examples/stop_before_tower.py --start-yaw-deg 5 --cruise 1.5

(from a clone; installed, `quadsim examples --copy my_examples` and `python my_examples/stop_before_tower.py`).

The program knows nothing of where the tower is: it climbs, then flies forward while the nearest
return in the LiDAR's sector ahead is farther than the stopping distance, slowing as it closes
in, and holds once it is there. The same loop as a ROS 2 node reads /quad/scan and publishes
/quad_cmd_twist (docs/ros2.md).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np

from quadsim import LidarMode, SimConfig, Simulator, StartPose, Twist, VehicleState, ZMode

CRUISE_ALTITUDE_M = 1.2
STOP_RANGE_M = 1.0  # from the LiDAR to the nearest thing ahead
SECTOR_RAD = math.radians(15.0)  # ahead: within this of the vehicle's heading, either side
SLOWING_PER_S = 0.8  # the forward speed per metre still to go


def nearest_ahead(ranges_m: np.ndarray, sector_rad: float = SECTOR_RAD) -> float:
    """The nearest return within `sector_rad` of straight ahead in a 2D scan (its beams from -pi,
    counter-clockwise, as sensor_msgs/LaserScan lays them out); +inf where nothing is there (REP
    117: +inf is no return, -inf something nearer than the LiDAR's minimum range)."""
    beams = len(ranges_m)
    angles = -math.pi + np.arange(beams) * (2.0 * math.pi / beams)
    ahead = ranges_m[np.abs(angles) <= sector_rad]
    if np.any(np.isneginf(ahead)):
        return 0.0
    finite = ahead[np.isfinite(ahead)]
    return float(finite.min()) if finite.size else math.inf


def command_for(nearest_m: float, state: VehicleState, cruise_mps: float) -> Twist:
    """Climb to the cruise altitude, then forward, slowing to a stop STOP_RANGE_M from what is ahead."""
    climb = max(-1.0, min(1.0, 1.5 * (CRUISE_ALTITUDE_M - state.position_m[2])))
    if state.position_m[2] < 0.8 * CRUISE_ALTITUDE_M:
        return Twist(linear_z=climb)
    forward = max(0.0, min(cruise_mps, SLOWING_PER_S * (nearest_m - STOP_RANGE_M)))
    return Twist(linear_x=forward, linear_z=climb)


@dataclass
class Flight:
    """Where the vehicle stopped, the nearest return ahead there, and whether it settled."""

    final: VehicleState
    nearest_m: float
    stopped: bool
    time_s: float
    crashed: bool


def stop_before_tower(start_yaw_rad: float = 0.0, cruise_mps: float = 1.0, max_s: float = 30.0) -> Flight:
    """Fly from the start facing `start_yaw_rad` until settled before what is ahead (or `max_s`)."""
    config = SimConfig(z_mode=ZMode.VELOCITY, start=StartPose(yaw_rad=start_yaw_rad), lidar=LidarMode.PLANAR)
    with Simulator(config) as sim:
        lidar = sim.drone.lidar
        assert lidar is not None  # asked for in the config
        every = config.rates.physics_hz // sim.vehicle.lidar.rate_hz  # a new scan each step of this loop
        settled, nearest = 0, math.inf
        sim.step(1)
        while sim.time_s < max_s:
            scan = lidar.latest
            nearest = nearest_ahead(scan.ranges_m) if scan is not None else math.inf
            state = sim.state
            command = command_for(nearest, state, cruise_mps)
            sim.send(command)
            speed = math.hypot(*state.linear_velocity_mps[:2])
            there = abs(nearest - STOP_RANGE_M) < 0.1 and speed < 0.05
            settled = settled + 1 if there else 0
            if settled >= sim.vehicle.lidar.rate_hz:  # a second stopped there
                break
            sim.step(every)
        crashed = any(e.kind.value == "crash" for e in sim.events)
        return Flight(sim.state, nearest, settled > 0, sim.time_s, crashed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--start-yaw-deg", type=float, default=0.0, help="heading at the start (0: facing the tower)")
    parser.add_argument("--cruise", type=float, default=1.0, metavar="M/S", help="forward speed far from it (1)")
    args = parser.parse_args()
    flight = stop_before_tower(math.radians(args.start_yaw_deg), args.cruise)
    x, y, z = flight.final.position_m
    what = "stopped" if flight.stopped else "gave up"
    print(f"{what} at x={x:.2f} y={y:.2f} z={z:.2f} m after {flight.time_s:.1f} s, {flight.nearest_m:.2f} m from it")


if __name__ == "__main__":
    main()
