"""The replay driver: the commands of a recording, delivered at the exact steps at which the
controller received them when the recording was made."""

from __future__ import annotations

from collections.abc import Iterable, Sized
from typing import Any

from quadsim.core.types import Twist
from quadsim.drivers import NEVER


class ReplayDriver:
    """Delivers each command at its step; `commands` in step order, read as the flight reaches
    them (a list, or a stream from a file). Of several at one step, the last is delivered; one
    at a step the loop did not poll at is skipped (cannot happen in a re-flight; be safe)."""

    name = "replay"

    def __init__(
        self,
        commands: Iterable[tuple[int, Twist]],
        source: str = "",
        count: int | None = None,
        command_timeout_s: float | None = None,
    ) -> None:
        """`command_timeout_s`: the dead-man timeout the commands were flown under, where it was the
        vehicle's own (a fleet vehicle flown from Foxglove); None: the run's."""
        self.command_timeout_s = command_timeout_s
        self._pending = iter(commands)
        self._next = next(self._pending, None)
        self.source = source
        self.count = count if count is not None else len(commands) if isinstance(commands, Sized) else None
        self.next_poll_step = self._next[0] if self._next is not None else NEVER

    def poll(self, step: int, time_s: float) -> Twist | None:
        twist = None
        while self._next is not None and self._next[0] <= step:
            if self._next[0] == step:
                twist = self._next[1]
            self._next = next(self._pending, None)
        self.next_poll_step = self._next[0] if self._next is not None else NEVER
        return twist

    @property
    def finished(self) -> bool:
        return self._next is None

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "source": self.source, "commands": self.count}
