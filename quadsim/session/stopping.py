"""Stopping on SIGINT (Ctrl-C), SIGTERM and SIGHUP, at any moment, without a traceback.

A signal is turned into a request, never into an exception thrown into the middle of an
import, a camera pipeline or a file write:
- the first signal only sets `requested`; run loops (a chunk of simulation, a window frame, a
  file of `check`, a benchmark figure) look at it at their next safe point and end normally, so
  the summary is printed and the recording finished; start-up runs to its end first;
- a second signal raises `StopRequested`, a KeyboardInterrupt, which `with` blocks unwind as
  they do for Ctrl-C (for a person who does not want to wait);
- while files are being finished (`with stop.shielded():`), signals only set `requested`.
Either way the program exits 128 + the signal number (130 for SIGINT, 143 for SIGTERM, 129 for
SIGHUP).
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from types import FrameType
from typing import Any

#: the signals that stop a run: Ctrl-C, kill, and the terminal closed (an ssh session dropped)
HANDLED = (signal.SIGINT, signal.SIGTERM, *((signal.SIGHUP,) if hasattr(signal, "SIGHUP") else ()))


class StopRequested(KeyboardInterrupt):
    """A stop asked for by a signal, raised where the program can unwind."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def exit_code(signum: int) -> int:
    return 128 + signum


def describe(signum: int) -> str:
    return (
        "interrupted"
        if signum == signal.SIGINT
        else "hung up"
        if signum == getattr(signal, "SIGHUP", -1)
        else "terminated"
    )


class SignalStop:
    """Installs the SIGINT and SIGTERM handlers for as long as it is entered (main thread only).

    Nested entries share the outermost one (`current()`), so the program's entry point can
    install it before anything heavy is imported and the commands find it."""

    _current: SignalStop | None = None

    def __init__(self) -> None:
        self.signum: int | None = None
        self._shield_depth = 0
        self._previous: dict[int, Any] = {}
        self._owner = False

    @classmethod
    def current(cls) -> SignalStop | None:
        return cls._current

    @property
    def requested(self) -> bool:
        """True once a signal has asked the program to stop."""
        return self.signum is not None

    def __enter__(self) -> SignalStop:
        if SignalStop._current is None:
            SignalStop._current = self
            self._owner = True
            for signum in HANDLED:
                self._previous[signum] = signal.signal(signum, self._handle)
        return SignalStop._current

    def __exit__(self, *exc: object) -> None:
        if self._owner:
            for signum, handler in self._previous.items():
                signal.signal(signum, handler)
            SignalStop._current = None
            self._owner = False

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        first = self.signum is None
        if first:
            self.signum = signum
        if self._shield_depth > 0:
            return  # finishing files: nothing may interrupt that; the request is kept
        if first:
            print(
                "quadsim: stopping at the next safe point (send the signal again to stop at once)",
                file=sys.stderr,
                flush=True,
            )
            return
        raise StopRequested(signum)

    def ignore_from_now(self) -> None:
        """Ignore SIGINT and SIGTERM for the rest of the process (its work is done)."""
        for signum in HANDLED:
            signal.signal(signum, signal.SIG_IGN)
        self._previous.clear()  # nothing to restore on exit

    @contextmanager
    def shielded(self) -> Iterator[SignalStop]:
        """A region no signal interrupts (finishing a recording); a request waits for its end."""
        self._shield_depth += 1
        try:
            yield self
        finally:
            self._shield_depth -= 1


def stop_requested() -> bool:
    """For run loops: has a signal asked the program to stop? (False when none is installed.)"""
    current = SignalStop.current()
    return current is not None and current.requested


def shielded_from_signals() -> AbstractContextManager[object]:
    """`SignalStop.current().shielded()`, or nothing when no SignalStop is installed."""
    current = SignalStop.current()
    return current.shielded() if current is not None else nullcontext()
