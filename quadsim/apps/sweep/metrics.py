"""Flight metrics of any run, from its published states, the commands its controller received
and its events: the columns of a sweep's table. Scenario-specific figures stay in
apps/flight_quality.py; these apply to every flight, so runs of different scenarios share columns."""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Sequence

from quadsim.core.types import Twist, VehicleState
from quadsim.sim.flight_events import EventKind, FlightEvent

#: metric name -> what it measures (the table's columns, in this order; NaN where not defined)
METRICS: dict[str, str] = {
    "tracking_rms_mps": "RMS of the horizontal velocity error against the command (velocity commands only)",
    "settle_time_s": "time after the last command change until the horizontal velocity stays within 0.1 m/s of it",
    "max_tilt_deg": "largest angle between the body's z axis and the vertical",
    "end_drift_m": "how far it wandered over the last 5 s while commanded to hold still",
    "max_altitude_m": "highest altitude reached",
    "distance_m": "path length flown",
    "crashes": "contacts reported as crashes",
    "touchdown_speed_mps": "fastest touchdown (impact speed at ground contact)",
}

_SETTLE_BAND_MPS = 0.1
_DRIFT_WINDOW_S = 5.0


def _tilt_deg(s: VehicleState) -> float:
    x, y, _, _ = s.orientation_xyzw
    # body z in world: its vertical component is 1 - 2(x^2 + y^2)
    return math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y)))))


def _horizontal_error(s: VehicleState, cmd: Twist) -> float:
    yaw = s.yaw_rad()
    c, sn = math.cos(yaw), math.sin(yaw)
    want_x = c * cmd.linear_x - sn * cmd.linear_y  # the command is in the heading frame
    want_y = sn * cmd.linear_x + c * cmd.linear_y
    vx, vy, _ = s.linear_velocity_mps
    return math.hypot(vx - want_x, vy - want_y)


def flight_metrics(
    states: Sequence[VehicleState],
    commands: Sequence[tuple[int, Twist]],
    physics_hz: int,
    events: Sequence[FlightEvent] = (),
) -> dict[str, float]:
    """Every metric of METRICS for one flight (NaN where it has no meaning for this flight)."""
    out = dict.fromkeys(METRICS, math.nan)
    if not states:
        return out
    steps = [step for step, _ in commands]

    def command_at(step: int) -> Twist | None:
        i = bisect.bisect_right(steps, step) - 1
        return commands[i][1] if i >= 0 else None

    errors = []
    for s in states:
        cmd = command_at(s.step)
        if cmd is not None:
            errors.append(_horizontal_error(s, cmd))
    if errors:
        out["tracking_rms_mps"] = math.sqrt(sum(e * e for e in errors) / len(errors))

    # settle: from the last change of the horizontal command
    change_step = None
    for (_, a), (step, b) in itertools.pairwise(commands):
        if (a.linear_x, a.linear_y) != (b.linear_x, b.linear_y):
            change_step = step
    if change_step is not None:
        last_outside = change_step
        for s in states:
            cmd = command_at(s.step)
            if s.step >= change_step and cmd is not None and _horizontal_error(s, cmd) > _SETTLE_BAND_MPS:
                last_outside = s.step
        out["settle_time_s"] = (last_outside - change_step) / physics_hz

    out["max_tilt_deg"] = max(_tilt_deg(s) for s in states)
    out["max_altitude_m"] = max(s.position_m[2] for s in states)
    out["distance_m"] = sum(math.dist(a.position_m, b.position_m) for a, b in itertools.pairwise(states))

    end = states[-1].step
    window_start = end - round(_DRIFT_WINDOW_S * physics_hz)
    window = [s for s in states if s.step >= window_start]
    holding = all((c := command_at(s.step)) is None or (c.linear_x, c.linear_y) == (0.0, 0.0) for s in window)
    if window and holding and window_start >= states[0].step:
        ref = window[0].position_m
        out["end_drift_m"] = max(math.dist(s.position_m, ref) for s in window)

    out["crashes"] = float(sum(e.kind is EventKind.CRASH for e in events))
    touchdowns = [e.speed_mps for e in events if e.kind is EventKind.TOUCHDOWN and e.speed_mps is not None]
    if touchdowns:
        out["touchdown_speed_mps"] = max(touchdowns)
    return out
