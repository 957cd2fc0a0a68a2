"""The programmatic driver: autonomy code sets the Twist to publish, like a ROS publisher."""

from __future__ import annotations

import math
from typing import Any

from quadsim.core.types import Twist
from quadsim.drivers import NEVER


class ProgrammaticDriver:
    """Publishes the last Twist given to `send` at every poll, until `stop` is called.

    Like a joystick held still: the command keeps arriving, so the dead-man timeout does not
    fire. After `stop()` (or before the first `send`) nothing is published, and the gate's
    timeout brings the vehicle to a hold.
    """

    name = "programmatic"
    finished = False  # a program's input never runs out
    next_poll_step = NEVER  # commands follow the input rate only

    def __init__(self) -> None:
        self._twist: Twist | None = None

    def send(self, twist: Twist) -> None:
        """Publish `twist` from the next poll on. Checked here, so a mistake shows at its source."""
        if not isinstance(twist, Twist):
            raise TypeError(f"send() takes a quadsim.Twist, got {type(twist).__name__}: {twist!r}")
        for name, value in zip(Twist._fields, twist):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError(f"Twist.{name} must be a number, got {type(value).__name__}: {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"Twist.{name} must be finite, got {value}")
        self._twist = Twist(**{name: float(v) for name, v in twist._asdict().items()})

    def stop(self) -> None:
        self._twist = None

    def poll(self, step: int, time_s: float) -> Twist | None:
        return self._twist

    def describe(self) -> dict[str, Any]:
        return {"name": self.name}


class IdleDriver(ProgrammaticDriver):
    """A vehicle no one flies (a fleet file's `input = "idle"`): its rotors stay still until
    something sends it a command from Python (`fleet["delta"].send(...)`); it says "idle"
    wherever its input is named (a recording's info, replay)."""

    name = "idle"
