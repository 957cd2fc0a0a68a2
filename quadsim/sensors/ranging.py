"""The ranging sensors (range finder, LiDAR): beams from a mount on the body, one batched ray cast
a reading, seeded noise.

A range finder is one beam (the vehicle parameter file's [range]); a LiDAR is a ring of beams (2D)
or its rings (3D) ([lidar]; quadsim.sensors.beams lays them out). Each reading is the range along
every beam, REP 117 (quadsim.sensors.beams.scan_ranges), with Gaussian noise from the sensor's own
random stream (one draw a beam a reading), so a run's readings depend on its seed and steps alone.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from quadsim.core.kinematics import Vec3, matrix_from_quaternion, rotate
from quadsim.core.types import VehicleState
from quadsim.physics.client import WorldClient
from quadsim.sensors.beams import Ranges, in_range, scan_ranges, world_rays
from quadsim.sensors.rays import cast, cast_one
from quadsim.vehicle.params import LidarParams, RangeParams


class RangingSensor:
    """Beams from `mount_m` (base_link) along `directions` (n x 3 unit vectors, base_link's
    axes), ranges in [min_range_m, max_range_m]: `measure(state)` casts them for the vehicle's
    state; as a loop tap (`tap`) it hands each reading to its `sinks`."""

    def __init__(
        self,
        mount_m: Vec3,
        directions: np.ndarray,
        limits_m: tuple[float, float],
        noise_std_m: float,
        scene: WorldClient,
        own_body: tuple[int, float],
        seed: np.random.SeedSequence,
    ) -> None:
        """`scene`: the world the vehicle flies in; `own_body`: its body, which the beams do not
        see, and the radius about base_link that holds it (quadsim.sensors.rays.cast); `seed`: the
        noise's random stream; `noise_std_m` 0: the true ranges."""
        self.mount_m = mount_m
        self.directions = directions
        #: the one beam of a range finder, as a tuple (None: several beams)
        self._beam: Vec3 | None = tuple(directions[0]) if len(directions) == 1 else None
        self.min_range_m, self.max_range_m = limits_m
        self.noise_std_m = noise_std_m
        self._scene = scene
        self._own_body, self._reach_m = own_body
        self._seed = seed
        #: called with every reading the tap takes (the run's topic producer)
        self.sinks: list[Callable[[Ranges], None]] = []
        #: the newest reading (None before the first)
        self.latest: Ranges | None = None
        self.reset()

    def reseed(self, seed: np.random.SeedSequence) -> None:
        """The noise's random stream from `seed` from the next reset on."""
        self._seed = seed

    def reset(self) -> None:
        """Back to the start of the noise's stream."""
        self._rng = np.random.Generator(np.random.PCG64(self._seed))
        self.latest = None

    def measure(self, state: VehicleState) -> Ranges:
        """The reading for the vehicle at `state`."""
        if self._beam is not None:
            return self._measure_one(state)
        origin, directions = world_rays(state.position_m, state.orientation_xyzw, self.mount_m, self.directions)
        reach = (state.position_m, self._reach_m)
        distances = cast(self._scene, self._own_body, origin, directions, self.max_range_m, reach)
        noise = self._rng.standard_normal(len(distances)) * self.noise_std_m if self.noise_std_m else 0.0
        self.latest = Ranges(state.step, scan_ranges(distances, noise, self.min_range_m, self.max_range_m))
        return self.latest

    def _measure_one(self, state: VehicleState) -> Ranges:
        """`measure` of a single beam, in plain Python (about a fifth of the time)."""
        rotation = matrix_from_quaternion(state.orientation_xyzw)
        (px, py, pz), (mx, my, mz) = state.position_m, rotate(rotation, self.mount_m)
        direction = rotate(rotation, self._beam)  # type: ignore[arg-type]  # set when there is one beam
        reach = (state.position_m, self._reach_m)
        distance = cast_one(
            self._scene, self._own_body, (px + mx, py + my, pz + mz), direction, self.max_range_m, reach
        )
        noise = float(self._rng.standard_normal()) * self.noise_std_m if self.noise_std_m else 0.0
        reading = in_range(distance, noise, self.min_range_m, self.max_range_m)
        self.latest = Ranges(state.step, np.array([reading], dtype=np.float32))
        return self.latest

    def tap(self, state: VehicleState) -> None:
        """A loop tap: measure, and hand the reading on."""
        reading = self.measure(state)
        for sink in self.sinks:
            sink(reading)


def mounted(
    params: RangeParams | LidarParams,
    directions: np.ndarray,
    scene: WorldClient,
    own_body: tuple[int, float],
    seed: np.random.SeedSequence,
    noise: bool = True,
) -> RangingSensor:
    """The sensor of [range] or [lidar] (its mount, ranges and noise) casting along `directions`:
    the range finder's one beam, or the LiDAR's (`beam_directions`) (`noise` False: no noise)."""
    return RangingSensor(
        params.position_m,
        directions,
        (params.min_range_m, params.max_range_m),
        params.noise_std_m if noise else 0.0,
        scene,
        own_body,
        seed,
    )
