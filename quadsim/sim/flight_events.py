"""Flight events: take-off, touchdown, landed, crash (and the reset after one), from the vehicle's
contacts and the landing layer's phase.

A new contact is a touchdown when it comes from the air, from below (the contact normal points
up), slowly and upright; any other new contact is a crash: a wall (or anything touched from the
side), the ground at speed, or the ground while tilted. Thresholds are module constants.
"""

from __future__ import annotations

import enum
import math
from typing import NamedTuple

from quadsim.physics.pybullet_world import Contact

#: a contact normal with a smaller world-z component than this is a wall, not something to land on
WALL_NORMAL_Z = 0.7  # 45 degrees
#: body z's world-z component below which a touchdown is a crash (tilted more than 45 degrees)
TILT_UP_Z = 0.7
#: impact speeds above this are crashes, m/s (above the largest descent rate a command asks for)
CRASH_SPEED_MPS = 2.0
#: after a contact ends, the same body touched again within this time is the same contact (bounces), s
DEBOUNCE_S = 0.5


class EventKind(enum.Enum):
    TAKEOFF = "takeoff"
    TOUCHDOWN = "touchdown"
    LANDED = "landed"
    CRASH = "crash"
    RESET = "reset"


class FlightEvent(NamedTuple):
    """Something that happened to the vehicle, at a physics step. `value` is the text /rosout and
    the HUD show; `speed_mps` the impact speed (touchdown, crash); `hit` what was touched."""

    step: int
    kind: EventKind
    value: str
    speed_mps: float | None = None
    hit: str | None = None


class ContactMonitor:
    """Turns each physics step's contacts into touchdown and crash events."""

    def __init__(self, physics_hz: int) -> None:
        self._debounce_steps = round(DEBOUNCE_S * physics_hz)
        self.reset()

    def reset(self) -> None:
        # the start pose rests on the floor: that contact is not news
        self._touching: set[str] = {"floor"}
        self._last_touch: dict[str, int] = {}
        self._airborne_since: int | None = None

    @property
    def touching(self) -> bool:
        """Whether the vehicle touched anything after the last step seen."""
        return bool(self._touching)

    def update(
        self,
        step: int,
        contacts: tuple[Contact, ...],
        velocity_before_mps: tuple[float, float, float],
        body_z_up: float,
    ) -> list[FlightEvent]:
        """Events of the physics step that ended at `step`."""
        events: list[FlightEvent] = []
        now = {c.other for c in contacts}
        if contacts and now != self._touching:
            speed = math.sqrt(sum(v * v for v in velocity_before_mps))
            from_air = not self._touching
            for contact in contacts:
                name = contact.other
                if name in self._touching:
                    continue
                if step - self._last_touch.get(name, -self._debounce_steps - 1) <= self._debounce_steps:
                    continue  # a bounce: the same contact
                wall = contact.normal_z < WALL_NORMAL_Z
                if wall or body_z_up < TILT_UP_Z or speed > CRASH_SPEED_MPS:
                    why = "side" if wall else "tilted" if body_z_up < TILT_UP_Z else "fast"
                    events.append(
                        FlightEvent(step, EventKind.CRASH, f"hit {name} at {speed:.2f} m/s ({why})", speed, name)
                    )
                elif from_air:
                    events.append(FlightEvent(step, EventKind.TOUCHDOWN, f"on {name} at {speed:.2f} m/s", speed, name))
        for name in self._touching | now:
            self._last_touch[name] = step
        self._touching = now
        return events
