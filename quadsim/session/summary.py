"""What a run did, vehicle by vehicle: where each vehicle ended, how far it flew, the commands it
took and its flight events (an odometer sink counts them as it flies)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from quadsim.core.types import VehicleState
from quadsim.drivers.subscribed import SubscribedDriver
from quadsim.sim.drone import Drone
from quadsim.sim.flight_events import EventKind, FlightEvent

if TYPE_CHECKING:  # the cameras' pipeline imports the imaging libraries: only where there are cameras
    from quadsim.sensors.pipeline import CameraPipeline


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
    cameras: str = ""  # what its cameras delivered (camera_line), when it has some

    @property
    def real_time_factor(self) -> float:
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else math.inf

    def lines(self) -> list[str]:
        """The whole summary: how long it flew and how fast, then where it went (`where_lines`)."""
        return [
            f"sim time        {self.sim_time_s:.2f} s",
            f"wall time       {self.wall_time_s:.2f} s",
            f"real-time factor {self.real_time_factor:.1f}x",
            *self.where_lines(),
        ]

    def where_lines(self) -> list[str]:
        """Where the vehicle ended, how far it flew, the commands it took and its flight events."""
        s = self.final_state
        x, y, z = s.position_m
        roll, pitch = s.roll_pitch_rad()
        return [
            f"final pose      x={x:+.3f} m  y={y:+.3f} m  z={z:+.3f} m  "
            f"yaw={math.degrees(s.yaw_rad()):+.1f} deg  roll={math.degrees(roll):+.1f}  pitch={math.degrees(pitch):+.1f}",
            f"distance flown  {self.distance_m:.2f} m (max altitude {self.max_altitude_m:.2f} m)",
            f"commands        {self.commands_received} received, {self.commands_rejected} rejected (not finite), "
            f"{self.commands_clamped} clamped to the limits",
            *([f"live input      {self.live_input}"] if self.live_input else []),
            *([f"cameras         {self.cameras}"] if self.cameras else []),
            f"flight events   {self.events_line()}",
            *(
                f"crash           at t={e.step / self.physics_hz:.2f} s: {e.value}"
                for e in self.events
                if e.kind is EventKind.CRASH
            ),
        ]

    def vehicle_line(self) -> str:
        """A fleet's vehicle in one line: where it ended, how far it flew, its commands and events."""
        (x, y, z), yaw_deg = self.final_state.position_m, math.degrees(self.final_state.yaw_rad())
        return (
            f"final x={x:+.2f} y={y:+.2f} z={z:+.2f} m yaw={yaw_deg:+.0f} deg; "
            f"flown {self.distance_m:.2f} m; {self.commands_received} commands; events: {self.events_line()}"
        )

    def events_line(self) -> str:
        counts = {kind: sum(e.kind is kind for e in self.events) for kind in EventKind}
        return ", ".join(f"{n} {kind.value}" for kind, n in counts.items() if n) or "none"


def _live_input(driver: object) -> str:
    """What arrived from a live input (drivers/subscribed.py), said so a user sees what the wire
    brought: a DDS payload of the right size always decodes to some Twist."""
    if not isinstance(driver, SubscribedDriver):
        return ""
    arrived = driver.received + driver.rejected
    goals = driver.goals_received + driver.goals_rejected
    return (
        f"{arrived} arrived on {driver.heard_on} from {driver.name}: {driver.rejected} rejected (not finite), "
        f"{driver.dropped} superseded before a step took them"
        + (f"; {goals} goal{'s' * (goals != 1)}, {driver.goals_rejected} refused" if goals else "")
    )


class Odometer:
    """A sink adding up the path length between published states, and the commands taken; with
    `summary`, what its vehicle did since it was attached."""

    def __init__(self, drone: Drone) -> None:
        self.drone = drone
        self.start_step = drone.step_count
        self.first_event = len(drone.events)
        self.distance_m = 0.0
        self.max_z_m = -math.inf
        self.commands = 0
        self._last: tuple[float, float, float] | None = None
        self._last_step = -1

    def on_command(self, step: int, twist: object) -> None:
        self.commands += 1

    def on_state(self, state: VehicleState) -> None:
        p = state.position_m
        if self._last is not None and state.step > self._last_step:  # (not across a reset to the start)
            self.distance_m += math.dist(p, self._last)
        self._last, self._last_step = p, state.step
        self.max_z_m = max(self.max_z_m, p[2])

    def summary(self, wall_s: float, stopped_early: bool, cameras: str = "") -> RunSummary:
        """What the vehicle did since this odometer was attached, flown in `wall_s` of wall time
        (`cameras`: what its cameras delivered, camera_line)."""
        drone = self.drone
        hz = drone.config.rates.physics_hz
        state = drone.state
        return RunSummary(
            sim_time_s=(drone.step_count - self.start_step) / hz,
            wall_time_s=wall_s,
            final_state=state,
            distance_m=self.distance_m,
            max_altitude_m=self.max_z_m if self.max_z_m > -math.inf else state.position_m[2],
            commands_received=self.commands,
            commands_rejected=drone.gate.rejected_count
            + (drone.driver.rejected if isinstance(drone.driver, SubscribedDriver) else 0),
            commands_clamped=drone.gate.clamped_count,
            live_input=_live_input(drone.driver),
            stopped_early=stopped_early,
            events=tuple(drone.events[self.first_event :]),
            physics_hz=hz,
            cameras=cameras,
        )


def camera_line(pipeline: CameraPipeline, sim_time_s: float, paced: bool) -> str:
    """What a vehicle's cameras delivered: each one's rate of the rate asked, and, paced to the
    wall clock, the captures dropped (every render worker busy), the frames late, and how long
    after their capture frames were handed on (a run that is not paced keeps every frame)."""
    accounts = pipeline.accounts
    rates = ", ".join(
        f"{spec.name} {accounts[spec.name].delivered / max(sim_time_s, 1e-9):.1f} of {spec.rate_hz} Hz"
        for spec in pipeline.specs
    )
    if not paced:
        return rates
    dropped = sum(a.dropped for a in accounts.values())
    late = sum(a.late for a in accounts.values())
    age = max((a.median_age_s for a in accounts.values()), default=0.0)
    return f"{rates}; {dropped} dropped, {late} late; frames {age:.2f} s after their capture (median)"
