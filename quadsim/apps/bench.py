"""The benchmark behind `python main.py bench`: ratios against a baseline measured in the same run.

Flight core:
  baseline   the bare PyBullet loop for this URDF and world: four applyExternalForce + stepSimulation
  physics    the loop stepping PhysicsWorld with a constant command, no controller, driver or sinks
             (motor lag, forces, yaw torque, drag, state read, the loop's own bookkeeping)
  full loop  SimLoop at 240 Hz physics and 240 Hz control: driver polling, command gate,
             controller, physics and state publishing, hovering at 2 m
Each figure is the best of several repeats (the least disturbed by other work on the machine).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from quadsim.control import ControllerKind
from quadsim.core.types import ActiveCommand, RotorForces, Twist, VehicleState, ZMode
from quadsim.physics.pybullet_quiet import pb
from quadsim.sim.config import Rates, SimConfig
from quadsim.sim.loop import SimLoop, StateLog
from quadsim.sim.simulator import Simulator


@dataclass(frozen=True)
class Figure:
    name: str
    seconds_per_step: float
    physics_hz: int

    @property
    def steps_per_s(self) -> float:
        return 1.0 / self.seconds_per_step

    @property
    def real_time_factor(self) -> float:
        return self.steps_per_s / self.physics_hz


def _best_of(repeats: int, steps: int, run: Callable[[int], object]) -> float:
    """Seconds per step, best of `repeats` timed runs of `steps` steps."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        run(steps)
        best = min(best, (time.perf_counter() - t0) / steps)
    return best


def bare_pybullet_loop(steps: int, repeats: int, physics_hz: int = 240) -> Figure:
    """The baseline: this URDF and world in PyBullet, four forces and one step, nothing else."""
    sim = Simulator(SimConfig(rates=Rates(physics_hz=physics_hz, control_hz=physics_hz, state_hz=physics_hz // 4)))
    phys = sim.physics
    body, cid = phys.body_id, phys.client_id
    rotors = [phys.link_index[r.link_name] for r in sim.vehicle.rotors]
    hover = sim.vehicle.hover_thrust_per_rotor_n
    pb.resetBasePositionAndOrientation(body, (0, 0, 2.0), (0, 0, 0, 1), physicsClientId=cid)

    def run(n: int) -> None:
        force = (0.0, 0.0, hover)
        origin = (0.0, 0.0, 0.0)
        link_frame = pb.LINK_FRAME
        for i in range(n):
            if i % 240 == 0:  # keep it in the air: a free body drifts and tumbles slowly
                pb.resetBasePositionAndOrientation(body, (0, 0, 2.0), (0, 0, 0, 1), physicsClientId=cid)
                pb.resetBaseVelocity(body, (0, 0, 0), (0, 0, 0), physicsClientId=cid)
            for link in rotors:
                pb.applyExternalForce(body, link, force, origin, link_frame, physicsClientId=cid)
            pb.stepSimulation(physicsClientId=cid)

    try:
        return Figure("bare PyBullet loop (baseline)", _best_of(repeats, steps, run), physics_hz)
    finally:
        sim.close()


def _hovering_sim(controller: ControllerKind, rates: Rates) -> Simulator:
    sim = Simulator(SimConfig(controller=controller, z_mode=ZMode.HEIGHT, rates=rates))
    sim.send(Twist())  # height mode, linear.z = 0: hold 2.0 m
    sim.add_sink(StateLog())
    sim.run_for(3.0)  # take off and settle before timing
    return sim


class _ConstantForces:
    """A stand-in controller asking for the same rotor forces every step, so that a loop
    stepped with it costs physics and bookkeeping alone."""

    kind = ControllerKind.CASCADE  # the Controller protocol names a kind; nothing reads it here

    def __init__(self, forces: RotorForces) -> None:
        self.forces = forces

    def reset(self) -> None:
        pass

    def update(self, state: VehicleState, command: ActiveCommand, dt_s: float) -> RotorForces:
        return self.forces

    def describe(self) -> dict[str, Any]:
        return {"name": "constant", "forces_n": list(self.forces)}


def physics_only(steps: int, repeats: int) -> Figure:
    sim = _hovering_sim(ControllerKind.CASCADE, Rates())
    phys = sim.physics
    body, cid = phys.body_id, phys.client_id
    hover = _ConstantForces((sim.vehicle.hover_thrust_per_rotor_n,) * sim.vehicle.rotor_count)
    loop = SimLoop(phys, hover, sim.gate, sim.config.rates)  # no driver, no sinks

    def run(n: int) -> None:
        for done in range(0, n, 240):
            # as the baseline: keep the uncontrolled body in the air
            pb.resetBasePositionAndOrientation(body, (0, 0, 2.0), (0, 0, 0, 1), physicsClientId=cid)
            pb.resetBaseVelocity(body, (0, 0, 0), (0, 0, 0), physicsClientId=cid)
            loop.run(min(240, n - done))

    try:
        return Figure("physics stepped by the loop, constant forces", _best_of(repeats, steps, run), 240)
    finally:
        sim.close()


def controller_only(steps: int, repeats: int, controller: ControllerKind) -> Figure:
    """One controller update per step on a recorded hover state (no physics at all)."""
    sim = _hovering_sim(controller, Rates())
    state, active, ctrl = sim.state, sim.gate.active(sim.step_count), sim.controller

    def run(n: int) -> None:
        update = ctrl.update
        for _ in range(n):
            update(state, active, 1.0 / 240.0)

    try:
        return Figure(f"{controller.value} controller update alone", _best_of(repeats, steps, run), 240)
    finally:
        sim.close()


def full_loop(steps: int, repeats: int, controller: ControllerKind = ControllerKind.CASCADE) -> Figure:
    sim = _hovering_sim(controller, Rates(physics_hz=240, control_hz=240, state_hz=60, input_hz=20))
    try:
        return Figure(f"full loop, {controller.value} controller @240 Hz", _best_of(repeats, steps, sim.step), 240)
    finally:
        sim.close()


def run_flight_core_bench(
    steps: int = 24000, repeats: int = 3, out: Callable[[str], None] = print
) -> dict[str, Figure]:
    out(f"quadsim bench: flight core ({steps} steps per run, best of {repeats}; 240 Hz physics)")
    base = bare_pybullet_loop(steps, repeats)
    figures = {
        "bare": base,
        "physics": physics_only(steps, repeats),
        "cascade_update": controller_only(steps, repeats, ControllerKind.CASCADE),
        "cascade": full_loop(steps, repeats, ControllerKind.CASCADE),
        "seed": full_loop(steps, repeats, ControllerKind.SEED),
    }
    out(f"  {'':46s} {'us/step':>8s} {'steps/s':>9s} {'x real time':>11s} {'x baseline':>10s}")
    for fig in figures.values():
        ratio = fig.seconds_per_step / base.seconds_per_step
        out(
            f"  {fig.name:46s} {fig.seconds_per_step * 1e6:8.1f} {fig.steps_per_s:9.0f} "
            f"{fig.real_time_factor:10.1f}x {ratio:9.2f}x"
        )
    cascade = figures["cascade"]
    ok_rt = cascade.real_time_factor >= 100.0
    ok_ratio = cascade.seconds_per_step <= 3.0 * base.seconds_per_step
    out(
        f"  target: full loop >= 100x real time [{'met' if ok_rt else 'MISSED'}], "
        f"within 3x of the baseline [{'met' if ok_ratio else 'MISSED'}]"
    )
    return figures


# --- cameras and recording ---------------------------------------------------------------------


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
    """Per-frame cost of the bare getCameraImage call and of quadsim's whole camera pipeline."""
    import tempfile
    from pathlib import Path

    from quadsim.recording.fanout import TopicFanout
    from quadsim.recording.writer import McapRecorder
    from quadsim.sensors.camera import RendererKind
    from quadsim.sensors.rig import CameraRig

    sim = _hovering_sim(ControllerKind.CASCADE, Rates())
    cams, views, projs = _camera_client(sim)
    cid = sim.physics.client_id
    results: dict[str, float] = {}
    state = sim.state
    rig = CameraRig(sim.vehicle, cams, RendererKind.TINY, cid, None)
    with tempfile.TemporaryDirectory() as tmp:
        rec = McapRecorder(Path(tmp) / "bench.mcap", sim.description().with_outputs(cams, 0))
        mounts = tuple((c, sim.vehicle.camera_mount(c.link_name)) for c in cams)
        fanout = TopicFanout(sim.config.rates.physics_hz, mounts)
        fanout.add_consumer(rec)
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

            def pipeline(n: int, cam=cam) -> None:
                for i in range(n):
                    for frame in rig.render((cam.name,), i, state.position_m, state.orientation_xyzw):
                        fanout.on_camera_frame(frame)

            results[f"bare_{cam.name}"] = _best_of(repeats, frames, bare)
            results[f"pipeline_{cam.name}"] = _best_of(repeats, frames, pipeline)
        rec.close()
    sim.close()
    out(f"  per frame, {cams[0].width_px}x{cams[0].height_px}, TinyRenderer   {'ms':>8s} {'x baseline':>11s}")
    for cam in cams:
        b, p = results[f"bare_{cam.name}"], results[f"pipeline_{cam.name}"]
        out(f"  {cam.name:5s} bare getCameraImage (baseline)      {b * 1e3:8.2f} {1.0:10.2f}x")
        out(f"  {cam.name:5s} render+encode+serialise+write      {p * 1e3:8.2f} {p / b:10.2f}x")
    worst = max(results[f"pipeline_{c.name}"] / results[f"bare_{c.name}"] for c in cams)
    out(f"  target: pipeline <= 1.2x the bare render [{'met' if worst <= 1.2 else 'MISSED'}: worst {worst:.2f}x]")
    return results


@dataclass(frozen=True)
class FlightFigure:
    real_time_factor: float  # sim time / wall time
    cpu_real_time_factor: float  # sim time / this process's CPU time: what other work on the machine does not skew
    size_bytes: int


def recorded_flight(duration_s: float, cameras: bool, workers: int, record: bool = True) -> FlightFigure:
    """The square scenario flown headless, recorded or not (not recorded and without cameras:
    the unrecorded loop, what `run --cameras none --no-record` flies)."""
    import tempfile
    from pathlib import Path

    from quadsim.apps.outputs import OutputOptions, RecordedRun
    from quadsim.drivers.scripted import ScriptedDriver, load_script
    from quadsim.sensors.camera import default_cameras

    script = load_script("square")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.mcap"
        with Simulator(SimConfig(z_mode=ZMode.HEIGHT), ScriptedDriver(script)) as sim:
            cams = default_cameras() if cameras else ()
            options = OutputOptions(record=record, out=path, cameras=cams, render_workers=workers)
            run = RecordedRun(sim, sim.description(), options, "bench")  # workers start before the clock does
            t0, cpu0 = time.perf_counter(), time.process_time()
            try:
                sim.run_for(duration_s)
            finally:
                run.close()
            wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
        return FlightFigure(duration_s / wall, duration_s / cpu, path.stat().st_size if record else 0)


def message_costs(states: int = 6000, repeats: int = 5) -> dict[str, float]:
    """Seconds per message of a recorded state (its five messages), best of `repeats`: turning it
    into messages (the fan-out's CDR encoding) and writing them (MCAP: logging, chunk compression
    at every simulated second). Measured on states of a real flight, without the loop."""
    import tempfile
    from pathlib import Path

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

        def on_event(self, step: int, kind: str, value: str) -> None:
            pass

    sim = _hovering_sim(ControllerKind.CASCADE, Rates())
    try:
        log = StateLog()
        sim.add_sink(log)
        sim.send(Twist(linear_x=1.0, angular_z=0.3))
        sim.run_for(states / sim.config.rates.state_hz)
        flown = log.states[-states:]
        encode = write = float("inf")
        for _ in range(repeats):
            fanout, kept = TopicFanout(sim.config.rates.physics_hz), Keep(True)
            fanout.add_consumer(Keep(False))
            t0 = time.perf_counter()
            for state in flown:
                fanout.on_state(state)
            encode = min(encode, time.perf_counter() - t0)
            fanout = TopicFanout(sim.config.rates.physics_hz)
            fanout.add_consumer(kept)
            for state in flown:
                fanout.on_state(state)
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


def run_recording_bench(out: Callable[[str], None] = print, flight_s: float = 20.0) -> None:
    out("quadsim bench: cameras and recording")
    camera_costs(frames=30, repeats=3, out=out)
    core = full_loop(12000, 3)
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


# --- the interactive window ---------------------------------------------------------------------


class _Timer:
    """Wraps a method of an object so the time spent in it is added up under a name."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    def wrap(self, obj: object, method: str, name: str) -> None:
        inner = getattr(obj, method)

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0

        setattr(obj, method, timed)


@dataclass(frozen=True)
class WindowFigures:
    frames_per_s: float
    real_time_factor: float
    frames_behind: int
    key_latency_frames: int | None  # frames from the key event to the command reaching the controller
    key_latency_ms: float | None
    camera_rates_hz: dict[str, float]
    shares: dict[str, float]


def _cpu_hogs(count: int) -> list:
    """`count` processes that spin on a core each, as other work on a busy machine does."""
    import subprocess
    import sys

    return [
        subprocess.Popen([sys.executable, "-c", "while True: pass"], stdin=subprocess.DEVNULL) for _ in range(count)
    ]


def measure_window(wall_s: float, hogs: int = 0) -> WindowFigures:
    """The teleop window (SDL dummy video, real-time pacing, 1280x720, both cameras 320x240 @ 30
    Hz, recording on) flown for `wall_s`, with `hogs` CPU-bound processes running beside it."""
    import os
    import tempfile
    from pathlib import Path

    os.environ["SDL_VIDEODRIVER"] = "dummy"
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    from quadsim.apps.outputs import OutputOptions
    from quadsim.apps.window.teleop import TeleopApp, TeleopOptions

    with tempfile.TemporaryDirectory() as tmp:
        app = TeleopApp(SimConfig(z_mode=ZMode.HEIGHT), OutputOptions(out=Path(tmp)), TeleopOptions(input="keyboard"))
        busy = _cpu_hogs(hogs)
        try:
            timer = _Timer()
            timer.wrap(app.sim, "step", "simulation (physics, control, recording)")
            timer.wrap(app.view, "draw", "drawing")
            if app.session.cameras is not None:
                timer.wrap(app.session.cameras, "poll", "camera hand-over")
            app.run(max_frames=30)  # warm up: take off, first frames
            timer.seconds.clear()
            frames0, steps0, t0 = app.frame_count, app.sim.step_count, time.perf_counter()
            behind = 0
            while time.perf_counter() - t0 < wall_s:
                app.frame()
                behind += app.pacer.lagging
            wall = time.perf_counter() - t0
            frames = app.frame_count - frames0
            sim_s = (app.sim.step_count - steps0) / app.sim.config.rates.physics_hz
            camera_rates = app.camera_rates()
            # key latency: frames from posting a key press to the command reaching the controller
            before = app.sim.gate.last_receive_step
            t_post = time.perf_counter()
            pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_UP, mod=0, unicode="", scancode=0))
            latency_frames: int | None = None
            latency_ms: float | None = None
            for k in range(120):
                app.frame()
                if app.sim.gate.last_receive_step != before and app.sim.gate.last_command.linear_x > 0:
                    latency_frames, latency_ms = k, (time.perf_counter() - t_post) * 1e3
                    break
            return WindowFigures(
                frames / wall,
                sim_s / wall,
                behind,
                latency_frames,
                latency_ms,
                camera_rates,
                {k: v / wall for k, v in timer.seconds.items()},
            )
        finally:
            for proc in busy:
                proc.kill()
                proc.wait()
            app.close()


def run_interactive_bench(out: Callable[[str], None] = print, wall_s: float = 10.0) -> None:
    """The window, on an idle machine and beside two CPU-bound processes."""
    out(
        "quadsim bench: interactive window (SDL dummy video, real-time pacing, 1280x720, "
        "both cameras 320x240@30Hz, recording on)"
    )
    for hogs in (0, 2):
        f = measure_window(wall_s, hogs)
        where = "idle machine" if not hogs else f"{hogs} CPU-bound processes beside it"
        cams = ", ".join(f"{name} {rate:.1f}" for name, rate in sorted(f.camera_rates_hz.items()))
        latency = (
            f"{f.key_latency_frames} frame(s) after the one that took the event, {f.key_latency_ms:.0f} ms"
            if f.key_latency_frames is not None
            else "no command seen within 120 frames"
        )
        out(f"  {where}:")
        out(
            f"    {f.frames_per_s:.1f} frames/s (target >= 30), sim at {f.real_time_factor:.2f}x real time, "
            f"{f.frames_behind} frames behind real time"
        )
        out(f"    key to controller: {latency} (target: within one frame)")
        out(f"    cameras delivered {cams} frames/s of 30 (frames are dropped, not waited for, when busy)")
        out(
            "    share of the wall time: "
            + ", ".join(f"{k} {v * 100:.1f}%" for k, v in sorted(f.shares.items(), key=lambda kv: -kv[1]))
        )


# --- replay ----------------------------------------------------------------------------------------


def run_replay_bench(out: Callable[[str], None] = print, flight_s: float = 20.0) -> None:
    """Headless playback read speed (recording with both cameras), and re-simulation speed
    (recording without cameras) against the flight core measured in the same run."""
    import tempfile
    from pathlib import Path

    from quadsim.apps.outputs import OutputOptions, RecordedRun
    from quadsim.apps.replay_export import summary_lines
    from quadsim.apps.resim import resimulate
    from quadsim.drivers.scripted import ScriptedDriver, load_script
    from quadsim.recording.flight import load_flight
    from quadsim.sensors.camera import default_cameras

    out("quadsim bench: replay")
    script = load_script("square")
    with tempfile.TemporaryDirectory() as tmp:
        paths = {}
        for name, cams in (("cams", default_cameras()), ("nocams", ())):
            paths[name] = Path(tmp) / f"{name}.mcap"
            with Simulator(SimConfig(z_mode=ZMode.HEIGHT), ScriptedDriver(script)) as sim:
                with RecordedRun(sim, sim.description(), OutputOptions(out=paths[name], cameras=cams), name):
                    sim.run_for(flight_s)
        best = float("inf")
        for _ in range(3):
            t0 = time.perf_counter()
            flight = load_flight(paths["cams"])
            summary_lines(flight)
            best = min(best, time.perf_counter() - t0)
        size = paths["cams"].stat().st_size / 1e6
        out(
            f"  headless playback of {flight_s:.0f} s with both cameras ({size:.1f} MB, "
            f"{sum(flight.topics.values())} messages): {best:.2f} s, {flight_s / best:.0f}x real time (target >= 50x)"
        )
        core = full_loop(12000, 3)
        flight = load_flight(paths["nocams"])
        best, best_stepping = float("inf"), float("inf")
        for _ in range(3):
            t0 = time.perf_counter()
            report = resimulate(flight, record=False)
            best = min(best, time.perf_counter() - t0)
            best_stepping = min(best_stepping, report.stepping_wall_s)
        out(
            f"  re-simulation of {flight_s:.0f} s without cameras: flying {report.sim_time_s / best_stepping:.0f}x real "
            f"time (flight core {core.real_time_factor:.0f}x in the same run); {flight_s / best:.0f}x including "
            f"loading, building the world and comparing; max position error {report.position.max_error:g} m"
        )


#: the ROS 2 distributions the bench flies from, oldest supported and newest (tests/ros2_env.py makes them)
ROS2_DISTRIBUTIONS = ("jazzy", "kilted")


def _ros2_peer(distribution: str) -> tuple[Path, Path] | None:
    """The ROS 2 node of the tests (tests/ros2_peer.py, in a clone) and the Python of the ROS 2
    `distribution` environment tests/test_ros2.py makes; None where either is missing."""
    import os
    import sys

    script = Path(__file__).resolve().parents[2] / "tests" / "ros2_peer.py"
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

    from quadsim.apps.headless import run_headless
    from quadsim.apps.outputs import OutputOptions, RecordedRun
    from quadsim.sensors.camera import default_cameras

    with tempfile.TemporaryDirectory() as tmp, Simulator(SimConfig(), driver) as sim:
        if sink is not None:
            sim.add_sink(sink)
        options = OutputOptions(out=Path(tmp) / "bench.mcap", cameras=default_cameras(), ordered_delivery=False)
        with RecordedRun(sim, sim.description(), options, "bench", live=live):
            t0, cpu0 = time.perf_counter(), time.process_time()
            run_headless(sim, wall_s, realtime=True)
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
        out("skipped: needs a clone's tests/ros2_peer.py and the ROS 2 environments tests/test_ros2.py makes")
        return
    base_wall, base_cpu = _realtime_cameras_run(wall_s, (), SubscribedDriver("none"))
    out(f"baseline (no bridge)   CPU {100 * base_cpu / base_wall:5.1f} % of one core over {base_wall:.1f} s")
    for k, (distribution, peer) in enumerate(peers.items()):
        out(f"### ROS 2 {distribution.capitalize()} node (rmw_fastrtps_cpp), discovery LOCALHOST")
        if peer is None:
            out(f"skipped: no ROS 2 {distribution} environment (tests/test_ros2.py makes it)")
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
        node = subprocess.Popen([str(python), str(script), "latency", str(report_path)], env=env)
        try:
            time.sleep(2.0)  # the node is up (rclpy imported) before the bridge starts: first message is the bridge's
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


# --- live: the Foxglove bridge -------------------------------------------------------------------


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


def measure_live(wall_s: float, foxglove: bool) -> dict[str, float]:
    """A real-time headless run (both cameras 320x240 @ 30 Hz, recording on, commands from a
    subscribed driver) for `wall_s`; with `foxglove`, a Foxglove server on an ephemeral port and
    a client (a thread here) subscribed to every topic and publishing Twists at 20 Hz. Returns the
    sim's real-time factor, the process's CPU share, the server threads' CPU share and the
    latency from a published Twist to the command reaching the controller (rotor commands change
    at that step)."""
    import json
    import struct
    import tempfile
    import threading
    from pathlib import Path

    from quadsim.apps.outputs import OutputOptions, RecordedRun
    from quadsim.drivers.subscribed import SubscribedDriver

    driver = SubscribedDriver("foxglove")
    results: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp, Simulator(SimConfig(z_mode=ZMode.VELOCITY), driver) as sim:
        before = _thread_ids()
        live: list[Any] = []
        if foxglove:
            from quadsim.live.foxglove import FoxgloveBridge

            live.append(FoxgloveBridge("127.0.0.1", 0, driver))
        server_threads = _thread_ids() - before
        stop = threading.Event()
        published: list[tuple[float, float]] = []  # (perf_counter, linear z) of each Twist that changed it

        def client(url: str) -> None:
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

        outputs = OutputOptions(out=Path(tmp), ordered_delivery=False)  # real time: frames are not waited for
        with RecordedRun(sim, sim.description(), outputs, "bench_live", live=live):
            worker = None
            if foxglove:
                worker = threading.Thread(target=client, args=(live[0].url,), daemon=True)
                worker.start()
            hz = sim.config.rates.physics_hz
            latencies: list[float] = []
            last_z = None
            cpu0, server0, t0 = time.process_time(), _thread_cpu_s(server_threads), time.perf_counter()
            steps0 = sim.step_count
            while time.perf_counter() - t0 < wall_s:
                sim.step(4)  # 1/60 s, as the real-time headless run does
                z = sim.gate.last_command.linear_z
                if last_z is not None and z != last_z:  # the command changed: when was it sent?
                    changes = [t for t, sent_z in published if sent_z == z]
                    if changes:
                        latencies.append(time.perf_counter() - changes[-1])
                last_z = z
                ahead = (sim.step_count - steps0) / hz - (time.perf_counter() - t0)
                if ahead > 0:
                    time.sleep(ahead)
            wall = time.perf_counter() - t0
            results["real_time_factor"] = (sim.step_count - steps0) / hz / wall
            results["cpu_share"] = (time.process_time() - cpu0) / wall
            results["server_cpu_share"] = (_thread_cpu_s(server_threads) - server0) / wall
            results["latency_ms"] = 1e3 * max(latencies) if latencies else float("nan")
            results["latency_median_ms"] = 1e3 * sorted(latencies)[len(latencies) // 2] if latencies else float("nan")
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
