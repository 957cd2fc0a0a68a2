"""Input drivers: where Twist commands come from. They know nothing of physics.

Every driver implements `InputDriver`: the simulation loop polls it at the input rate and
passes whatever it returns to the command gate, stamped with the step of the poll.
"""

from __future__ import annotations

from typing import Any, Protocol

from quadsim.messages import Twist


class InputDriver(Protocol):
    """The one protocol of keyboard, joystick, scripted, replay and programmatic input."""

    name: str
    #: True when the driver has a change to publish before the next input-rate tick (a key
    #: pressed, a stick moved): the loop then polls it at the next step, like the ROS joy
    #: node publishing on change as well as at its autorepeat rate.
    pending: bool

    def poll(self, step: int, time_s: float) -> Twist | None:
        """The command to publish now, or None to publish nothing (silence)."""

    @property
    def finished(self) -> bool:
        """True once the driver has nothing more to say (end of a script or a replay)."""

    def describe(self) -> dict[str, Any]:
        """The driver's definition, as plain data for recordings."""
