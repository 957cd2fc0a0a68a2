"""Flight events: take-off, touchdown, landed, crash (and the reset after one), from the vehicle's
contacts and the landing layer's phase.

A new contact is a touchdown when it comes from the air, from below (the contact normal points
up), slowly and upright; any other new contact is a crash: a wall (or anything touched from the
side), the ground at speed, or the ground while tilted. Thresholds are module constants.

A body touched again soon after the vehicle left it is the same contact, a bounce, only if the
vehicle comes back no faster than it hit that body or left it (a rebound returns at most at the
speed it left with; a tumble after a crash at most at the crash's speed): a fall from a height
the vehicle was put at, or a dive soon after a take-off, hits harder and is news.
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
#: after a contact ends, the same body touched again within this time, plus the time a ballistic
#: hop at the speed the vehicle left with takes, is the same contact (a bounce) if no faster than
#: the vehicle hit that body or left it, s
DEBOUNCE_S = 0.5
#: how much faster than that a bounce may come back (the speeds are taken a step before the
#: contact starts or ends, while gravity still acts; the rotors may push), m/s
BOUNCE_SPEED_MARGIN_MPS = 0.5
#: for the length of a hop
_GRAVITY_MPS2 = 9.81


class EventKind(enum.Enum):
    TAKEOFF = "takeoff"
    TOUCHDOWN = "touchdown"
    LANDED = "landed"
    CRASH = "crash"
    RESET = "reset"
    GOAL = "goal"  # a goal taken (flying to it), or dropped for a Twist (quadsim.drivers.goal)
    GOAL_REACHED = "goal_reached"


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
        self._physics_hz = physics_hz
        self._debounce_steps = round(DEBOUNCE_S * physics_hz)
        self.reset()

    def reset(self) -> None:
        # the start pose rests on the floor: that contact is not news
        self._touching: set[str] = {"floor"}
        self._last_touch: dict[str, int] = {}
        #: the speed the vehicle hit each body at (when a contact that was not a bounce began), m/s
        self._hit_at_mps: dict[str, float] = {"floor": 0.0}
        #: the speed the vehicle left each body with (when the contact ended), m/s
        self._left_at_mps: dict[str, float] = {}

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
        speed = math.sqrt(sum(v * v for v in velocity_before_mps))
        if contacts and now != self._touching:
            from_air = not self._touching
            for contact in contacts:
                name = contact.other
                if name in self._touching or self._bounce(name, step, speed):
                    continue
                self._hit_at_mps[name] = speed
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
        for name in self._touching - now:  # contacts that ended in this step
            self._left_at_mps[name] = speed
        self._touching = now
        return events

    def _bounce(self, name: str, step: int, speed_mps: float) -> bool:
        """Whether touching `name` again at `step`, at `speed_mps`, is the contact that ended
        lately coming back: within a hop's ballistic time at the speed it left with, and no
        faster than it hit or left (only the rotors could add the energy for more)."""
        last = self._last_touch.get(name)
        if last is None:
            return False
        left_mps = self._left_at_mps.get(name, 0.0)
        hop_steps = 2.0 * left_mps / _GRAVITY_MPS2 * self._physics_hz
        slower = speed_mps <= max(left_mps, self._hit_at_mps.get(name, 0.0)) + BOUNCE_SPEED_MARGIN_MPS
        return step - last <= self._debounce_steps + hop_steps and slower
