"""Fly to the red tower by looking for it with the front camera. Find it in the image, turn until
it is centred, approach it, stop short of it.

    .venv/bin/python examples/fly_to_tower.py          # start facing away from it (yaw 150 deg)
    .venv/bin/python examples/fly_to_tower.py --start-yaw-deg 0 --save-frame tower.png

(from a clone; installed, `quadsim examples --copy my_examples` and `python my_examples/fly_to_tower.py`).

The program knows nothing of where the tower is: it sees red pixels in the front camera (a colour
threshold), turns toward the largest red blob, and reads the range from the depth image.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import cv2
import numpy as np

from quadsim import Cameras, CameraSpec, SimConfig, Simulator, StartPose, Twist, VehicleState, ZMode

#: a small front camera is plenty for a red tower, and cheap to render at the control rate
FRONT = CameraSpec("front", "front_camera_link", 160, 120, rate_hz=15)
CRUISE_ALTITUDE_M = 1.5
STOP_RANGE_M = 1.0  # stop this far from the tower's face
SEARCH_YAW_RATE = 0.6  # rad/s, counter-clockwise, while nothing red is in view


@dataclass(frozen=True)
class Blob:
    """The red blob in an image: where it is and how far."""

    bearing_rad: float  # left of the optical axis is positive (as yaw is)
    range_m: float  # median depth of its pixels
    box: tuple[int, int, int, int]  # x, y, width, height in pixels


def find_red_tower(rgb: np.ndarray, depth_m: np.ndarray, fx: float, cx: float) -> Blob | None:
    """The largest upright red blob (strongly red, taller than wide, 20 pixels or more), or None.
    Upright: the floor's texture has red specks too, and they are flat."""
    r, g, b = (rgb[:, :, i].astype(np.int16) for i in range(3))
    mask = ((r > 120) & (r > 2 * g) & (r > 2 * b)).astype(np.uint8)
    count, labels, stats, centroids = cv2.connectedComponentsWithStats(mask)
    upright = [
        i
        for i in range(1, count)
        if stats[i, cv2.CC_STAT_AREA] >= 20 and stats[i, cv2.CC_STAT_HEIGHT] > 1.2 * stats[i, cv2.CC_STAT_WIDTH]
    ]
    if not upright:
        return None
    tower = max(upright, key=lambda i: stats[i, cv2.CC_STAT_AREA])
    x, y, w, h = (int(v) for v in stats[tower, :4])
    bearing = -math.atan((centroids[tower][0] - cx) / fx)  # a pixel right of centre is to the right
    return Blob(bearing, float(np.median(depth_m[labels == tower])), (x, y, w, h))


def command_for(blob: Blob | None, state: VehicleState) -> Twist:
    """Hold the cruise altitude; search, turn toward the tower, then close in on it."""
    climb = max(-1.0, min(1.0, 1.5 * (CRUISE_ALTITUDE_M - state.position_m[2])))
    if blob is None:
        return Twist(linear_z=climb, angular_z=SEARCH_YAW_RATE)
    turn = max(-1.0, min(1.0, 2.0 * blob.bearing_rad))
    centred = abs(blob.bearing_rad) < 0.1
    forward = max(0.0, min(1.0, 0.6 * (blob.range_m - STOP_RANGE_M))) if centred else 0.0
    return Twist(linear_x=forward, linear_z=climb, angular_z=turn)


@dataclass
class Flight:
    """What happened: where the vehicle stopped, every state seen, the last image."""

    final: VehicleState
    states: list[VehicleState]
    last_rgb: np.ndarray
    last_blob: Blob | None
    arrived: bool
    time_s: float


def fly_to_tower(start_yaw_rad: float = 0.0, max_s: float = 40.0) -> Flight:
    """Fly from the start pose facing `start_yaw_rad` until stopped short of the tower (or `max_s`)."""
    config = SimConfig(z_mode=ZMode.VELOCITY, start=StartPose(yaw_rad=start_yaw_rad))
    with Simulator(config) as sim, Cameras(sim, (FRONT,), depth=True) as cameras:
        steps_per_frame = config.rates.physics_hz // FRONT.rate_hz
        states, settled, blob = [], 0, None
        while sim.time_s < max_s:
            image = cameras.latest("front")  # rendered for this very step (SYNC mode)
            assert image is not None and image.depth_m is not None  # SYNC, with depth: always there
            blob = find_red_tower(image.rgb, image.depth_m, image.info.fx, image.info.cx)
            state = sim.state
            states.append(state)
            command = command_for(blob, state)
            sim.send(command)
            speed = math.hypot(*state.linear_velocity_mps[:2])
            near = blob is not None and blob.range_m < STOP_RANGE_M + 0.1
            settled = settled + 1 if near and speed < 0.05 and command.linear_x < 0.05 else 0
            if settled >= FRONT.rate_hz:  # a second stopped in front of it
                break
            sim.step(steps_per_frame)
        last = cameras.latest("front")
        assert last is not None
        return Flight(sim.state, states, last.rgb, blob, settled >= FRONT.rate_hz, sim.time_s)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--start-yaw-deg", type=float, default=150.0, help="heading at the start (0: facing the tower)")
    parser.add_argument("--save-frame", help="write the last front-camera image, the tower boxed, to this PNG")
    args = parser.parse_args()
    flight = fly_to_tower(math.radians(args.start_yaw_deg))
    x, y, z = flight.final.position_m
    print(
        f"{'stopped' if flight.arrived else 'gave up'} at x={x:.2f} y={y:.2f} z={z:.2f} m after {flight.time_s:.1f} s"
    )
    if flight.last_blob is not None:
        print(f"tower {flight.last_blob.range_m:.2f} m ahead, {math.degrees(flight.last_blob.bearing_rad):+.1f} deg")
    if args.save_frame:
        bgr = cv2.cvtColor(flight.last_rgb, cv2.COLOR_RGB2BGR)
        if flight.last_blob is not None:
            bx, by, bw, bh = flight.last_blob.box
            cv2.rectangle(bgr, (bx, by), (bx + bw - 1, by + bh - 1), (0, 255, 0), 1)
        cv2.imwrite(args.save_frame, bgr)


if __name__ == "__main__":
    main()
