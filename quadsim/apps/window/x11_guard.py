"""A window destroyed from outside, or a lost X connection, ends the run cleanly.

Without this, Xlib's default handlers print ("X Error of failed request: BadWindow", "XIO: fatal
IO error") and call exit(1) from inside whatever SDL call met the error: Python never unwinds, so
the recording is left without its summary and needs `recover`.

SDL (2.28, in the pygame wheel) loads the system's libX11 at run time. Once the window is open,
`X11Guard.install` reaches that same library through ctypes and installs:
- an error handler (XSetErrorHandler): a protocol error on the window's connection (BadWindow,
  BadDrawable: the window was destroyed by another client, as `xdotool windowclose` does) is
  recorded instead of exiting. Errors on other connections go to the handler that was there
  before (SDL's, which ends in Xlib's default);
- an IO error handler (XSetIOErrorHandler) and, with libX11 1.7 or later, an IO error *exit*
  handler on the window's connection (XSetIOErrorExitHandler): a lost connection (the X server
  went away; `xkill` or `xdotool windowkill` closed the client) is recorded and Xlib no longer
  calls exit(). From then on Xlib's calls on that connection return at once.

The app looks at `lost` after each call that touches the display (events, flip) and, once it is
set, stops touching the display, finishes its recording and says so (`EXIT_DISPLAY_LOST`).
SDL's own teardown must not run after a loss either: with the connection gone, SDL hiding the
window waits forever for an UnmapNotify that never comes (XIfEvent spinning at 100 % CPU); with
the server gone, closing the second connection SDL keeps for wake-up events would have Xlib call
exit(1) (SDL 2.28's X11_DeleteDevice); after a window destroyed from outside the teardown works,
but SDL puts Xlib's default error handler back before closing the display, so a late BadWindow
would still exit(1). So after any loss the process ends with `end_process`: Python's exit
functions run (but not pygame's, which would tear SDL down), then os._exit. The command line calls it (quadsim.apps.launch); for other programs a loss also
registers it to run first at interpreter exit, with `EXIT_DISPLAY_LOST`.

With a libX11 older than 1.7 (no XSetIOErrorExitHandler), Xlib calls exit() as soon as the IO
error handler returns: that handler then runs the app's `on_fatal` (which finishes the
recording and says so) and ends the process itself with `EXIT_DISPLAY_LOST`. It is a best effort:
it all runs inside the SDL call that met the error, with Xlib's exit() waiting behind it.
(QUADSIM_X11_LEGACY=1 takes that path on a newer libX11, for the tests.)

Nothing is installed when the window is not on X11 (Wayland, the dummy driver) or libX11 cannot
be found in the process: `install` returns None and the app runs as before.
"""

from __future__ import annotations

import atexit
import ctypes
import ctypes.util
import logging
import os
import sys
from collections.abc import Callable
from typing import Any, NoReturn

log = logging.getLogger(__name__)

#: exit code of a run whose window's display was lost (the recording is finished all the same):
#: the run did not end the way the person asked (Esc, closing the window: exit 0), so a script
#: can tell; 1, not 2, because nothing was wrong with the command line or the files
EXIT_DISPLAY_LOST = 1

#: QUADSIM_X11_LEGACY=1: behave as with a libX11 without XSetIOErrorExitHandler (tests)
LEGACY_ENV = "QUADSIM_X11_LEGACY"

#: core X protocol error codes (X.h), 1 to 17, for the message
_ERROR_NAMES = dict(
    enumerate(
        [
            "BadRequest",
            "BadValue",
            "BadWindow",
            "BadPixmap",
            "BadAtom",
            "BadCursor",
            "BadFont",
            "BadMatch",
            "BadDrawable",
            "BadAccess",
            "BadAlloc",
            "BadColor",
            "BadGC",
            "BadIDChoice",
            "BadName",
            "BadLength",
            "BadImplementation",
        ],
        start=1,
    )
)
_WINDOW_GONE = {3, 9}  # BadWindow, BadDrawable


class _XErrorEvent(ctypes.Structure):
    """Xlib's XErrorEvent."""

    _fields_ = [
        ("type", ctypes.c_int),
        ("display", ctypes.c_void_p),
        ("resourceid", ctypes.c_ulong),
        ("serial", ctypes.c_ulong),
        ("error_code", ctypes.c_ubyte),
        ("request_code", ctypes.c_ubyte),
        ("minor_code", ctypes.c_ubyte),
    ]


_ERROR_HANDLER = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.POINTER(_XErrorEvent))
_IO_ERROR_HANDLER = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p)
_IO_ERROR_EXIT_HANDLER = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)

#: every ctypes callback ever handed to Xlib: kept alive for the life of the process (Xlib may
#: hold a pointer to one after its guard is gone, if someone else changed the handlers meanwhile)
_KEEP_ALIVE: list[Any] = []
_active: X11Guard | None = None
_lost_seen = False


def _pointer(callback: Any) -> int:
    return int(ctypes.cast(callback, ctypes.c_void_p).value or 0)


def _load_libx11() -> ctypes.CDLL | None:
    """The libX11 already in the process (the one SDL loaded), never a second copy. Its usual
    name first: looking it up (ctypes.util.find_library runs ldconfig) takes a tenth of a second,
    while the window is open and unguarded."""
    for name in ("libX11.so.6", None):
        if name is None:
            name = ctypes.util.find_library("X11")
            if not name or name == "libX11.so.6":
                return None
        try:
            return ctypes.CDLL(name, mode=os.RTLD_NOLOAD | os.RTLD_LAZY)
        except (OSError, AttributeError):
            continue
    return None


def _display_pointer(capsule: object) -> int | None:
    """The Display* in pygame's get_wm_info()['display'] (a PyCapsule, or an int)."""
    if isinstance(capsule, int):
        return capsule or None
    get = ctypes.pythonapi.PyCapsule_GetPointer
    get.restype = ctypes.c_void_p
    get.argtypes = [ctypes.py_object, ctypes.c_char_p]
    return get(capsule, b"display") or None


class X11Guard:
    """The X error handlers for one window's connection. `install` after the window is open;
    `uninstall` before pygame.display.quit() on a normal end; after a loss, leave the display
    alone and end the process with `end_process`."""

    def __init__(
        self,
        lib: ctypes.CDLL,
        display: int,
        window: int,
        on_fatal: Callable[[str], None] | None,
        use_exit_handler: bool,
    ) -> None:
        self._lib = lib
        self.display = display
        self.window = window
        self.on_fatal = on_fatal
        self.exit_handler = use_exit_handler
        self.reason: str | None = None
        self.errors = 0
        self._installed = False
        lib.XSetErrorHandler.restype = ctypes.c_void_p
        lib.XSetErrorHandler.argtypes = [ctypes.c_void_p]
        lib.XSetIOErrorHandler.restype = ctypes.c_void_p
        lib.XSetIOErrorHandler.argtypes = [ctypes.c_void_p]
        lib.XDisplayString.restype = ctypes.c_char_p
        lib.XDisplayString.argtypes = [ctypes.c_void_p]
        name = lib.XDisplayString(display)
        self.display_name = name.decode(errors="replace") if name else os.environ.get("DISPLAY", "?")
        self._error_cb = _ERROR_HANDLER(self._on_error)
        self._io_cb = _IO_ERROR_HANDLER(self._on_io_error)
        self._exit_cb = _IO_ERROR_EXIT_HANDLER(self._on_io_exit)
        _KEEP_ALIVE.extend([self._error_cb, self._io_cb, self._exit_cb])
        self._previous_error = 0
        self._previous_io = 0

    # --- installing -------------------------------------------------------------------------

    @classmethod
    def install(cls, on_fatal: Callable[[str], None] | None = None) -> X11Guard | None:
        """Guard the pygame window's X connection, or return None when it is not on X11 (or
        libX11 is not in the process). `on_fatal(reason)` is only used with a libX11 older than
        1.7: it must finish the recording and say so; the process ends right after it."""
        global _active
        try:
            import pygame

            if not pygame.display.get_init() or pygame.display.get_driver() != "x11":
                return None
            info = pygame.display.get_wm_info()
            display = _display_pointer(info.get("display"))
            window = int(info.get("window") or 0)
            lib = _load_libx11()
            if display is None or lib is None:
                return None
            legacy = os.environ.get(LEGACY_ENV) == "1"
            guard = cls(lib, display, window, on_fatal, hasattr(lib, "XSetIOErrorExitHandler") and not legacy)
            if _active is not None:
                _active.uninstall()
            guard._install()
            _active = guard
            return guard
        except Exception as exc:  # a guard that cannot be installed changes nothing
            log.debug("X11 guard not installed: %s", exc)
            return None

    def _install(self) -> None:
        lib = self._lib
        self._previous_error = int(lib.XSetErrorHandler(_pointer(self._error_cb)) or 0)
        self._previous_io = int(lib.XSetIOErrorHandler(_pointer(self._io_cb)) or 0)
        if self.exit_handler:
            lib.XSetIOErrorExitHandler.restype = None
            lib.XSetIOErrorExitHandler.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
            lib.XSetIOErrorExitHandler(self.display, _pointer(self._exit_cb), None)
        self._installed = True

    def uninstall(self) -> None:
        """Put back the handlers that were there before (a normal end, before the display is
        closed; never after a loss, when the display must not be touched)."""
        global _active
        if not self._installed:
            return
        self._installed = False
        if _active is self:
            _active = None
        lib = self._lib
        replaced = int(lib.XSetErrorHandler(self._previous_error or None) or 0)
        if replaced != _pointer(self._error_cb):
            lib.XSetErrorHandler(replaced)  # someone installed theirs over ours: keep theirs
        replaced = int(lib.XSetIOErrorHandler(self._previous_io or None) or 0)
        if replaced != _pointer(self._io_cb):
            lib.XSetIOErrorHandler(replaced)
        if self.exit_handler and self.reason is None:
            default = _pointer(lib._XDefaultIOErrorExit)
            lib.XSetIOErrorExitHandler(self.display, default, None)

    # --- state ------------------------------------------------------------------------------

    @property
    def lost(self) -> bool:
        """True once the window's connection is gone or its window was destroyed."""
        return self.reason is not None

    def _mark_lost(self, reason: str) -> None:
        global _lost_seen
        if self.reason is None:
            self.reason = reason
        if not _lost_seen:
            _lost_seen = True
            atexit.register(_end_at_interpreter_exit)

    # --- the handlers (called by Xlib from inside SDL calls: they never raise) --------------

    def _on_error(self, display: int | None, event: Any) -> int:
        try:
            if display != self.display:
                if self._previous_error:
                    return int(_ERROR_HANDLER(self._previous_error)(display, event))
                return 0
            ev = event.contents
            self.errors += 1
            name = _ERROR_NAMES.get(ev.error_code, f"X error {ev.error_code}")
            request = f"{ev.request_code}.{ev.minor_code}" if ev.request_code >= 128 else str(ev.request_code)
            if ev.error_code in _WINDOW_GONE and (ev.resourceid == self.window or not self.window):
                self._mark_lost(f"the window was destroyed by another program: {name} on X request {request}")
            else:
                self._mark_lost(f"X error {name} on request {request}, resource 0x{ev.resourceid:x}")
        except BaseException:
            pass
        return 0

    def _on_io_error(self, display: int | None) -> int:
        try:
            if display != self.display:
                if self._previous_io:  # another connection: as before (Xlib's message and exit)
                    return int(_IO_ERROR_HANDLER(self._previous_io)(display))
                return 0
            self._mark_lost(f"the connection to the X server {self.display_name} was closed")
            if not self.exit_handler:
                # an old libX11 calls exit() when this returns: finish here, then end the process
                reason = self.reason or "the connection to the X server was closed"
                try:
                    if self.on_fatal is not None:
                        self.on_fatal(reason)
                    else:
                        print(f"the window's display was lost ({reason})", file=sys.stderr)
                finally:
                    end_process(EXIT_DISPLAY_LOST)
        except BaseException:
            pass
        return 0

    def _on_io_exit(self, display: int | None, data: int | None) -> None:
        try:
            if display == self.display:
                self._mark_lost(f"the connection to the X server {self.display_name} was closed")
        except BaseException:
            pass


def display_lost() -> bool:
    """Has a guarded window lost its display in this process?"""
    return _lost_seen


def end_process(code: int) -> NoReturn:
    """End the process after a display loss without SDL's teardown: Python's exit functions run
    (logging, multiprocessing, temporary folders), pygame's does not; then os._exit(code)."""
    atexit.unregister(_end_at_interpreter_exit)
    pygame = sys.modules.get("pygame")
    if pygame is not None:
        atexit.unregister(pygame.quit)
    try:
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:
                pass
        os._exit(code)


def _end_at_interpreter_exit() -> None:
    """For programs other than the command line: registered at the first loss, so it runs first
    among the exit functions, before pygame's would touch the dead display."""
    end_process(EXIT_DISPLAY_LOST)
