"""What the teleop and replay windows share: their display opened, a lost one noticed (x11_guard),
the frame loop, and the display closed without hanging on a lost X connection."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol, TypeVar

import pygame

from quadsim.apps.window.x11_guard import X11Guard


class FrameLoop(Protocol):
    """A window that draws frame after frame until it quits."""

    quit: bool
    frame_count: int

    def frame(self) -> None: ...


W = TypeVar("W", bound=FrameLoop)


def open_display(size: tuple[int, int], caption: str) -> pygame.Surface:
    """A resizable window of `size`, titled `caption`."""
    pygame.display.init()
    pygame.font.init()
    screen = pygame.display.set_mode(size, pygame.RESIZABLE)
    pygame.display.set_caption(caption)
    return screen


def lost(guard: X11Guard | None) -> bool:
    """Whether the display went away (destroyed from outside, X connection lost): from then on
    nothing touches it."""
    return guard is not None and guard.lost


def run_frames(
    window: W,
    max_frames: int | None = None,
    before_frame: Callable[[W], None] | None = None,
    stop: Callable[[], bool] | None = None,
) -> None:
    """Frames until the window quits, `max_frames` frames, or `stop()` (a signal) says so;
    `before_frame` lets tests post events."""
    while not window.quit and (max_frames is None or window.frame_count < max_frames):
        if stop is not None and stop():
            return
        if before_frame is not None:
            before_frame(window)
        window.frame()


def close_display(guard: X11Guard | None) -> None:
    """Close the display, unless it was lost: after a loss SDL's teardown would wait forever on it."""
    if guard is None:
        pygame.display.quit()
    elif not guard.lost:
        guard.uninstall()
        pygame.display.quit()
