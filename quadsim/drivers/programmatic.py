"""The programmatic driver: autonomy code sets the Twist to publish, like a ROS publisher."""

from __future__ import annotations

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
    next_poll_step = NEVER  # commands follow the input rate only

    def __init__(self) -> None:
        self._twist: Twist | None = None

    def send(self, twist: Twist) -> None:
        self._twist = twist

    def stop(self) -> None:
        self._twist = None

    def poll(self, step: int, time_s: float) -> Twist | None:
        return self._twist

    @property
    def finished(self) -> bool:
        return False

    def describe(self) -> dict[str, Any]:
        return {"name": self.name}
