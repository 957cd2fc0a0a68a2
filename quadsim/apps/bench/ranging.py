"""`bench --section ranging`: what the range finder and the LiDAR cost.

- per reading, hovering at 2 m in the default world: the range finder's one beam, a 2D scan (one
  ring) and a 16-channel 3D scan, each against a bare `rayTestBatch` of the same rays measured in
  the same run (the baseline: PyBullet's own cost, which no Python around it can go below);
- the real-time factor of the square scenario flown headless and recorded (no cameras) with the
  range finder, a 10 Hz 2D scan and a 10 Hz 16-channel 3D scan, against the same flight recorded
  without them (the baseline), and what each adds to the recording's size.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from quadsim.apps.bench.figures import best_of
from quadsim.apps.bench.recording import recorded_flight
from quadsim.core.types import LidarMode, Twist, ZMode
from quadsim.physics.pybullet_quiet import pb
from quadsim.sensors.beams import world_rays
from quadsim.sensors.ranging import RangingSensor
from quadsim.sim.config import SimConfig
from quadsim.sim.simulator import Simulator


def _best(run: Callable[[], object], count: int, repeats: int = 3) -> float:
    """Seconds per call of `run`, best of `repeats` runs of `count` calls."""
    return best_of(repeats, count, lambda calls: [run() for _ in range(calls)])


def reading_cost(lidar: LidarMode | None, count: int = 20) -> tuple[float, float, int]:
    """A sensor's (s per reading, s per bare rayTestBatch of its rays, rays), hovering at 2 m:
    the range finder (`lidar` None) or the LiDAR making that scan."""
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT, range_finder=lidar is None, lidar=lidar)) as sim:
        sim.send(Twist())  # hold 2.0 m
        sim.run_for(3.0)
        sensor: RangingSensor | None = sim.drone.range_finder if lidar is None else sim.drone.lidar
        assert sensor is not None
        state = sim.state
        origin, directions = world_rays(state.position_m, state.orientation_xyzw, sensor.mount_m, sensor.directions)
        starts = np.ascontiguousarray(np.broadcast_to(origin, directions.shape))
        ends = origin + directions * sensor.max_range_m
        cid = sim.scene_client.posed()
        bare = _best(lambda: pb.rayTestBatch(starts, ends, physicsClientId=cid), count)
        return _best(lambda: sensor.measure(state), count), bare, len(directions)


def run_ranging_bench(out: Callable[[str], None] = print, flight_s: float = 20.0) -> None:
    out("quadsim bench: the range finder and the LiDAR (PyBullet ray casts), quadsim_x's [range] and [lidar]")
    out(f"  per reading, hovering at 2 m            {'rays':>6s} {'ms':>8s} {'bare rayTestBatch':>18s} {'ratio':>7s}")
    for what, lidar in (
        ("range finder", None),
        ("2D scan", LidarMode.PLANAR),
        ("3D scan, 16 channels", LidarMode.SPATIAL),
    ):
        cost, bare, rays = reading_cost(lidar)
        out(f"  {what:38s} {rays:6d} {cost * 1e3:8.3f} {bare * 1e3:15.3f} ms {cost / bare:6.2f}x")
    flights = {
        "no ranging sensor (baseline)": SimConfig(),
        "range finder (60 Hz)": SimConfig(range_finder=True),
        "2D LiDAR, 10 Hz, 360 beams": SimConfig(lidar=LidarMode.PLANAR),
        "3D LiDAR, 10 Hz, 16 x 360 beams": SimConfig(lidar=LidarMode.SPATIAL),
    }
    figures = {
        what: recorded_flight(flight_s, cameras=False, workers=0, config=config) for what, config in flights.items()
    }
    base = figures["no ranging sensor (baseline)"]
    out(
        f"  headless flight ('square', {flight_s:.0f} s sim), recorded, no cameras {'x real time':>12s} {'x baseline':>11s} {'MB/min':>8s}"
    )
    for what, figure in figures.items():
        out(
            f"  {what:58s} {figure.real_time_factor:11.1f}x {figure.real_time_factor / base.real_time_factor:10.2f}x "
            f"{figure.size_bytes / flight_s * 60 / 1e6:8.2f}"
        )
    spatial = figures["3D LiDAR, 10 Hz, 16 x 360 beams"].size_bytes - base.size_bytes
    out(
        f"  an hour of 10 Hz 16-channel scans: {spatial / flight_s * 3600 / 1e9:.2f} GB in the recording (zstd chunks); "
        f"at most {16 * 360 * 12 * 10 * 3600 / 1e9:.2f} GB of points before compression (every beam a return)"
    )
