"""Every section of `quadsim bench`, in the order `all` runs them: its name, what it measures and
the function that measures it (the bench command imports this module when it runs)."""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

from quadsim.apps.bench.autonomy import run_autonomy_bench
from quadsim.apps.bench.fleet import run_fleet_bench
from quadsim.apps.bench.flight import run_flight_core_bench
from quadsim.apps.bench.live import run_live_bench
from quadsim.apps.bench.ranging import run_ranging_bench
from quadsim.apps.bench.recording import run_recording_bench
from quadsim.apps.bench.replay import run_replay_bench
from quadsim.apps.bench.ros2 import run_ros2_bench
from quadsim.apps.bench.sweep import run_sweep_bench
from quadsim.apps.bench.window import run_interactive_bench


class Section(NamedTuple):
    what: str
    run: Callable[..., object]


SECTIONS: dict[str, Section] = {
    "flight": Section("the flight core", run_flight_core_bench),
    "recording": Section("cameras and recording", run_recording_bench),
    "ranging": Section("the range finder and the LiDAR: per reading, and in a recorded flight", run_ranging_bench),
    "window": Section("the teleop window headless", run_interactive_bench),
    "autonomy": Section("camera images in code, the Gymnasium envs", run_autonomy_bench),
    "replay": Section("playback and re-simulation", run_replay_bench),
    "live": Section("Foxglove streaming", run_live_bench),
    "ros2": Section("the ROS 2 bridge beside a real rclpy node", run_ros2_bench),
    "sweep": Section("a 64-run sweep on 1 worker, every core and Ray", run_sweep_bench),
    "fleet": Section("1 to 25 vehicles in one world", run_fleet_bench),
}
