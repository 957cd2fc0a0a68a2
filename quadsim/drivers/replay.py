"""The replay driver: the commands of a recording, delivered at the exact steps at which the
controller received them when the recording was made."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from quadsim.core.types import Twist
from quadsim.drivers import NEVER


class ReplayDriver:
    name = "replay"

    def __init__(self, commands: Sequence[tuple[int, Twist]], source: str = "") -> None:
        self._commands = sorted(commands, key=lambda c: c[0])
        self._index = 0
        self.source = source
        self.next_poll_step = self._commands[0][0] if self._commands else NEVER

    def poll(self, step: int, time_s: float) -> Twist | None:
        commands, i = self._commands, self._index
        while i < len(commands) and commands[i][0] < step:
            i += 1  # a step the loop did not poll at (cannot happen in a re-flight; be safe)
        twist = None
        if i < len(commands) and commands[i][0] == step:
            twist = commands[i][1]
            i += 1
        self._index = i
        self.next_poll_step = commands[i][0] if i < len(commands) else NEVER
        return twist

    @property
    def finished(self) -> bool:
        return self._index >= len(self._commands)

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "source": self.source, "commands": len(self._commands)}
