"""Headless runs: fly a driver (or a fleet) for a duration as fast as the machine allows, then
summarise."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from quadsim.core.types import VehicleState
from quadsim.drivers.subscribed import SubscribedDriver
from quadsim.session.real_time import collect_start_up_garbage
from quadsim.session.stopping import stop_requested
from quadsim.sim.fleet import Fleet
from quadsim.sim.flight_events import EventKind, FlightEvent
from quadsim.sim.loop import StateLog
from quadsim.sim.simulator import Simulator

#: Simulation time advanced between two progress updates.
_CHUNK_S = 0.5


def final_pose_text(state: VehicleState) -> str:
    """Where a fleet vehicle ended, as its summary line starts: position and heading."""
    x, y, z = state.position_m
    return f"final x={x:+.2f} y={y:+.2f} z={z:+.2f} m yaw={math.degrees(state.yaw_rad()):+.0f} deg"


@dataclass(frozen=True)
class RunSummary:
    sim_time_s: float
    wall_time_s: float
    final_state: VehicleState
    distance_m: float
    max_altitude_m: float
    commands_received: int
    commands_rejected: int
    commands_clamped: int = 0  # taken with a field past the vehicle's limits, brought within them
    live_input: str = ""  # what a live input (ROS 2, Foxglove) saw arrive, when one flew the run
    stopped_early: bool = False  # a signal asked the run to stop before its end
    events: tuple[FlightEvent, ...] = ()  # take-off, touchdown, landed, crash, reset
    physics_hz: int = 240  # the events' steps -> seconds

    @property
    def real_time_factor(self) -> float:
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else math.inf

    def lines(self) -> list[str]:
        s = self.final_state
        x, y, z = s.position_m
        roll, pitch = s.roll_pitch_rad()
        return [
            f"sim time        {self.sim_time_s:.2f} s",
            f"wall time       {self.wall_time_s:.2f} s",
            f"real-time factor {self.real_time_factor:.1f}x",
            f"final pose      x={x:+.3f} m  y={y:+.3f} m  z={z:+.3f} m  "
            f"yaw={math.degrees(s.yaw_rad()):+.1f} deg  roll={math.degrees(roll):+.1f}  pitch={math.degrees(pitch):+.1f}",
            f"distance flown  {self.distance_m:.2f} m (max altitude {self.max_altitude_m:.2f} m)",
            f"commands        {self.commands_received} received, {self.commands_rejected} rejected (not finite), "
            f"{self.commands_clamped} clamped to the limits",
            *([f"live input      {self.live_input}"] if self.live_input else []),
            f"flight events   {self.events_line()}",
            *(
                f"crash           at t={e.step / self.physics_hz:.2f} s: {e.value}"
                for e in self.events
                if e.kind is EventKind.CRASH
            ),
        ]

    def events_line(self) -> str:
        counts = {kind: sum(e.kind is kind for e in self.events) for kind in EventKind}
        return ", ".join(f"{n} {kind.value}" for kind, n in counts.items() if n) or "none"


class _Odometer:
    """A sink adding up the path length between published states."""

    def __init__(self) -> None:
        self.distance_m = 0.0
        self.max_z_m = -math.inf
        self.commands = 0
        self._last: tuple[float, float, float] | None = None

    def on_command(self, step: int, twist: object) -> None:
        self.commands += 1

    def on_state(self, state: VehicleState) -> None:
        p = state.position_m
        if self._last is not None:
            self.distance_m += math.dist(p, self._last)
        self._last = p
        self.max_z_m = max(self.max_z_m, p[2])


def _live_input(driver: object) -> str:
    """What arrived from a live input (drivers/subscribed.py), said so a user sees what the wire
    brought: a DDS payload of the right size always decodes to some Twist."""
    if not isinstance(driver, SubscribedDriver):
        return ""
    arrived = driver.received + driver.rejected
    return (
        f"{arrived} arrived on {driver.topic} from {driver.name}: {driver.rejected} rejected (not finite), "
        f"{driver.dropped} superseded before a step took them"
    )


def run_headless(
    sim: Simulator,
    duration_s: float,
    progress: Callable[[float], None] | None = None,
    realtime: bool = False,
    log: StateLog | None = None,
) -> RunSummary:
    """Advance `sim` by `duration_s`. `realtime` paces sim time to the wall clock (GUI viewing)."""
    odo = _Odometer()
    sim.add_sink(odo)
    if log is not None:
        sim.add_sink(log)
    hz = sim.config.rates.physics_hz
    start_step = sim.step_count
    first_event = len(sim.events)
    done, total, wall = _advance(sim.step, hz, duration_s, progress, realtime)
    return _summary(sim, odo, start_step, first_event, wall, done < total)


def run_fleet_headless(
    fleet: Fleet,
    duration_s: float,
    progress: Callable[[float], None] | None = None,
    realtime: bool = False,
) -> dict[str, RunSummary]:
    """Advance every vehicle of `fleet` by `duration_s`, together; each vehicle's summary, by name."""
    odometers = {name: _Odometer() for name in fleet}
    for name, odo in odometers.items():
        fleet[name].add_sink(odo)
    start_step = fleet.step_count
    first_events = {name: len(fleet[name].events) for name in fleet}
    done, total, wall = _advance(fleet.step, fleet.config.rates.physics_hz, duration_s, progress, realtime)
    return {
        name: _summary(fleet[name], odo, start_step, first_events[name], wall, done < total)
        for name, odo in odometers.items()
    }


def _advance(
    step: Callable[[int], object],
    hz: int,
    duration_s: float,
    progress: Callable[[float], None] | None,
    realtime: bool,
) -> tuple[int, int, float]:
    """Call `step(n)` until `duration_s` of sim time have passed or a signal asks to stop (between
    two chunks), paced to the wall clock with `realtime`: (steps done, steps asked, wall time)."""
    total_steps = round(duration_s * hz)
    chunk = max(1, round((1.0 / 60.0 if realtime else _CHUNK_S) * hz))
    if realtime:
        collect_start_up_garbage()
    t0 = time.perf_counter()
    done = 0
    while done < total_steps and not stop_requested():
        n = min(chunk, total_steps - done)
        step(n)
        done += n
        if realtime:
            ahead = done / hz - (time.perf_counter() - t0)
            while ahead > 0 and not stop_requested():
                time.sleep(min(ahead, 0.05))
                ahead = done / hz - (time.perf_counter() - t0)
        if progress is not None:
            progress(done / hz)
    return done, total_steps, time.perf_counter() - t0


def _summary(
    sim: Simulator, odo: _Odometer, start_step: int, first_event: int, wall: float, stopped_early: bool
) -> RunSummary:
    hz = sim.config.rates.physics_hz
    return RunSummary(
        sim_time_s=(sim.step_count - start_step) / hz,
        wall_time_s=wall,
        final_state=sim.state,
        distance_m=odo.distance_m,
        max_altitude_m=odo.max_z_m if odo.max_z_m > -math.inf else sim.state.position_m[2],
        commands_received=odo.commands,
        commands_rejected=sim.gate.rejected_count
        + (sim.driver.rejected if isinstance(sim.driver, SubscribedDriver) else 0),
        commands_clamped=sim.gate.clamped_count,
        live_input=_live_input(sim.driver),
        stopped_early=stopped_early,
        events=tuple(sim.events[first_event:]),
        physics_hz=hz,
    )
