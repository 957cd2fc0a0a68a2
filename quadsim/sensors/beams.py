"""The ranging sensors' geometry and readings as plain numbers (no PyBullet): beams, frames, REP 117.

What the range finder (quadsim.sensors.range_finder) and the LiDAR (quadsim.sensors.lidar)
measure, and how their beams lie: a 2D scan is `samples` beams in the sensor's x-y plane, from
-pi (behind) counter-clockwise through 0 (ahead, +x) in steps of 2 pi / samples, as
sensor_msgs/LaserScan lays them out; a 3D scan has `channels` such rings at elevations spread
evenly over the vertical field of view, lowest first. A reading follows REP 117: -inf where
something is nearer than the minimum range, +inf where nothing is within the maximum.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from quadsim.core.kinematics import Quat, Vec3, matrix_from_quaternion
from quadsim.core.types import LidarMode
from quadsim.vehicle.params import LidarParams


class Ranges(NamedTuple):
    """One reading of a ranging sensor at simulation step `step`: each beam's range (float32,
    metres or +-inf, REP 117), in the order of its beams (a LiDAR's: `beam_directions`)."""

    step: int
    ranges_m: np.ndarray


def in_range(distance_m: float, noise_m: float, low_m: float, high_m: float) -> float:
    """A true distance (inf: no hit) as a reading (REP 117): -inf nearer than `low_m`, +inf beyond
    `high_m`, else the distance plus `noise_m`, kept within [low_m, high_m]."""
    if distance_m < low_m:
        return -math.inf
    if not distance_m <= high_m:
        return math.inf
    return min(max(distance_m + noise_m, low_m), high_m)


def scan_ranges(distances_m: np.ndarray, noise_m: np.ndarray | float, low_m: float, high_m: float) -> np.ndarray:
    """True distances (inf: no hit) as readings (float32), `in_range` beam by beam."""
    ranges = np.clip(distances_m + noise_m, low_m, high_m)
    ranges[distances_m < low_m] = -math.inf
    ranges[~(distances_m <= high_m)] = math.inf
    return ranges.astype(np.float32)


def beam_directions(params: LidarParams, mode: LidarMode) -> np.ndarray:
    """Unit vectors of every beam in the sensor's frame (rings x samples rows, ring after ring)."""
    azimuths = -math.pi + np.arange(params.samples) * (2.0 * math.pi / params.samples)
    if mode is LidarMode.PLANAR or params.channels == 1:
        elevations = np.zeros(1)
    else:
        half = params.vertical_fov_rad / 2.0
        elevations = np.linspace(-half, half, params.channels)
    e, a = np.meshgrid(elevations, azimuths, indexing="ij")
    return np.stack((np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)), axis=-1).reshape(-1, 3)


def xyz_points(directions: np.ndarray, ranges_m: np.ndarray) -> np.ndarray:
    """The returns of a scan as points (n x 3 float32, metres) in the sensor's frame; beams with
    no return (+-inf) are left out."""
    valid = np.isfinite(ranges_m)
    return (directions[valid] * ranges_m[valid, None]).astype(np.float32)


def world_rays(
    position_m: Vec3, orientation_xyzw: Quat, mount_m: Vec3, directions: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The sensor's origin in `world` and its beams' unit directions in `world`, for base_link at
    `position_m` turned by `orientation_xyzw`, the sensor at `mount_m` in base_link and
    `directions` (n x 3, unit vectors in base_link axes)."""
    rotation: np.ndarray = np.array(matrix_from_quaternion(orientation_xyzw), dtype=float)
    # written out, not `@`: OpenBLAS's sums differ in the last bit from one CPU to another, and
    # a scan that feeds a flight must read the same on every machine
    mx, my, mz = (float(v) for v in mount_m)
    origin = np.asarray(position_m, dtype=float) + (rotation[:, 0] * mx + rotation[:, 1] * my + rotation[:, 2] * mz)
    d = np.asarray(directions, dtype=float)
    return origin, d[:, 0:1] * rotation[:, 0] + d[:, 1:2] * rotation[:, 1] + d[:, 2:3] * rotation[:, 2]


def frame_rotation(direction: Vec3) -> Quat:
    """The quaternion (x, y, z, w) of the frame whose x axis points along the unit vector
    `direction` (a sensor_msgs/Range's frame: its beam along x), turned the shortest way from base_link."""
    dx, dy, dz = direction
    w = 1.0 + dx  # (x cross d, 1 + x . d), normalised: the half-angle form, exact at d = x
    if w < 1e-9:  # straight back: half a turn about z
        return (0.0, 0.0, 1.0, 0.0)
    x, y, z = 0.0, -dz, dy
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    return (x / norm, y / norm, z / norm, w / norm)
