"""The ROS 2 bridge beside a real rclpy node in its own process: rates, latency, CPU."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from quadsim.sim.config import SimConfig

#: the ROS 2 distributions the bench flies from, oldest supported and newest (tests/helpers/ros2_env.py makes them)
ROS2_DISTRIBUTIONS = ("jazzy", "kilted")


def _ros2_peer(distribution: str) -> tuple[Path, Path] | None:
    """The ROS 2 node of the tests (tests/helpers/ros2_peer.py, in a clone) and the Python of the ROS 2
    `distribution` environment tests/e2e/test_ros2.py makes; None where either is missing."""
    import os
    import sys

    script = Path(__file__).resolve().parents[2] / "tests" / "helpers" / "ros2_peer.py"
    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    tag = f"py{sys.version_info.major}{sys.version_info.minor}"
    python = cache / "quadsim-tests" / f"ros2-{distribution}-{tag}" / "bin" / "python"
    return (python, script) if script.exists() and python.exists() else None


class _CommandTimes:
    """A loop sink noting when (wall clock) each new climb rate reached the controller."""

    def __init__(self) -> None:
        self.seen: dict[float, float] = {}

    def on_command(self, step: int, twist: Any) -> None:
        z = round(twist.linear_z, 6)
        if z not in self.seen:
            self.seen[z] = time.time()

    def on_state(self, state: Any) -> None:
        pass


def _realtime_cameras_run(wall_s: float, live: tuple[Any, ...], driver: Any, sink: Any = None) -> tuple[float, float]:
    """A real-time run with both cameras, recorded, fed to `live` consumers: (wall s, CPU s of this process)."""
    import tempfile

    from quadsim.sensors.camera import default_cameras
    from quadsim.session.outputs import OutputOptions
    from quadsim.session.pacing import RealTimePacer
    from quadsim.session.plan import RunPlan
    from quadsim.session.run import Run

    with tempfile.TemporaryDirectory() as tmp:
        options = OutputOptions(out=Path(tmp) / "bench.mcap", cameras=default_cameras(), ordered_delivery=False)
        plan = RunPlan.alone(SimConfig(), driver, duration_s=wall_s, outputs=options, label="bench", live=live)
        with Run(plan) as run:
            if sink is not None:
                run.fleet.members[0].add_sink(sink)
            t0, cpu0 = time.perf_counter(), time.process_time()
            run.fly(RealTimePacer(plan.config.rates.physics_hz, max_frame_s=None))
            return time.perf_counter() - t0, time.process_time() - cpu0


def run_ros2_bench(out: Callable[[str], None] = print, wall_s: float = 12.0) -> None:
    """The ROS 2 bridge in a real-time run with both cameras, beside a real rclpy node (rmw_fastrtps_cpp,
    ROS 2 Jazzy and Kilted in turn) subscribed to odometry, a camera and /clock and publishing a new
    Twist every 0.25 s: the bridge's CPU share against the same run without it, the time from the
    bridge's start to the node's first message, and the latency from the node's publish to the
    controller getting the command (its rotor forces are computed in that same step)."""
    from quadsim.drivers.subscribed import SubscribedDriver

    out("## ROS 2 bridge (real time, both cameras, recorded)")
    peers = {d: _ros2_peer(d) for d in ROS2_DISTRIBUTIONS}
    if not any(peers.values()):
        out(
            "skipped: needs a clone's tests/helpers/ros2_peer.py and the ROS 2 environments tests/e2e/test_ros2.py makes"
        )
        return
    base_wall, base_cpu = _realtime_cameras_run(wall_s, (), SubscribedDriver("none"))
    out(f"baseline (no bridge)   CPU {100 * base_cpu / base_wall:5.1f} % of one core over {base_wall:.1f} s")
    for k, (distribution, peer) in enumerate(peers.items()):
        out(f"### ROS 2 {distribution.capitalize()} node (rmw_fastrtps_cpp), discovery LOCALHOST")
        if peer is None:
            out(f"skipped: no ROS 2 {distribution} environment (tests/e2e/test_ros2.py makes it)")
            continue
        _ros2_bench_one(out, wall_s, peer, base_cpu / base_wall, k)


def _ros2_bench_one(
    out: Callable[[str], None], wall_s: float, peer: tuple[Path, Path], base_cpu_share: float, index: int
) -> None:
    """One distribution's node beside the bridge (`index` keeps its domain apart from the other's)."""
    import json
    import os
    import subprocess
    import tempfile

    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.live.ros2 import Ros2Bridge

    python, script = peer
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ROS_", "RMW_", "CYCLONEDDS_"))}
    env.update(ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(150 + (os.getpid() + index) % 50))
    driver, times = SubscribedDriver("ros2"), _CommandTimes()
    with tempfile.TemporaryDirectory() as tmp:
        report_path = Path(tmp) / "peer.json"
        node = subprocess.Popen(
            [str(python), str(script), "latency", str(report_path)], env=env, stdout=subprocess.PIPE, text=True
        )
        try:
            # the node is up (rclpy imported) before the bridge starts: the first message is the bridge's
            if node.stdout is None or "node up" not in node.stdout.readline():
                raise RuntimeError("the ROS 2 node did not start")
            started = time.time()
            with Ros2Bridge(exclude=("/quad_cmd_twist",), env=env) as bridge:
                bridge.subscribe_twist(driver)
                wall, cpu = _realtime_cameras_run(wall_s, (bridge,), driver, times)
            node.wait(timeout=60)
        finally:
            node.kill()
        report = json.loads(report_path.read_text())
    latencies = sorted(times.seen[round(z, 6)] - sent for z, sent in report["sent"] if round(z, 6) in times.seen)
    out(
        f"with the bridge        CPU {100 * cpu / wall:5.1f} % of one core ({cpu / wall / base_cpu_share:.2f}x) "
        f"over {wall:.1f} s for {wall_s:.1f} s of sim time"
    )
    out(
        f"bridge share           {100 * (cpu / wall - base_cpu_share):5.1f} % of one core; writing took "
        f"{100 * bridge.busy_s / wall:.1f} % of the loop's time ({bridge.published} messages)"
    )
    out(
        f"node received          {report['odom_count']} odometry, {report['image_count']} front images, "
        f"{report['clock_count']} /clock"
    )
    if report["first_clock_wall_s"] is not None:
        out(
            f"first message          {report['first_clock_wall_s'] - started:.2f} s after the bridge started (target < 3 s)"
        )
    if latencies:
        median, worst = latencies[len(latencies) // 2], latencies[-1]
        out(
            f"Twist -> controller    median {1000 * median:.1f} ms, worst {1000 * worst:.1f} ms over {len(latencies)} "
            f"commands (target < 50 ms: one input period)"
        )
    else:
        out("Twist -> controller    no command arrived")
