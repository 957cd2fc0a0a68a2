"""Virtual joysticks in pygame's own SDL library, through ctypes: a device plugged in this way goes
through the same SDL device path (JOYDEVICEADDED, the game-controller layer, axis state) as a real
pad. SDL 2.0.14 and later (pygame 2.6.1 bundles 2.28.4); signatures as in its SDL_joystick.h:

    int SDL_JoystickAttachVirtual(SDL_JoystickType type, int naxes, int nbuttons, int nhats);
    int SDL_JoystickDetachVirtual(int device_index);
    int SDL_JoystickSetVirtualAxis(SDL_Joystick *joystick, int axis, Sint16 value);
    int SDL_JoystickSetVirtualButton(SDL_Joystick *joystick, int button, Uint8 value);
    int SDL_JoystickSetVirtualHat(SDL_Joystick *joystick, int hat, Uint8 value);

A virtual device typed SDL_JOYSTICK_TYPE_GAMECONTROLLER with 6 axes and 15 buttons gets SDL's
standard mapping (leftx lefty rightx righty lefttrigger righttrigger; triggers start at -32768,
released). Values are set in SDL's own sign and range: stick up and left negative.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import glob
import os

import pygame

SDL_JOYSTICK_TYPE_UNKNOWN = 0
SDL_JOYSTICK_TYPE_GAMECONTROLLER = 1
SDL_HAT_CENTERED, SDL_HAT_UP, SDL_HAT_RIGHT, SDL_HAT_DOWN, SDL_HAT_LEFT = 0, 1, 2, 4, 8

LEFTX, LEFTY, RIGHTX, RIGHTY, TRIGGERLEFT, TRIGGERRIGHT = range(6)


def pygame_sdl_library_path() -> str:
    """The SDL2 shared library pygame's own modules use (inside the wheel where it bundles one)."""
    package = os.path.dirname(pygame.__file__)
    for folder in (os.path.join(package, os.pardir, "pygame.libs"), package):  # Linux wheels, then others
        found = sorted(glob.glob(os.path.join(folder, "libSDL2-2*.so*")) + glob.glob(os.path.join(folder, "SDL2*.dll")))
        if found:
            return os.path.normpath(found[0])
    system = ctypes.util.find_library("SDL2-2.0") or ctypes.util.find_library("SDL2")
    if system is None:
        raise OSError("no SDL2 library found beside pygame or on the system")
    return system


class SDL:
    """The few SDL functions the tests need, with their C signatures."""

    def __init__(self) -> None:
        lib = ctypes.CDLL(pygame_sdl_library_path())
        c_int, ptr = ctypes.c_int, ctypes.c_void_p
        for name, restype, argtypes in (
            ("SDL_JoystickAttachVirtual", c_int, [c_int, c_int, c_int, c_int]),
            ("SDL_JoystickDetachVirtual", c_int, [c_int]),
            ("SDL_JoystickSetVirtualAxis", c_int, [ptr, c_int, ctypes.c_int16]),
            ("SDL_JoystickSetVirtualButton", c_int, [ptr, c_int, ctypes.c_uint8]),
            ("SDL_JoystickSetVirtualHat", c_int, [ptr, c_int, ctypes.c_uint8]),
            ("SDL_JoystickOpen", ptr, [c_int]),
            ("SDL_JoystickClose", None, [ptr]),
            ("SDL_JoystickInstanceID", ctypes.c_int32, [ptr]),
            ("SDL_JoystickGetDeviceInstanceID", ctypes.c_int32, [c_int]),
            ("SDL_NumJoysticks", c_int, []),
            ("SDL_GetError", ctypes.c_char_p, []),
            ("SDL_SetHint", ctypes.c_int, [ctypes.c_char_p, ctypes.c_char_p]),
        ):
            fn = getattr(lib, name)
            fn.restype, fn.argtypes = restype, argtypes
        self.lib = lib

    def allow_background_events(self) -> None:
        """Let joystick input through while no window has keyboard focus. SDL ignores stick moves
        away from the centre unless a window of the process has focus (SDL_HINT_JOYSTICK_ALLOW_
        BACKGROUND_EVENTS, default off), and a window of the dummy video driver never gets it."""
        self.lib.SDL_SetHint(b"SDL_JOYSTICK_ALLOW_BACKGROUND_EVENTS", b"1")

    def check(self, result: int, what: str) -> int:
        if result < 0:
            raise OSError(f"{what} failed: {self.lib.SDL_GetError().decode(errors='replace')}")
        return result


_sdl: SDL | None = None


def sdl() -> SDL:
    global _sdl
    if _sdl is None:
        _sdl = SDL()
    return _sdl


def _raw(value: float) -> int:
    """-1..1 to SDL's Sint16 (-1 is -32768, as a released trigger reads)."""
    return max(-32768, min(32767, round(value * 32767) if value > -1.0 else -32768))


class VirtualPad:
    """One virtual device. `axes` are set before the device is announced, as a pad plugged in with
    its sticks already held would be."""

    def __init__(
        self,
        game_controller: bool = True,
        naxes: int = 6,
        nbuttons: int = 15,
        nhats: int = 0,
        axes: dict[int, float] | None = None,
    ) -> None:
        self.sdl = sdl()
        self.game_controller = game_controller
        self.shape = (naxes, nbuttons, nhats)
        self.instance_id: int | None = None
        self._handle: int | None = None
        self.plug(axes)

    def plug(self, axes: dict[int, float] | None = None) -> None:
        lib = self.sdl.lib
        kind = SDL_JOYSTICK_TYPE_GAMECONTROLLER if self.game_controller else SDL_JOYSTICK_TYPE_UNKNOWN
        index = self.sdl.check(lib.SDL_JoystickAttachVirtual(kind, *self.shape), "SDL_JoystickAttachVirtual")
        handle = lib.SDL_JoystickOpen(index)
        if not handle:
            raise OSError(f"SDL_JoystickOpen failed: {lib.SDL_GetError().decode(errors='replace')}")
        self._handle = handle
        self.instance_id = lib.SDL_JoystickInstanceID(handle)
        for axis, value in (axes or {}).items():
            self.set_axis(axis, value)

    def set_axis(self, axis: int, value: float) -> None:
        """`value` in SDL's sign: stick up and left negative; a trigger -1 released, +1 pressed."""
        self.sdl.check(self.sdl.lib.SDL_JoystickSetVirtualAxis(self._handle, axis, _raw(value)), "SetVirtualAxis")

    def set_button(self, button: int, pressed: bool) -> None:
        self.sdl.check(
            self.sdl.lib.SDL_JoystickSetVirtualButton(self._handle, button, int(pressed)), "SetVirtualButton"
        )

    def set_hat(self, hat: int, value: int) -> None:
        self.sdl.check(self.sdl.lib.SDL_JoystickSetVirtualHat(self._handle, hat, value), "SetVirtualHat")

    def centre(self) -> None:
        for axis in range(self.shape[0]):
            rest = -1.0 if self.game_controller and axis in (TRIGGERLEFT, TRIGGERRIGHT) else 0.0
            self.set_axis(axis, rest)

    def device_index(self) -> int | None:
        lib = self.sdl.lib
        for i in range(lib.SDL_NumJoysticks()):
            if lib.SDL_JoystickGetDeviceInstanceID(i) == self.instance_id:
                return i
        return None

    def unplug(self) -> None:
        if self._handle is None:
            return
        lib = self.sdl.lib
        index = self.device_index()
        lib.SDL_JoystickClose(self._handle)
        self._handle = None
        if index is not None:
            self.sdl.check(lib.SDL_JoystickDetachVirtual(index), "SDL_JoystickDetachVirtual")
