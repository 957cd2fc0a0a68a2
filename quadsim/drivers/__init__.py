"""Input drivers: where Twist commands come from. They know nothing of physics.

Every driver implements `InputDriver`: the simulation loop polls it at the input rate and
passes whatever it returns to the command gate, stamped with the step of the poll.
"""

from __future__ import annotations

import sys
from typing import Any, Protocol

from quadsim.core.types import Twist

ASAP = 0
NEVER = sys.maxsize


class InputDriver(Protocol):
    """The one protocol of keyboard, joystick, scripted, replay and programmatic input."""

    name: str
    #: Besides the input-rate ticks, the loop polls the driver at every step n >= next_poll_step.
    #: Keyboard and joystick set it to ASAP when a key or stick changes (like the ROS joy node
    #: publishing on change as well as at its autorepeat rate) and back to NEVER once polled;
    #: the replay driver sets it to the step of its next recorded command.
    next_poll_step: int

    def poll(self, step: int, time_s: float) -> Twist | None:
        """The command to publish now, or None to publish nothing (silence)."""

    @property
    def finished(self) -> bool:
        """True once the driver has nothing more to say (end of a script or a replay)."""

    def describe(self) -> dict[str, Any]:
        """The driver's definition, as plain data for recordings."""

    # Optional: `preferred_z_mode: ZMode | None`, the z-mode the driver's commands are written
    # for (a script's `z_mode` line). A SimConfig without a z_mode takes it.
    # Optional: `rewind()`, start over from the beginning: a Simulator's reset calls it (a script
    # plays again from its start when the clock does).
    # Optional: `command_timeout_s: float | None`, how long the gate holds the driver's last
    # command without a new one (the dead-man timeout) when the driver knows better than the run's
    # default: a live input whose clients send nothing on release (subscribed.py), recorded
    # commands re-flown under the timeout they were flown with (replay.py). None: the config's.
