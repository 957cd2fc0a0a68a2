"""A small progress bar for long headless work, on stderr, that stays quiet when not a terminal."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class ProgressBar:
    """Redraws at most ten times a second on a terminal; elsewhere prints a line per quarter. With
    `eta`, each line says when the work will be done at the pace so far."""

    def __init__(
        self, total: float, label: str, stream: TextIO | None = None, unit: str = "s", eta: bool = False
    ) -> None:
        self.total = total
        self._eta = Eta(total) if eta else None
        self.label = label
        self.unit = unit
        self.stream = stream if stream is not None else sys.stderr
        self._tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self._last_draw = 0.0
        self._next_quarter = 0.25

    def _amount(self, value: float) -> str:
        return f"{value:g}" if isinstance(self.total, int) else f"{value:.1f}"

    def update(self, done: float, extra: str = "") -> None:
        if self._eta is not None and not extra:
            extra = self._eta.text(done)
        frac = 0.0 if self.total <= 0 else min(1.0, done / self.total)
        if self._tty:
            now = time.monotonic()
            if now - self._last_draw < 0.1 and frac < 1.0:
                return
            self._last_draw = now
            width = 30
            filled = int(frac * width)
            bar = "#" * filled + "-" * (width - filled)
            line = f"\r{self.label} [{bar}] {self._amount(done):>7}/{self._amount(self.total)} {self.unit} {extra}"
            print(line, end="", file=self.stream, flush=True)
        elif frac >= self._next_quarter:
            while frac >= self._next_quarter:
                self._next_quarter += 0.25
            line = f"{self.label}: {frac * 100:3.0f}% ({self._amount(done)}/{self._amount(self.total)} {self.unit}) {extra}"
            print(line, file=self.stream, flush=True)

    def close(self) -> None:
        if self._tty:
            print(file=self.stream, flush=True)


class Eta:
    """Work done per second since the start (runs, simulated seconds), and the time left at that pace."""

    def __init__(self, total: float) -> None:
        self.total = total
        self.t0 = time.monotonic()

    def text(self, done: float) -> str:
        elapsed = time.monotonic() - self.t0
        if done == 0 or elapsed <= 0:
            return ""
        left = (self.total - done) * elapsed / done
        return f"ETA {_clock(left)}" if done < self.total else f"in {_clock(elapsed)}"


def _clock(seconds: float) -> str:
    s = round(seconds)
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"
