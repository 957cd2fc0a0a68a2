"""The sensors an env's observation may add (`gymnasium.make("quadsim/Hover-v0", sensors=("range", "scan"))`,
TowerVision-v0's, `make_vec`'s, the PettingZoo fleet's but for "depth"): a depth image, the range
finder, a 2D or a 3D LiDAR scan, each a bounded Box of float32.

- "depth": (DEPTH.height_px, DEPTH.width_px) metres along the front camera's optical axis, rendered
  in SYNC mode at every agent step (the image of the step's last physics step); nothing drawn
  (inf, or beyond the far plane) reads DEPTH_FAR_M.
- "range": (1,) the downward range finder (the vehicle parameter file's [range]).
- "scan": (samples,) the 2D LiDAR's ring ([lidar]), beam 0 pointing backwards (-pi), counter-
  clockwise seen from above.
- "scan3d": (channels, samples) the 3D LiDAR's rings, lowest first, each as "scan"'s.

The range finder and the LiDAR are the simulator's own (SimConfig's range_finder and lidar),
sampled at their rates by loop taps whatever the agent does: an observation holds the newest
reading, at most one sensor period old (range finder 60 Hz, LiDAR 10 Hz with the quad's
parameters: up to 2 agent steps); a reset measures once, so the first observation has one.
Readings are REP 117 (+inf beyond the maximum range, -inf below the minimum); the observation
clips them into the Box: +inf to the maximum range, -inf to the minimum. Only one LiDAR: "scan"
or "scan3d".
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
from gymnasium import spaces

from quadsim.core.types import LidarMode, VehicleState
from quadsim.sensors.camera import CameraSpec
from quadsim.sensors.ranging import RangingSensor
from quadsim.sim.cameras import Cameras
from quadsim.sim.drone import Drone
from quadsim.sim.simulator import Simulator

#: the sensors an observation may add
SENSORS = ("depth", "range", "scan", "scan3d")
#: what "depth" reads where nothing is drawn (the depth camera's far plane)
DEPTH_FAR_M = 30.0
#: the depth camera: small, front, at the agent's rate (30 Hz)
DEPTH = CameraSpec("depth", "front_camera_link", 64, 48, rate_hz=30, far_m=DEPTH_FAR_M)


def sensor_names(sensors: Iterable[str] | str, cameras: bool = True) -> tuple[str, ...]:
    """`sensors` checked: a name or names of SENSORS, each once, at most one LiDAR; `cameras`
    False: not "depth" (a fleet's vehicles have no cameras)."""
    try:
        names = (sensors,) if isinstance(sensors, str) else tuple(sensors)
    except TypeError:
        raise ValueError(f"sensors: a name or names of {', '.join(SENSORS)}; got {sensors!r:.30}") from None
    for name in names:
        if name not in SENSORS:
            raise ValueError(f"sensors: unknown sensor {name!r:.30}; the choices are {', '.join(SENSORS)}")
    if len(set(names)) != len(names):
        raise ValueError(f"sensors: each sensor once, got {', '.join(names)}")
    if "scan" in names and "scan3d" in names:
        raise ValueError("sensors: one LiDAR, 'scan' (2D) or 'scan3d' (3D), not both")
    if "depth" in names and not cameras:
        raise ValueError("sensors: 'depth' is a single vehicle's (gymnasium.make); a fleet's are range, scan, scan3d")
    return names


def sim_options(names: tuple[str, ...]) -> dict[str, Any]:
    """SimConfig's fields for the sensors `names` carries (range_finder, lidar)."""
    lidar = LidarMode.PLANAR if "scan" in names else LidarMode.SPATIAL if "scan3d" in names else None
    return {"range_finder": "range" in names, "lidar": lidar}


class SensorObservation:
    """The readings of `names` (checked by sensor_names) on `drone` (made with sim_options), as
    entries of a Dict observation; "depth" needs `sim`, the drone's Simulator (the cameras are
    a Simulator's: a fleet's vehicles have none)."""

    def __init__(self, drone: Drone, names: tuple[str, ...], sim: Simulator | None = None) -> None:
        assert sim is not None or "depth" not in names  # sensor_names(cameras=False) says so
        self.names = names
        self._drone = drone
        self._ranging: dict[str, RangingSensor] = {}
        for name, sensor in (("range", drone.range_finder), ("scan", drone.lidar), ("scan3d", drone.lidar)):
            if name in names:
                assert sensor is not None  # made with sim_options
                self._ranging[name] = sensor
        lidar = drone.vehicle.lidar
        self._shapes = {"range": (1,), "scan": (lidar.samples,), "scan3d": (lidar.channels, lidar.samples)}
        self.cameras = Cameras(sim, (DEPTH,), depth=True) if sim is not None and "depth" in names else None

    def spaces(self) -> dict[str, spaces.Box]:
        """A Box for each sensor, by name."""
        boxes: dict[str, spaces.Box] = {}
        if self.cameras is not None:
            boxes["depth"] = spaces.Box(0.0, DEPTH_FAR_M, (DEPTH.height_px, DEPTH.width_px), np.float32)
        for name, sensor in self._ranging.items():
            boxes[name] = spaces.Box(sensor.min_range_m, sensor.max_range_m, self._shapes[name], np.float32)
        return boxes

    def reset(self) -> None:
        """After the simulator's reset: a reading of each sensor at step 0."""
        state = self._drone.state
        for sensor in self._ranging.values():
            if sensor.latest is None:
                sensor.measure(state)
        if self.cameras is not None:
            self.cameras.capture_now()

    def observe(self, state: VehicleState) -> dict[str, np.ndarray]:
        """Each sensor's newest reading at `state`, clipped into its Box, by name."""
        observation: dict[str, np.ndarray] = {}
        if self.cameras is not None:
            image = self.cameras.latest(DEPTH.name)
            assert image is not None and image.depth_m is not None and image.step == state.step  # SYNC
            observation["depth"] = np.minimum(image.depth_m, np.float32(DEPTH_FAR_M))
        for name, sensor in self._ranging.items():
            reading = sensor.latest
            assert reading is not None  # measured at reset
            low, high = np.float32(sensor.min_range_m), np.float32(sensor.max_range_m)
            observation[name] = np.clip(reading.ranges_m, low, high).reshape(self._shapes[name])
        return observation

    def close(self) -> None:
        if self.cameras is not None:
            self.cameras.close()
