"""Foxglove streaming: what serving a run live costs the flight."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from quadsim.core.types import ZMode
from quadsim.session.pacing import RealTimePacer
from quadsim.session.plan import RunPlan
from quadsim.session.run import Run
from quadsim.sim.config import SimConfig


def _thread_cpu_s(tids: set[int]) -> float:
    """CPU seconds (user + system) the threads `tids` of this process have used (Linux /proc)."""
    import os

    tick = os.sysconf("SC_CLK_TCK")
    total = 0
    for tid in tids:
        try:
            with open(f"/proc/self/task/{tid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue  # the thread ended
        total += int(fields[11]) + int(fields[12])  # utime, stime
    return total / tick


def _thread_ids() -> set[int]:
    import os

    return {int(t) for t in os.listdir("/proc/self/task")}


def _twist_client(url: str, stop: threading.Event, published: list[tuple[float, float]]) -> None:
    """A Foxglove client: subscribes to every topic advertised and publishes a Twist at 20 Hz
    whose linear z changes every second, noting when it changed."""
    import json
    import struct

    from websockets.sync.client import connect

    protocols: Any = ["foxglove.sdk.v1"]
    with connect(url, subprotocols=protocols, compression=None, max_size=None) as ws:
        ws.send(json.dumps({"op": "advertise", "channels": [{"id": 1, "topic": "/quad_cmd_twist",
                            "encoding": "cdr", "schemaName": "geometry_msgs/msg/Twist"}]}))  # fmt: skip
        next_send, subscribed, sent = time.perf_counter(), 0, 0
        while not stop.is_set():
            try:
                frame = ws.recv(timeout=0.005)
                if isinstance(frame, str) and json.loads(frame)["op"] == "advertise":
                    channels = json.loads(frame)["channels"]
                    ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                        {"id": subscribed + i, "channelId": c["id"]} for i, c in enumerate(channels)]}))  # fmt: skip
                    subscribed += len(channels)
            except TimeoutError:
                pass
            if time.perf_counter() >= next_send:
                sent += 1
                x = 0.5 if sent % 40 < 20 else 0.0  # climb 1 s, hold 1 s: the command changes
                ws.send(struct.pack("<BI", 1, 1) + b"\x00\x01\x00\x00" + struct.pack("<6d", 0, 0, x, 0, 0, 0))
                if not published or published[-1][1] != x:
                    published.append((time.perf_counter(), x))
                next_send += 0.05


def _paced_run(
    run: Run, wall_s: float, published: list[tuple[float, float]], server_threads: set[int]
) -> dict[str, float]:
    """Fly in real time for `wall_s` (the run's pacer); the real-time factor, the CPU shares and
    the latency from a published Twist to the gate's command."""
    results: dict[str, float] = {}
    drone = run.fleet.members[0]
    hz = drone.config.rates.physics_hz
    latencies: list[float] = []
    last_z: list[float] = []

    def watch(_flown_s: float) -> None:
        z = drone.gate.last_command.linear_z
        if last_z and z != last_z[0]:  # the command changed: when was it sent?
            changes = [t for t, sent_z in published if sent_z == z]
            if changes:
                latencies.append(time.perf_counter() - changes[-1])
        last_z[:] = [z]

    cpu0, server0, t0 = time.process_time(), _thread_cpu_s(server_threads), time.perf_counter()
    steps0 = drone.step_count
    run.fly(RealTimePacer(hz, max_frame_s=None), watch, stop=lambda: time.perf_counter() - t0 >= wall_s)
    wall = time.perf_counter() - t0
    results["real_time_factor"] = (drone.step_count - steps0) / hz / wall
    results["cpu_share"] = (time.process_time() - cpu0) / wall
    results["server_cpu_share"] = (_thread_cpu_s(server_threads) - server0) / wall
    results["latency_ms"] = 1e3 * max(latencies) if latencies else float("nan")
    results["latency_median_ms"] = 1e3 * sorted(latencies)[len(latencies) // 2] if latencies else float("nan")
    return results


def measure_live(wall_s: float, foxglove: bool) -> dict[str, float]:
    """A real-time headless run (both cameras 320x240 @ 30 Hz, recording on, commands from a
    subscribed driver) for `wall_s`; with `foxglove`, a Foxglove server on an ephemeral port and
    a client (a thread here) subscribed to every topic and publishing Twists at 20 Hz. Returns the
    sim's real-time factor, the process's CPU share, the server threads' CPU share and the
    latency from a published Twist to the command reaching the controller (rotor commands change
    at that step)."""
    import tempfile

    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.session.outputs import OutputOptions

    driver = SubscribedDriver("foxglove")
    with tempfile.TemporaryDirectory() as tmp:
        before = _thread_ids()
        live: list[Any] = []
        if foxglove:
            from quadsim.live.foxglove import FoxgloveBridge

            live.append(FoxgloveBridge("127.0.0.1", 0, driver))
        server_threads = _thread_ids() - before
        stop = threading.Event()
        published: list[tuple[float, float]] = []  # (perf_counter, linear z) of each Twist that changed it

        outputs = OutputOptions(out=Path(tmp), ordered_delivery=False)  # real time: frames are not waited for
        config = SimConfig(z_mode=ZMode.VELOCITY)
        with Run(RunPlan.alone(config, driver, outputs=outputs, label="bench_live", live=tuple(live))) as run:
            worker = None
            if foxglove:
                worker = threading.Thread(target=_twist_client, args=(live[0].url, stop, published), daemon=True)
                worker.start()
            results = _paced_run(run, wall_s, published, server_threads)
            stop.set()
            if worker is not None:
                worker.join(timeout=2)
    return results


def run_live_bench(out: Callable[[str], None] = print, wall_s: float = 10.0) -> None:
    """Live streaming to a Foxglove client with both cameras, against the same run without it."""
    try:
        import websockets  # noqa: F401
    except ImportError:
        out("quadsim bench: live: needs the websockets package for its client (pip install websockets)")
        return
    out("quadsim bench: live Foxglove streaming (real-time headless run, both cameras 320x240@30Hz, recording on)")
    base = measure_live(wall_s, foxglove=False)
    live = measure_live(wall_s, foxglove=True)
    out(
        f"  without a server (baseline): sim at {base['real_time_factor']:.2f}x real time, "
        f"process CPU {base['cpu_share'] * 100:.0f}% of a core"
    )
    out(
        f"  serving a client subscribed to every topic: sim at {live['real_time_factor']:.2f}x real time "
        f"({live['real_time_factor'] / base['real_time_factor']:.2f} of the baseline), process CPU "
        f"{live['cpu_share'] * 100:.0f}% ({live['cpu_share'] / base['cpu_share']:.2f}x the baseline, the client "
        f"thread included); the server's threads {live['server_cpu_share'] * 100:.1f}% of a core"
    )
    out(
        f"  client-published Twist to the controller (rotor commands change at that step): median "
        f"{live['latency_median_ms']:.0f} ms, worst {live['latency_ms']:.0f} ms (target < 50 ms)"
    )
