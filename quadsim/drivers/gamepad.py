"""The devices behind the joystick driver: pads SDL knows, read through its game-controller layer
by named axis, and other joysticks read raw; both report in the ROS `joy` node's convention.

SDL's game-controller layer (pygame's `_sdl2.controller`) puts every pad it has a mapping for
(Xbox, PlayStation, Switch and their clones) into one layout, the one ROS 2's
`game_controller_node` publishes: axes 0 leftx, 1 lefty, 2 rightx, 3 righty, 4 lefttrigger,
5 righttrigger; buttons a, b, x, y, back, guide, start, leftstick, rightstick, leftshoulder,
rightshoulder, dpup, dpdown, dpleft, dpright, misc1, paddle1-4, touchpad. A joystick SDL has no
mapping for keeps its own axis order, then two axes per hat, as the ROS `joy_node` publishes it.
Either way the values are SDL's negated (stick up and left positive, triggers 0 released and
-1 pressed on a game controller), scaled by 32767 as the ROS nodes do, before any deadzone.
"""

from __future__ import annotations

import contextlib
import enum
import os
from types import ModuleType
from typing import Protocol

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

#: /joy's axis names on an SDL game controller, by index
GAME_CONTROLLER_AXES: tuple[str, ...] = ("leftx", "lefty", "rightx", "righty", "lefttrigger", "righttrigger")
#: how many /joy buttons an SDL game controller has: those the module's docstring names, in their
#: order (SDL_CONTROLLER_BUTTON_*), as far as this SDL knows them
GAME_CONTROLLER_BUTTON_COUNT = 21


#: what a person calls a game controller's axes: (control, direction when positive, when negative)
_CONTROLLER_AXIS_WORDS = (
    ("left stick", "left", "right"),
    ("left stick", "up", "down"),
    ("right stick", "left", "right"),
    ("right stick", "up", "down"),
    ("left trigger", "released", "pressed"),
    ("right trigger", "released", "pressed"),
)


class PadKind(enum.Enum):
    GAME_CONTROLLER = "SDL game controller"
    JOYSTICK = "joystick"


class Pad(Protocol):
    """One opened device, read in /joy's order and sign (before the deadzone)."""

    kind: PadKind
    name: str
    instance_id: int  # SDL's id of the device while it stays plugged in (JOYDEVICEREMOVED's)
    axis_names: tuple[str, ...]  # /joy axis index -> what a person calls it ("right stick up/down")

    def read(self) -> tuple[tuple[float, ...], tuple[int, ...]]: ...
    def held(self, index: int, value: float) -> str: ...
    def close(self) -> None: ...


def ros_axis(raw: int) -> float:
    """SDL's -32768..32767 as the ROS joy nodes report it: -1..1 with the sign turned (SDL's stick
    up and left are negative, ROS's positive)."""
    return -max(raw, -32767) / 32767.0


def controller_layer() -> ModuleType | None:
    """pygame's SDL game-controller module, initialised; None where pygame has none."""
    try:
        from pygame._sdl2 import controller
    except ImportError:
        return None
    try:
        controller.init()
    except pygame.error:
        return None
    return controller


class GameControllerPad:
    """A pad SDL has a mapping for, read by named axis and button."""

    kind = PadKind.GAME_CONTROLLER
    axis_names = tuple(
        control if control.endswith("trigger") else f"{control} {positive}/{negative}"
        for control, positive, negative in _CONTROLLER_AXIS_WORDS
    )

    def __init__(self, controller_module: ModuleType, device_index: int) -> None:
        self._joystick = pygame.joystick.Joystick(device_index)
        self._controller = controller_module.Controller.from_joystick(self._joystick)
        controller_module.update()  # else the layer reports the triggers as 0 until the next event pump
        self.name = self._controller.name or self._joystick.get_name()
        self.instance_id = self._joystick.get_instance_id()
        self._nbuttons = min(GAME_CONTROLLER_BUTTON_COUNT, int(getattr(pygame, "CONTROLLER_BUTTON_MAX", 15)))

    def read(self) -> tuple[tuple[float, ...], tuple[int, ...]]:
        c = self._controller
        axes = tuple(ros_axis(c.get_axis(i)) for i in range(len(GAME_CONTROLLER_AXES)))
        return axes, tuple(int(c.get_button(i)) for i in range(self._nbuttons))

    def held(self, index: int, value: float) -> str:
        """Where /joy axis `index` reading `value` is held, in words ("right stick held up")."""
        control, positive, negative = _CONTROLLER_AXIS_WORDS[index]
        if control.endswith("trigger"):
            return f"{control} held"
        return f"{control} held {positive if value > 0 else negative}"

    def close(self) -> None:
        for thing in (self._controller, self._joystick):
            with contextlib.suppress(pygame.error):
                thing.quit()


class JoystickPad:
    """Any other joystick: its own axes, then two per hat (left and up positive), then buttons."""

    kind = PadKind.JOYSTICK

    def __init__(self, device_index: int) -> None:
        self._joystick = pygame.joystick.Joystick(device_index)
        self.name = self._joystick.get_name()
        self.instance_id = self._joystick.get_instance_id()
        naxes, nhats = self._joystick.get_numaxes(), self._joystick.get_numhats()
        self.axis_names = tuple(f"axis {i}" for i in range(naxes)) + tuple(
            f"hat {h} {d}" for h in range(nhats) for d in ("left/right", "up/down")
        )

    def read(self) -> tuple[tuple[float, ...], tuple[int, ...]]:
        j = self._joystick
        # pygame scales SDL's integer by 1/32768; undo that to scale as ROS does
        axes = [ros_axis(round(j.get_axis(i) * 32768.0)) for i in range(j.get_numaxes())]
        for h in range(j.get_numhats()):
            x, y = j.get_hat(h)  # pygame: x right +, y up +
            axes += [float(-x), float(y)]
        return tuple(axes), tuple(int(j.get_button(i)) for i in range(j.get_numbuttons()))

    def held(self, index: int, value: float) -> str:
        return f"{self.axis_names[index]} held at {value:+.2f}"

    def close(self) -> None:
        with contextlib.suppress(pygame.error):
            self._joystick.quit()


def is_game_controller(device_index: int) -> bool:
    """Whether SDL has a game-controller mapping for device `device_index`."""
    controller = controller_layer()
    return controller is not None and bool(controller.is_controller(device_index))


def open_pad(device_index: int) -> Pad:
    """Open SDL device `device_index`: through the game-controller layer if SDL knows the pad.
    Raises pygame.error if the device cannot be opened (gone again, or not a joystick)."""
    if not 0 <= device_index < pygame.joystick.get_count():
        raise pygame.error(f"no joystick device {device_index}")
    controller = controller_layer()
    if controller is not None and controller.is_controller(device_index):
        return GameControllerPad(controller, device_index)
    return JoystickPad(device_index)
