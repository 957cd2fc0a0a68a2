"""What the teleop and replay windows share (`Window`): their display opened, a lost one noticed
(x11_guard), the frame loop, the notices they show for a few seconds, and the display closed
without hanging on a lost X connection."""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable
from typing import TypeVar

import pygame

from quadsim.apps.window.x11_guard import X11Guard
from quadsim.errors import QuadsimError
from quadsim.physics.pybullet_quiet import c_output_silenced

#: SDL's video drivers that draw where no one sees: SDL falls back to "offscreen" when the display
#: named by DISPLAY or WAYLAND_DISPLAY does not answer, and the window then flies unseen, forever
HEADLESS_DRIVERS = frozenset({"offscreen", "dummy"})
#: tries at opening the display before saying it does not answer (a server under heavy load can
#: refuse a connection once)
OPEN_ATTEMPTS = 3


def open_display(
    size: tuple[int, int], caption: str, on_fatal: Callable[[str], None] | None = None
) -> tuple[pygame.Surface, X11Guard | None]:
    """A resizable window of `size`, titled `caption`, and its X11 guard (None off X11), installed
    as soon as the window exists: a window destroyed from outside while the app still starts up
    (loading the world, a first compile: seconds) ends it as cleanly as in flight, where Xlib
    would print its own line and exit. `on_fatal`: see X11Guard.install. A display that does not
    answer is a QuadsimError, not a window no one sees."""
    _init_video()
    pygame.font.init()
    screen = pygame.display.set_mode(size, pygame.RESIZABLE)
    guard = X11Guard.install(on_fatal=on_fatal)
    pygame.display.set_caption(caption)
    return screen, guard


def _init_video() -> None:
    """pygame's display, on a driver that shows the window: SDL's offscreen or dummy driver only
    when SDL_VIDEODRIVER asks for it (the tests, a user's headless set-up)."""
    asked = {name.strip() for name in os.environ.get("SDL_VIDEODRIVER", "").split(",") if name.strip()}
    why = ""
    for attempt in range(OPEN_ATTEMPTS):
        try:
            with c_output_silenced() if attempt else contextlib.nullcontext():  # what SDL said once is enough
                pygame.display.init()
        except pygame.error as exc:  # the driver SDL_VIDEODRIVER names cannot start ("x11 not available")
            why = f"SDL: {exc}"
            continue
        driver = pygame.display.get_driver()
        if driver not in HEADLESS_DRIVERS or driver in asked:
            return
        pygame.display.quit()
        why = f"SDL fell back to its {driver} driver, which shows nothing"
    named = [f"{var}={os.environ[var]}" for var in ("DISPLAY", "WAYLAND_DISPLAY") if os.environ.get(var)]
    raise QuadsimError(
        f"cannot open a window: no display answers on {' or '.join(named) or 'this machine'} ({why}); start "
        "the display server or set DISPLAY right, or unset DISPLAY to work without a window"
    )


def show_starting(screen: pygame.Surface, lines: list[str], guard: X11Guard | None = None) -> None:
    """A window that is not flying yet says what it is doing (it would show black while the world,
    the cameras and a first compile load), in the middle, line under line. Once its display is lost
    (`guard`), nothing: the start-up goes on without touching it, and the frame loop ends the run."""
    if lost(guard):
        return
    screen.fill((18, 20, 26))
    font = pygame.font.Font(None, 28)
    width, height = screen.get_size()
    y = height // 2 - 18 * len(lines)
    for text in lines:
        image = font.render(text, True, (220, 224, 232))
        screen.blit(image, ((width - image.get_width()) // 2, y))
        y += 36
    pygame.display.flip()
    if not lost(guard):
        pygame.event.pump()  # a window manager sees it respond


def lost(guard: X11Guard | None) -> bool:
    """Whether the display went away (destroyed from outside, X connection lost): from then on
    nothing touches it."""
    return guard is not None and guard.lost


def close_display(guard: X11Guard | None) -> None:
    """Close the display, unless it was lost: after a loss SDL's teardown would wait forever on it."""
    if guard is None:
        pygame.display.quit()
    elif not guard.lost:
        guard.uninstall()
        pygame.display.quit()


W = TypeVar("W", bound="Window")


class Window:
    """A window that draws frame after frame until it quits (Esc, closed, its display lost): the
    teleop window and the replay window. `frame()` draws one; the display is touched no more once
    it is lost (`display_lost` says why)."""

    def __init__(self, size: tuple[int, int], caption: str, on_fatal: Callable[[str], None] | None) -> None:
        """The window open (see `open_display`), before its first frame."""
        self.screen, self._x11 = open_display(size, caption, on_fatal)
        self.quit = False
        self.frame_count = 0
        self.show_help = False
        self.notice = ""  # said in the HUD until _notice_until (time.monotonic)
        self._notice_until = 0.0

    def frame(self) -> None:
        raise NotImplementedError

    @property
    def display_lost(self) -> str | None:
        """Why the window's display went away (destroyed from outside, X connection lost), or
        None."""
        return self._x11.reason if self._x11 is not None else None

    def _display_gone(self) -> bool:
        """After each call that touches the display: once it is lost, stop (and touch it no more)."""
        if lost(self._x11):
            self.quit = True
            return True
        return False

    def stop(self) -> None:
        """End the frame loop (Esc, the window closed)."""
        self.quit = True

    def toggle_help(self) -> None:
        self.show_help = not self.show_help

    def _say(self, text: str, seconds: float = 3.0) -> None:
        """A notice in the HUD for `seconds`."""
        self.notice, self._notice_until = text, time.monotonic() + seconds

    def run(
        self: W,
        max_frames: int | None = None,
        before_frame: Callable[[W], None] | None = None,
        stop: Callable[[], bool] | None = None,
    ) -> None:
        """Frames until the window quits, `max_frames` frames, or `stop()` (a signal) says so;
        `before_frame` lets tests post events."""
        while not self.quit and (max_frames is None or self.frame_count < max_frames):
            if stop is not None and stop():
                return
            if before_frame is not None:
                before_frame(self)
            self.frame()

    def close(self) -> None:
        close_display(self._x11)

    def __enter__(self: W) -> W:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
