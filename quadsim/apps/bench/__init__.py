"""The benchmark behind `quadsim bench`, a section per module: each figure as a rate and as a
ratio against a baseline measured in the same run (the machines are shared and noisy, so only
ratios taken together mean something).

`SECTIONS` maps `bench --section NAME` to (module, function, what it measures), run in this
order by `all`. A section's module is imported only when it runs.
"""

from __future__ import annotations

SECTIONS: dict[str, tuple[str, str, str]] = {
    "flight": ("quadsim.apps.bench.flight", "run_flight_core_bench", "the flight core"),
    "recording": ("quadsim.apps.bench.recording", "run_recording_bench", "cameras and recording"),
    "window": ("quadsim.apps.bench.window", "run_interactive_bench", "the teleop window headless"),
    "autonomy": ("quadsim.apps.bench.autonomy", "run_autonomy_bench", "camera images in code, the Gymnasium envs"),
    "replay": ("quadsim.apps.bench.replay", "run_replay_bench", "playback and re-simulation"),
    "live": ("quadsim.apps.bench.live", "run_live_bench", "Foxglove streaming"),
    "ros2": ("quadsim.apps.bench.ros2", "run_ros2_bench", "the ROS 2 bridge beside a real rclpy node"),
    "sweep": ("quadsim.apps.bench.sweep", "run_sweep_bench", "a 64-run sweep on 1 worker, every core and Ray"),
    "fleet": ("quadsim.apps.bench.fleet", "run_fleet_bench", "1 to 25 vehicles in one world"),
}
