"""The joystick driver: a gamepad in "mode 2" (left stick climb and yaw, right stick forward and
sideways), with a rescaled deadzone, optional enable and turbo buttons (as teleop_twist_joy),
a mapping file, and hot-plug.

The device is anything with pygame.joystick.Joystick's reading methods, made by a factory from
a device index, so tests can plug in a device of their own through JOYDEVICEADDED events.
Unplugged, the driver publishes nothing: the dead-man timeout then holds position.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Protocol

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from quadsim.core.toml_compat import tomllib
from quadsim.core.types import HEIGHT_MODE_BASE_M, Twist, ZMode
from quadsim.drivers import ASAP, NEVER
from quadsim.errors import ConfigError


class JoystickDevice(Protocol):
    def get_name(self) -> str: ...
    def get_instance_id(self) -> int: ...
    def get_numaxes(self) -> int: ...
    def get_axis(self, i: int) -> float: ...
    def get_numbuttons(self) -> int: ...
    def get_button(self, i: int) -> int: ...


@dataclass(frozen=True)
class AxisMap:
    index: int
    scale: float  # sign and size: SDL's stick up is negative, so "up = +" axes have a negative scale


@dataclass(frozen=True)
class JoystickMapping:
    """Which stick moves which Twist field, and the buttons. Defaults: mode 2 on an
    Xbox-style pad as SDL numbers it (axes 0/1 left stick, 3/4 right stick)."""

    forward: AxisMap = AxisMap(4, -1.0)  # right stick up
    left: AxisMap = AxisMap(3, -1.0)  # right stick left
    up: AxisMap = AxisMap(1, -1.0)  # left stick up
    yaw: AxisMap = AxisMap(0, -1.0)  # left stick left = counter-clockwise
    deadzone: float = 0.1
    linear_mps: float = 1.5
    climb_mps: float = 1.0
    yaw_radps: float = 1.2
    enable_button: int | None = None  # if set, motion only while it is held
    turbo_button: int | None = None
    turbo_factor: float = 2.0

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def load_mapping(path: Path) -> JoystickMapping:
    """A TOML mapping file: any of JoystickMapping's fields; axes as {index = N, scale = S}."""
    try:
        with open(path, "rb") as fh:
            table = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"joystick mapping file not found: {path}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None
    fields = {f for f in JoystickMapping.__dataclass_fields__}
    unknown = set(table) - fields
    if unknown:
        raise ConfigError(f"{path}: unknown key(s) {', '.join(sorted(unknown))}; known: {', '.join(sorted(fields))}")
    values: dict[str, Any] = {}
    for key, value in table.items():
        if key in ("forward", "left", "up", "yaw"):
            if not isinstance(value, dict) or not isinstance(value.get("index"), int):
                raise ConfigError(f"{path}: {key} must be {{ index = N, scale = S }}")
            values[key] = AxisMap(value["index"], float(value.get("scale", 1.0)))
        else:
            values[key] = value
    mapping = JoystickMapping(**values)
    if not 0.0 <= mapping.deadzone < 0.9:
        raise ConfigError(f"{path}: deadzone must be in [0, 0.9)")
    return mapping


def apply_deadzone(value: float, deadzone: float) -> float:
    """Zero inside the deadzone, rescaled outside it so the output is continuous and reaches 1."""
    if -deadzone <= value <= deadzone:
        return 0.0
    sign = 1.0 if value > 0 else -1.0
    return sign * min(1.0, (abs(value) - deadzone) / (1.0 - deadzone))


def _pygame_device(index: int) -> JoystickDevice:
    joystick = pygame.joystick.Joystick(index)
    joystick.init()
    return joystick


class JoystickDriver:
    name = "joystick"

    def __init__(
        self,
        mapping: JoystickMapping = JoystickMapping(),
        z_mode: ZMode = ZMode.VELOCITY,
        device_factory: Callable[[int], JoystickDevice] = _pygame_device,
    ) -> None:
        self.mapping = mapping
        self.z_mode = z_mode
        self.device: JoystickDevice | None = None
        self.status = "no joystick"
        self.next_poll_step = NEVER
        self.joy_sinks: list[Callable[[int, tuple[float, ...], tuple[int, ...]], None]] = []
        self._factory = device_factory
        self._last_poll_s: float | None = None
        self._height_offset_m = 0.0

    # --- devices ----------------------------------------------------------------------------

    def attach(self, index: int) -> None:
        if self.device is None:
            self.device = self._factory(index)
            self.status = f"joystick: {self.device.get_name()}"
            self.next_poll_step = ASAP

    def handle_event(self, event: pygame.event.Event) -> bool:
        if event.type == pygame.JOYDEVICEADDED:
            self.attach(event.device_index)
            return True
        if event.type == pygame.JOYDEVICEREMOVED:
            if self.device is not None and event.instance_id == self.device.get_instance_id():
                self.device = None
                self.status = "joystick unplugged: holding position"
            return True
        if event.type in (pygame.JOYAXISMOTION, pygame.JOYBUTTONDOWN, pygame.JOYBUTTONUP):
            self.next_poll_step = ASAP
            return True
        return False

    # --- reading ----------------------------------------------------------------------------

    def raw(self) -> tuple[tuple[float, ...], tuple[int, ...]]:
        d = self.device
        if d is None:
            return (), ()
        return (
            tuple(d.get_axis(i) for i in range(d.get_numaxes())),
            tuple(d.get_button(i) for i in range(d.get_numbuttons())),
        )

    def twist_from(self, axes: tuple[float, ...], buttons: tuple[int, ...], dt_s: float) -> Twist:
        m = self.mapping

        def axis(a: AxisMap) -> float:
            return apply_deadzone(axes[a.index], m.deadzone) * a.scale if a.index < len(axes) else 0.0

        def pressed(b: int | None) -> bool:
            return b is not None and b < len(buttons) and bool(buttons[b])

        enabled = m.enable_button is None or pressed(m.enable_button)
        k = (m.turbo_factor if pressed(m.turbo_button) else 1.0) if enabled else 0.0
        up = axis(m.up) * m.climb_mps * k
        if self.z_mode is ZMode.HEIGHT:
            self._height_offset_m += up * dt_s
            up = self._height_offset_m
        return Twist(
            linear_x=axis(m.forward) * m.linear_mps * k,
            linear_y=axis(m.left) * m.linear_mps * k,
            linear_z=up,
            angular_z=axis(m.yaw) * m.yaw_radps * k,
        )

    def poll(self, step: int, time_s: float) -> Twist | None:
        self.next_poll_step = NEVER
        dt = 0.0 if self._last_poll_s is None else time_s - self._last_poll_s
        self._last_poll_s = time_s
        if self.device is None:
            return None  # silence: the gate's dead-man timeout holds position
        axes, buttons = self.raw()
        for sink in self.joy_sinks:
            sink(step, axes, buttons)
        return self.twist_from(axes, buttons, dt)

    def reset(self) -> None:
        self._last_poll_s = None
        self._height_offset_m = 0.0

    def set_z_mode(self, z_mode: ZMode, altitude_m: float) -> None:
        self.z_mode = z_mode
        self._height_offset_m = altitude_m - HEIGHT_MODE_BASE_M
        self.next_poll_step = ASAP

    @property
    def finished(self) -> bool:
        return False

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "mapping": self.mapping.to_dict(),
            "device": self.device.get_name() if self.device is not None else None,
        }
