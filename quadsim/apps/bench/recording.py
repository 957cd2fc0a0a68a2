"""Cameras and recording: what a frame, a message and a recorded flight cost."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from quadsim.apps.bench.figures import best_of, cpu_hogs
from quadsim.apps.bench.flight import full_loop, hovering_sim
from quadsim.control import ControllerKind
from quadsim.core.types import Twist, ZMode
from quadsim.physics.pybullet_quiet import pb
from quadsim.sim.config import Rates, SimConfig
from quadsim.sim.loop import StateLog
from quadsim.sim.simulator import Simulator


def _camera_client(sim: Simulator):
    """The cameras' view from a vehicle hovering at 2 m in the default world."""
    from quadsim.sensors.camera import camera_pose, default_cameras
    from quadsim.sensors.rendering import projection_matrix, view_matrix

    cams = default_cameras()
    state = sim.state
    views = {
        c.name: view_matrix(
            camera_pose(sim.vehicle.camera_mount(c.link_name), state.position_m, state.orientation_xyzw)
        )
        for c in cams
    }
    return cams, views, {c.name: projection_matrix(c) for c in cams}


def camera_costs(frames: int, repeats: int, out: Callable[[str], None]) -> dict[str, float]:
    """Per-frame cost of the bare getCameraImage call and of quadsim's whole camera pipeline,
    without and with the camera's depth (16UC1) and segmentation images."""
    from dataclasses import replace

    sim = hovering_sim(ControllerKind.CASCADE, Rates())
    cams, views, projs = _camera_client(sim)
    cid = sim.physics.client_id
    results: dict[str, float] = {}
    for cam in cams:

        def bare(n: int, cam=cam) -> None:
            for _ in range(n):
                pb.getCameraImage(
                    cam.width_px,
                    cam.height_px,
                    views[cam.name],
                    projs[cam.name],
                    renderer=pb.ER_TINY_RENDERER,
                    physicsClientId=cid,
                )

        results[f"bare_{cam.name}"] = best_of(repeats, frames, bare)
    for kind, specs in (
        ("pipeline", cams),
        ("images", tuple(replace(c, depth="16UC1", segmentation=True) for c in cams)),
    ):
        for cam, cost in _recorded_frame_costs(sim, specs, frames, repeats).items():
            results[f"{kind}_{cam}"] = cost
    sim.close()
    out(f"  per frame, {cams[0].width_px}x{cams[0].height_px}, TinyRenderer   {'ms':>8s} {'x baseline':>11s}")
    for cam in cams:
        b, p, i = (results[f"{kind}_{cam.name}"] for kind in ("bare", "pipeline", "images"))
        out(f"  {cam.name:5s} bare getCameraImage (baseline)      {b * 1e3:8.2f} {1.0:10.2f}x")
        out(f"  {cam.name:5s} render+encode+serialise+write      {p * 1e3:8.2f} {p / b:10.2f}x")
        out(f"  {cam.name:5s} the same + 16UC1 depth, labels     {i * 1e3:8.2f} {i / b:10.2f}x")
    worst = max(results[f"pipeline_{c.name}"] / results[f"bare_{c.name}"] for c in cams)
    out(f"  target: pipeline <= 1.2x the bare render [{'met' if worst <= 1.2 else 'MISSED'}: worst {worst:.2f}x]")
    return results


def _recorded_frame_costs(sim: Simulator, cams: tuple, frames: int, repeats: int) -> dict[str, float]:
    """Each camera's cost per frame, rendered in `sim`'s client and recorded through a fan-out."""
    import tempfile

    from quadsim.recording.fanout import TopicFanout
    from quadsim.recording.writer import McapRecorder
    from quadsim.sensors.camera import RendererKind
    from quadsim.sensors.rig import CameraRig

    state = sim.state
    rig = CameraRig(sim.vehicle, cams, RendererKind.TINY, sim.physics.client_id, None, scene=sim.scene_client)
    costs = {}
    with tempfile.TemporaryDirectory() as tmp:
        rec = McapRecorder(Path(tmp) / "bench.mcap", sim.description().with_outputs(cams, 0))
        mounts = tuple((c, sim.vehicle.camera_mount(c.link_name)) for c in cams)
        fanout = TopicFanout(sim.config.rates.physics_hz, sim.world)
        producer = fanout.add_vehicle(cameras=mounts)
        fanout.add_consumer(rec)
        for cam in cams:

            def pipeline(n: int, cam=cam) -> None:
                for i in range(n):
                    for frame in rig.render((cam.name,), i, state.position_m, state.orientation_xyzw):
                        producer.on_camera_frame(frame)

            costs[cam.name] = best_of(repeats, frames, pipeline)
        rec.close()
    return costs


@dataclass(frozen=True)
class FlightFigure:
    real_time_factor: float  # sim time / wall time
    cpu_real_time_factor: float  # sim time / this process's CPU time: what other work on the machine does not skew
    size_bytes: int


def recorded_flight(
    duration_s: float, cameras: bool, workers: int, record: bool = True, config: SimConfig | None = None
) -> FlightFigure:
    """The square scenario flown headless, recorded or not (not recorded and without cameras:
    the unrecorded loop, what `run --cameras none --no-record` flies); `config`: its settings
    (default: SimConfig's, height z-mode)."""
    import tempfile

    from quadsim.drivers.scripted import ScriptedDriver, load_script
    from quadsim.sensors.camera import default_cameras
    from quadsim.session.outputs import OutputOptions
    from quadsim.session.plan import RunPlan
    from quadsim.session.run import Run, to_the_end

    script = load_script("square")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.mcap"
        cams = default_cameras() if cameras else ()
        options = OutputOptions(record=record, out=path, cameras=cams, render_workers=workers)
        plan = RunPlan.alone(
            replace(config or SimConfig(), z_mode=ZMode.HEIGHT),
            ScriptedDriver(script),
            duration_s=duration_s,
            outputs=options,
            label="bench",
        )
        with Run(plan) as run:  # workers start before the clock does
            t0, cpu0 = time.perf_counter(), time.process_time()
            try:
                run.fly(stop=to_the_end)
            finally:
                run.outputs.close()
            wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
        return FlightFigure(duration_s / wall, duration_s / cpu, path.stat().st_size if record else 0)


def message_costs(states: int = 6000, repeats: int = 5) -> dict[str, float]:
    """Seconds per message of a recorded state (its five messages), best of `repeats`: turning it
    into messages (the fan-out's CDR encoding) and writing them (MCAP: logging, chunk compression
    at every simulated second). Measured on states of a real flight, without the loop."""
    import tempfile

    from quadsim.recording.contract import Topic
    from quadsim.recording.fanout import Message, TopicFanout
    from quadsim.recording.writer import McapRecorder

    class Keep:
        def __init__(self, keep: bool) -> None:
            self.keep = keep
            self.batches: list[Sequence[Message]] = []

        def add_topic(self, topic: Topic) -> None:
            pass

        def on_messages(self, messages: Sequence[Message]) -> None:
            if self.keep:
                self.batches.append(messages)

        def on_event(self, step: int, kind: str, value: str, vehicle: str = "") -> None:
            pass

    sim = hovering_sim(ControllerKind.CASCADE, Rates())
    try:
        log = StateLog()
        sim.add_sink(log)
        sim.send(Twist(linear_x=1.0, angular_z=0.3))
        sim.run_for(states / sim.config.rates.state_hz)
        flown = log.states[-states:]
        encode = write = float("inf")
        for _ in range(repeats):
            fanout, kept = TopicFanout(sim.config.rates.physics_hz), Keep(True)
            producer = fanout.add_vehicle()
            fanout.add_consumer(Keep(False))
            t0 = time.perf_counter()
            for state in flown:
                producer.on_state(state)
            encode = min(encode, time.perf_counter() - t0)
            fanout = TopicFanout(sim.config.rates.physics_hz)
            producer = fanout.add_vehicle()
            fanout.add_consumer(kept)
            for state in flown:
                producer.on_state(state)
            batches = kept.batches[1:]  # after /tf_static
            with tempfile.TemporaryDirectory() as tmp:
                rec = McapRecorder(Path(tmp) / "bench.mcap", sim.description())
                for topic in fanout.topics:
                    rec.add_topic(topic)
                t0 = time.perf_counter()
                for batch in batches:
                    rec.on_messages(batch)
                write = min(write, time.perf_counter() - t0)
                rec.close()
        count = sum(len(b) for b in batches)
        return {"encode": encode / count, "write": write / count}
    finally:
        sim.close()


def realtime_cameras(flight_s: float, hogs: int) -> str:
    """A real-time run with both cameras (320x240 at 30 Hz, 2 render workers, recorded), beside
    `hogs` processes that keep a core busy each: what the summary says of each camera's delivered
    rate, the captures dropped and how long after their capture frames were handed on."""
    import tempfile

    from quadsim.drivers.scripted import ScriptedDriver, load_script
    from quadsim.sensors.camera import default_cameras
    from quadsim.session.outputs import OutputOptions
    from quadsim.session.pacing import RealTimePacer
    from quadsim.session.plan import RunPlan
    from quadsim.session.run import Run, to_the_end

    with cpu_hogs(hogs), tempfile.TemporaryDirectory() as tmp:
        options = OutputOptions(out=Path(tmp), cameras=default_cameras(), ordered_delivery=False)
        plan = RunPlan.alone(
            SimConfig(z_mode=ZMode.HEIGHT),
            ScriptedDriver(load_script("square")),
            duration_s=flight_s,
            outputs=options,
        )
        with Run(plan) as run:
            summary = run.fly(RealTimePacer(plan.config.rates.physics_hz, max_frame_s=None), stop=to_the_end)[""]
    return summary.cameras


def run_recording_bench(out: Callable[[str], None] = print, flight_s: float = 20.0) -> None:
    out("quadsim bench: cameras and recording")
    camera_costs(frames=30, repeats=3, out=out)
    core = full_loop().figure(12000, 3)
    with_cams = recorded_flight(flight_s, cameras=True, workers=2)
    rtf_cam, size_cam = with_cams.real_time_factor, with_cams.size_bytes
    rtf_cam1 = recorded_flight(flight_s, cameras=True, workers=0).real_time_factor
    # the recorded flight without cameras against the same flight unrecorded, interleaved, best of
    # 3 each; their ratio on CPU time, which other work on the machine does not skew
    recorded, unrecorded = [], []
    for _ in range(3):
        unrecorded.append(recorded_flight(60.0, cameras=False, workers=0, record=False))
        recorded.append(recorded_flight(60.0, cameras=False, workers=0))
    rtf_nocam = max(f.real_time_factor for f in recorded)
    rtf_unrecorded = max(f.real_time_factor for f in unrecorded)
    ratio = max(f.cpu_real_time_factor for f in recorded) / max(f.cpu_real_time_factor for f in unrecorded)
    size_nocam = recorded[0].size_bytes
    out(f"  headless flight ('square', {flight_s:.0f} s sim), recorded:        {'x real time':>12s}")
    out(f"  both cameras 320x240@30Hz, 2 render workers          {rtf_cam:11.2f}x")
    out(f"  both cameras 320x240@30Hz, rendered in-process      {rtf_cam1:11.2f}x")
    out(f"  no cameras (flight core alone: {core.real_time_factor:.0f}x)               {rtf_nocam:11.1f}x")
    out(f"  no cameras, not recorded (the unrecorded loop)      {rtf_unrecorded:11.1f}x")
    out(
        f"  target: with cameras >= 1.5x [{'met' if rtf_cam >= 1.5 else 'MISSED'}]; "
        f"without cameras >= 100x [{'met' if rtf_nocam >= 100 else 'MISSED'}]; "
        f"recorded without cameras >= 0.8 of the unrecorded loop's speed "
        f"[{'met' if ratio >= 0.8 else 'MISSED'}: {ratio:.2f}, on CPU time]"
    )
    costs = message_costs()
    total = costs["encode"] + costs["write"]
    out(
        f"  per state message: {total * 1e6:.2f} us = making it (CDR) {costs['encode'] * 1e6:.2f} us "
        f"({costs['encode'] / total:.0%}) + writing it (MCAP) {costs['write'] * 1e6:.2f} us ({costs['write'] / total:.0%})"
    )
    out(
        f"  one minute of recording: {size_cam / flight_s * 60 / 1e6:.1f} MB with both cameras, "
        f"{size_nocam / 1e6:.2f} MB without"
    )
    out("  real time, both cameras 320x240@30Hz, 2 render workers (what the run's summary says):")
    for hogs in (0, 2):
        out(f"  {'alone' if not hogs else f'beside {hogs} CPU hogs':<17} {realtime_cameras(10.0, hogs)}")
    out("  target: frames at most 0.25 s after their capture (median), beside two CPU hogs")
