"""The keyboard driver: hold-to-move teleop from a table of key bindings.

Held keys are tracked from KEYDOWN/KEYUP events (pygame.key.get_pressed() does not see posted
events, and a window that loses focus never gets the KEYUP), and cleared when focus is lost.
Each binding adds a signed unit of one Twist axis while its key is held; the sum is scaled by
the current speeds. Releasing a key stops that motion.
"""

from __future__ import annotations

import enum
import os
from dataclasses import dataclass
from typing import Any

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from quadsim.core.kinematics import clamp
from quadsim.core.types import HEIGHT_MODE_BASE_M, Twist, ZMode
from quadsim.drivers import ASAP, NEVER


class Axis(enum.Enum):
    FORWARD = "linear.x"
    LEFT = "linear.y"
    UP = "linear.z"
    YAW = "angular.z"


@dataclass(frozen=True)
class KeyBinding:
    key: int
    axis: Axis
    sign: float  # a unit in that axis' direction (+1, -1)
    label: str


@dataclass(frozen=True)
class KeyLayout:
    name: str
    bindings: tuple[KeyBinding, ...]
    stop_keys: tuple[int, ...]  # while held: zero command, whatever else is held
    faster_keys: tuple[int, ...]
    slower_keys: tuple[int, ...]

    def help_lines(self) -> list[str]:
        def names(keys: tuple[int, ...]) -> str:
            return ", ".join(pygame.key.name(k) for k in keys)

        out = []
        for axis in Axis:
            keys = [b for b in self.bindings if b.axis is axis]
            out.append(f"{axis.value:10s} " + ", ".join(f"{pygame.key.name(b.key)} {b.label}" for b in keys))
        out.append("stop       " + names(self.stop_keys))
        out.append(f"speed      {names(self.faster_keys)} faster, {names(self.slower_keys)} slower (10% a press)")
        return out


DEFAULT_LAYOUT = KeyLayout(
    "default",
    (
        KeyBinding(pygame.K_UP, Axis.FORWARD, 1.0, "forward"),
        KeyBinding(pygame.K_DOWN, Axis.FORWARD, -1.0, "back"),
        KeyBinding(pygame.K_LEFT, Axis.LEFT, 1.0, "left"),
        KeyBinding(pygame.K_RIGHT, Axis.LEFT, -1.0, "right"),
        KeyBinding(pygame.K_w, Axis.UP, 1.0, "climb"),
        KeyBinding(pygame.K_s, Axis.UP, -1.0, "descend"),
        KeyBinding(pygame.K_a, Axis.YAW, 1.0, "turn left"),
        KeyBinding(pygame.K_d, Axis.YAW, -1.0, "turn right"),
    ),
    stop_keys=(pygame.K_SPACE,),
    faster_keys=(pygame.K_EQUALS, pygame.K_PLUS, pygame.K_KP_PLUS),
    slower_keys=(pygame.K_MINUS, pygame.K_KP_MINUS),
)

#: The layout of ros-teleop's teleop_twist_keyboard (holonomic keys as its shift layer), held.
TELEOP_TWIST_LAYOUT = KeyLayout(
    "teleop_twist_keyboard",
    (
        KeyBinding(pygame.K_i, Axis.FORWARD, 1.0, "forward"),
        KeyBinding(pygame.K_u, Axis.FORWARD, 1.0, "forward+"),
        KeyBinding(pygame.K_o, Axis.FORWARD, 1.0, "forward+"),
        KeyBinding(pygame.K_COMMA, Axis.FORWARD, -1.0, "back"),
        KeyBinding(pygame.K_m, Axis.FORWARD, -1.0, "back+"),
        KeyBinding(pygame.K_PERIOD, Axis.FORWARD, -1.0, "back+"),
        KeyBinding(pygame.K_u, Axis.YAW, 1.0, "turn left"),
        KeyBinding(pygame.K_j, Axis.YAW, 1.0, "turn left"),
        KeyBinding(pygame.K_PERIOD, Axis.YAW, 1.0, "turn left"),
        KeyBinding(pygame.K_o, Axis.YAW, -1.0, "turn right"),
        KeyBinding(pygame.K_l, Axis.YAW, -1.0, "turn right"),
        KeyBinding(pygame.K_m, Axis.YAW, -1.0, "turn right"),
        KeyBinding(pygame.K_h, Axis.LEFT, 1.0, "strafe left"),
        KeyBinding(pygame.K_SEMICOLON, Axis.LEFT, -1.0, "strafe right"),
        KeyBinding(pygame.K_t, Axis.UP, 1.0, "up"),
        KeyBinding(pygame.K_b, Axis.UP, -1.0, "down"),
    ),
    stop_keys=(pygame.K_k,),
    faster_keys=(pygame.K_q,),
    slower_keys=(pygame.K_z,),
)

LAYOUTS = {layout.name: layout for layout in (DEFAULT_LAYOUT, TELEOP_TWIST_LAYOUT)}


@dataclass(frozen=True)
class Speeds:
    linear_mps: float = 1.0
    climb_mps: float = 0.8
    yaw_radps: float = 1.0


class KeyboardDriver:
    """Feed it pygame events with `handle_event`; the loop polls it at the input rate."""

    name = "keyboard"
    finished = False  # a person's input never runs out

    def __init__(
        self, layout: KeyLayout = DEFAULT_LAYOUT, speeds: Speeds = Speeds(), z_mode: ZMode = ZMode.VELOCITY
    ) -> None:
        self.layout = layout
        self.speeds = speeds
        self.scale = 1.0
        self.z_mode = z_mode
        self.held: set[int] = set()
        self.next_poll_step = NEVER  # ASAP after a change: the loop polls at once
        self._last_poll_s: float | None = None
        self._height_offset_m = 0.0  # height z-mode: W/S move the altitude wanted
        self._bound = {b.key for b in layout.bindings} | set(layout.stop_keys)

    def handle_event(self, event: pygame.event.Event) -> bool:
        """Update held keys; True if the event was the driver's."""
        if event.type == pygame.KEYDOWN:
            if event.key in self.layout.faster_keys:
                self.scale = min(5.0, self.scale * 1.1)
            elif event.key in self.layout.slower_keys:
                self.scale = max(0.1, self.scale / 1.1)
            elif event.key in self._bound:
                self.held.add(event.key)
            else:
                return False
            self.next_poll_step = ASAP
            return True
        elif event.type == pygame.KEYUP and event.key in self.held:
            self.held.discard(event.key)
            self.next_poll_step = ASAP
            return True
        elif event.type == pygame.WINDOWFOCUSLOST or (
            event.type == pygame.ACTIVEEVENT and getattr(event, "gain", 1) == 0 and getattr(event, "state", 0) & 2
        ):
            self.clear()
            return True
        return False

    def clear(self) -> None:
        """Forget every held key (focus lost: their KEYUPs will never come)."""
        if self.held:
            self.held.clear()
            self.next_poll_step = ASAP

    def reset(self) -> None:
        self.held.clear()
        self._last_poll_s = None
        self._height_offset_m = 0.0
        self.next_poll_step = NEVER

    def set_z_mode(self, z_mode: ZMode, altitude_m: float) -> None:
        """Follow a z-mode switch; in height mode W/S then move from the current altitude."""
        self.z_mode = z_mode
        self._height_offset_m = altitude_m - HEIGHT_MODE_BASE_M
        self.next_poll_step = ASAP

    def _units(self) -> dict[Axis, float]:
        units = dict.fromkeys(Axis, 0.0)
        if any(k in self.held for k in self.layout.stop_keys):
            return units
        for b in self.layout.bindings:
            if b.key in self.held:
                units[b.axis] += b.sign
        return {a: clamp(v, -1.0, 1.0) for a, v in units.items()}

    def poll(self, step: int, time_s: float) -> Twist:
        self.next_poll_step = NEVER
        u = self._units()
        s, k = self.speeds, self.scale
        dt = 0.0 if self._last_poll_s is None else time_s - self._last_poll_s
        self._last_poll_s = time_s
        if self.z_mode is ZMode.HEIGHT:
            # W/S move the altitude wanted at the climb speed, for as long as they are held
            self._height_offset_m += u[Axis.UP] * s.climb_mps * k * dt
            z = self._height_offset_m
        else:
            z = u[Axis.UP] * s.climb_mps * k
        return Twist(
            linear_x=u[Axis.FORWARD] * s.linear_mps * k,
            linear_y=u[Axis.LEFT] * s.linear_mps * k,
            linear_z=z,
            angular_z=u[Axis.YAW] * s.yaw_radps * k,
        )

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "layout": self.layout.name, "speeds": vars(self.speeds).copy()}
