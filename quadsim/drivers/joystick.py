"""The joystick driver: a gamepad in "mode 2" (left stick climb and yaw, right stick forward and
sideways), mapped as teleop_twist_joy maps /joy to a Twist, with the ROS joy node's rescaled
deadzone, optional enable and turbo buttons, a mapping file, hot-plug, and a centring guard.

Axes are numbered and signed as the driver publishes them on /joy (see quadsim.drivers.gamepad):
on an SDL game controller 0 leftx, 1 lefty, 2 rightx, 3 righty, 4 lefttrigger, 5 righttrigger,
stick up and left positive; so the default mode 2 is forward = 3, left = 2, climb = 1, yaw = 0,
all with positive scales, and the triggers move nothing.

Centring guard: an axis moves the vehicle only once it has been seen centred since the pad
appeared, as an RC transmitter refuses to arm with the throttle up. A pad plugged in with a stick
held (or a raw joystick whose mapped "stick" is really a trigger resting at one end) commands
nothing on that axis until it is let go; `warnings()` says which.

Unplugged, the driver publishes nothing: the dead-man timeout then holds position.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from quadsim.core.toml_files import read_toml, refuse_unknown_keys
from quadsim.core.types import HEIGHT_MODE_BASE_M, Twist, ZMode
from quadsim.drivers import ASAP, NEVER
from quadsim.drivers.gamepad import Pad, PadKind, is_game_controller, open_pad
from quadsim.errors import ConfigError

#: an axis counts as centred within this of 0 (or within the deadzone, if that is wider)
CENTRE_TOLERANCE = 0.05


@dataclass(frozen=True)
class AxisMap:
    """One Twist field from one /joy axis: field = axis value x scale (x scale_turbo in turbo)."""

    index: int  # /joy axis index
    scale: float  # m/s or rad/s at full deflection, in /joy's sign (stick up and left = +1)
    scale_turbo: float


@dataclass(frozen=True)
class JoystickMapping:
    """Which /joy axis moves which Twist field, and the buttons (teleop_twist_joy's meaning).
    Defaults: mode 2 on an SDL game controller (right stick forward/left, left stick climb/yaw)."""

    linear_x: AxisMap | None = AxisMap(3, 1.5, 3.0)  # righty: right stick up = forward
    linear_y: AxisMap | None = AxisMap(2, 1.5, 3.0)  # rightx: right stick left = left
    linear_z: AxisMap | None = AxisMap(1, 1.0, 2.0)  # lefty: left stick up = climb
    angular_z: AxisMap | None = AxisMap(0, 1.2, 2.4)  # leftx: left stick left = counter-clockwise
    deadzone: float = 0.1
    enable_button: int | None = None  # if set, motion only while it (or the turbo button) is held
    enable_turbo_button: int | None = None  # while held: the turbo scales

    def axes(self) -> dict[str, AxisMap]:
        """The mapped Twist fields (those with an axis)."""
        return {f: a for f in TWIST_FIELDS if (a := getattr(self, f)) is not None}


TWIST_FIELDS = ("linear_x", "linear_y", "linear_z", "angular_z")
#: what the HUD calls each Twist field
FIELD_LABELS = {"linear_x": "forward/back", "linear_y": "sideways", "linear_z": "climb/descend", "angular_z": "turn"}
#: the mapping file's tables, in teleop_twist_joy's names: table -> {key -> Twist field}
_LINEAR = {"x": "linear_x", "y": "linear_y", "z": "linear_z"}
_ANGULAR = {"yaw": "angular_z"}
_TABLES = {
    "axis_linear": _LINEAR,
    "scale_linear": _LINEAR,
    "scale_linear_turbo": _LINEAR,
    "axis_angular": _ANGULAR,
    "scale_angular": _ANGULAR,
    "scale_angular_turbo": _ANGULAR,
}
_SCALARS = ("deadzone", "enable_button", "enable_turbo_button")
#: keys of the mapping files of quadsim <= 0.2, whose axes were read in SDL's sign (up negative)
_OLD_KEYS = ("forward", "left", "up", "yaw", "linear_mps", "climb_mps", "yaw_radps", "turbo_button", "turbo_factor")


def _number(path: Path, key: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{path}: {key} must be a finite number, got {value!r}")
    return float(value)


def _index(path: Path, key: str, value: object, lowest: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < lowest:
        raise ConfigError(f"{path}: {key} must be a whole number >= {lowest}, got {value!r}")
    return value


def load_mapping(path: Path) -> JoystickMapping:
    """A TOML mapping file in teleop_twist_joy's names (`axis_linear.x = 3`, `scale_linear.x = 1.5`,
    `scale_linear_turbo.x`, `axis_angular.yaw`, `scale_angular.yaw`, `enable_button`,
    `enable_turbo_button`) plus `deadzone`. Axes are /joy's; an axis of -1 moves nothing. A turbo
    scale not given is twice the scale; one given must have the scale's sign."""
    table = read_toml(Path(path), "joystick mapping file")
    old = sorted(set(table) & set(_OLD_KEYS))
    if old:
        raise ConfigError(
            f"{path}: {', '.join(old)} belong to the old mapping format, which read the axes in SDL's sign "
            "(stick up negative). Mapping files now use teleop_twist_joy's names and /joy's sign (stick up and "
            "left positive), e.g. axis_linear.x = 3 and scale_linear.x = 1.5: see the teleop page of the docs"
        )
    refuse_unknown_keys(table, [*_TABLES, *_SCALARS], str(path), top_level=True)
    read: dict[str, dict[str, Any]] = {}  # each table's numbers, by the Twist field they are for
    for name, keys in _TABLES.items():
        sub = table.get(name, {})
        if not isinstance(sub, dict):
            raise ConfigError(f"{path}: {name} must be a table ({name}.{next(iter(keys))} = ...)")
        extra = sorted(set(sub) - set(keys))
        if extra:
            raise ConfigError(
                f"{path}: {name}.{extra[0]} is not used by quadsim; {name} takes {', '.join(name + '.' + k for k in keys)}"
            )
        axis = name.startswith("axis_")
        read[name] = {
            keys[key]: _index(path, f"{name}.{key}", value, -1) if axis else _number(path, f"{name}.{key}", value)
            for key, value in sub.items()
        }
    defaults = JoystickMapping()
    values: dict[str, Any] = {}
    for f in TWIST_FIELDS:
        kind, key = ("linear", f[-1]) if f.startswith("linear") else ("angular", "yaw")
        default = getattr(defaults, f)
        i, scale = read[f"axis_{kind}"].get(f, default.index), read[f"scale_{kind}"].get(f, default.scale)
        turbo = read[f"scale_{kind}_turbo"].get(f)
        values[f] = None if i == -1 else AxisMap(i, scale, 2.0 * scale if turbo is None else turbo)
        if i != -1 and turbo is not None and turbo * scale < 0:
            raise ConfigError(
                f"{path}: scale_{kind}_turbo.{key} = {turbo} and scale_{kind}.{key} = {scale} have opposite "
                "signs: the turbo button would fly the other way; give both the same sign"
            )
    if "deadzone" in table:
        values["deadzone"] = _number(path, "deadzone", table["deadzone"])
        if not 0.0 <= values["deadzone"] < 0.9:
            raise ConfigError(f"{path}: deadzone must be in [0, 0.9), got {values['deadzone']}")
    for key in ("enable_button", "enable_turbo_button"):
        if key in table:
            values[key] = _index(path, key, table[key], 0)
    return replace(defaults, **values)


def apply_deadzone(value: float, deadzone: float) -> float:
    """Zero inside the deadzone, rescaled outside it so the output is continuous and reaches 1
    (the ROS joy node's deadzone)."""
    if -deadzone <= value <= deadzone:
        return 0.0
    sign = 1.0 if value > 0 else -1.0
    return sign * min(1.0, (abs(value) - deadzone) / (1.0 - deadzone))


#: events that mean the pad's state changed: poll at once
_MOTION_EVENTS = frozenset(
    getattr(pygame, name)
    for name in (
        "JOYAXISMOTION",
        "JOYBUTTONDOWN",
        "JOYBUTTONUP",
        "JOYHATMOTION",
        "CONTROLLERAXISMOTION",
        "CONTROLLERBUTTONDOWN",
        "CONTROLLERBUTTONUP",
    )
    if hasattr(pygame, name)
)


class JoystickDriver:
    """Feed it pygame events with `handle_event`; the loop polls it at the input rate."""

    name = "joystick"
    finished = False  # a person's input never runs out

    def __init__(
        self,
        mapping: JoystickMapping = JoystickMapping(),
        z_mode: ZMode = ZMode.VELOCITY,
        pad_opener: Callable[[int], Pad] = open_pad,
    ) -> None:
        self.mapping = mapping
        self.z_mode = z_mode
        self.pad: Pad | None = None
        self.status = "no gamepad: plug one in"
        self.next_poll_step = NEVER
        #: receive (step, axes, buttons) as published on /joy: ROS sign, deadzone applied
        self.joy_sinks: list[Callable[[int, tuple[float, ...], tuple[int, ...]], None]] = []
        self._open = pad_opener
        self._last_poll_s: float | None = None
        self._height_offset_m = 0.0
        self._centred: set[int] = set()  # axes seen centred since the pad appeared
        self._axes: tuple[float, ...] = ()  # the last reading (ROS sign, before the deadzone)

    # --- devices ----------------------------------------------------------------------------

    def attach(self, device_index: int) -> bool:
        """Open SDL device `device_index` unless a pad is already attached; True if it was."""
        if self.pad is not None:
            return False
        try:
            pad = self._open(device_index)
        except pygame.error as exc:
            self.status = f"cannot open joystick {device_index}: {exc}"
            return False
        self.pad = pad
        self._centred = set()
        self._axes = ()
        known = pad.kind is PadKind.GAME_CONTROLLER
        self.status = f"gamepad {pad.name}" if known else f"joystick {pad.name} (raw axes, see --joy-map)"
        self.next_poll_step = ASAP
        return True

    def attach_first(self) -> bool:
        """Attach the first device plugged in, game controllers before other joysticks."""
        indices = sorted(range(pygame.joystick.get_count()), key=lambda i: not is_game_controller(i))
        return any(self.attach(i) for i in indices)

    def detach(self) -> None:
        if self.pad is not None:
            self.close()
            self.status = "gamepad unplugged: holding position (plug it in again to fly)"

    def close(self) -> None:
        if self.pad is not None:
            self.pad.close()
            self.pad = None

    def handle_event(self, event: pygame.event.Event) -> bool:
        """Follow plugging and unplugging; True if the event was the driver's."""
        if event.type == pygame.JOYDEVICEADDED:
            self.attach(event.device_index)
            return True
        if event.type == pygame.JOYDEVICEREMOVED:
            if self.pad is not None and event.instance_id == self.pad.instance_id:
                self.detach()
            return True
        if event.type in _MOTION_EVENTS:
            self.next_poll_step = ASAP
            return True
        return False

    # --- reading ----------------------------------------------------------------------------

    def twist_from(self, axes: tuple[float, ...], buttons: tuple[int, ...], dt_s: float) -> Twist:
        """The command for /joy axes (deadzone applied) and buttons, as teleop_twist_joy makes it:
        turbo scales while the turbo button is held, else the normal ones if enabled, else zero."""
        m = self.mapping

        def pressed(b: int | None) -> bool:
            return b is not None and b < len(buttons) and bool(buttons[b])

        turbo = pressed(m.enable_turbo_button)
        enabled = turbo or m.enable_button is None or pressed(m.enable_button)
        out = dict.fromkeys(TWIST_FIELDS, 0.0)
        if enabled:
            for field, a in m.axes().items():
                if a.index < len(axes):
                    out[field] = axes[a.index] * (a.scale_turbo if turbo else a.scale)
        up = out["linear_z"]
        if self.z_mode is ZMode.HEIGHT:
            self._height_offset_m += up * dt_s
            up = self._height_offset_m
        return Twist(linear_x=out["linear_x"], linear_y=out["linear_y"], linear_z=up, angular_z=out["angular_z"])

    def poll(self, step: int, time_s: float) -> Twist | None:
        self.next_poll_step = NEVER
        dt = 0.0 if self._last_poll_s is None else time_s - self._last_poll_s
        self._last_poll_s = time_s
        if self.pad is None:
            return None  # silence: the gate's dead-man timeout holds position
        try:
            raw, buttons = self.pad.read()
        except pygame.error:  # gone between its removal and the event saying so
            self.detach()
            return None
        self._axes = raw
        tolerance = max(CENTRE_TOLERANCE, self.mapping.deadzone)
        self._centred.update(i for i, v in enumerate(raw) if abs(v) <= tolerance)
        axes = tuple(apply_deadzone(v, self.mapping.deadzone) for v in raw)
        for sink in self.joy_sinks:
            sink(step, axes, buttons)
        usable = tuple(v if i in self._centred else 0.0 for i, v in enumerate(axes))
        return self.twist_from(usable, buttons, dt)

    def warnings(self) -> list[str]:
        """What the person flying must know: no pad, sticks to centre, axes the pad lacks."""
        pad = self.pad
        if pad is None:
            return [self.status]
        out = []
        waiting = []
        for field, a in self.mapping.axes().items():
            if a.index >= len(pad.axis_names):
                out.append(f"{FIELD_LABELS[field]}: this pad has no axis {a.index} (see --joy-map)")
            elif a.index not in self._centred and a.scale != 0.0 and a.index < len(self._axes):
                waiting.append(f"{pad.held(a.index, self._axes[a.index])} ({FIELD_LABELS[field]})")
        if waiting:
            out.insert(0, "centre the sticks to fly: " + ", ".join(waiting))
        return out

    def help_lines(self) -> list[str]:
        names = self.pad.axis_names if self.pad is not None else ()
        m = self.mapping
        moves = [
            f"{FIELD_LABELS[field]}: {names[a.index] if a.index < len(names) else f'axis {a.index}'}"
            for field, a in m.axes().items()
        ]
        lines = [f"gamepad    {', '.join(moves[:2])}", f"           {', '.join(moves[2:])}"]
        if m.enable_button is not None:
            lines.append(f"           hold button {m.enable_button} to fly")
        if m.enable_turbo_button is not None:
            lines.append(f"           hold button {m.enable_turbo_button} to fly faster (turbo)")
        lines.append("           a stick moves nothing until it has been centred once after the pad appears")
        return lines

    def reset(self) -> None:
        self._last_poll_s = None
        self._height_offset_m = 0.0

    def set_z_mode(self, z_mode: ZMode, altitude_m: float) -> None:
        self.z_mode = z_mode
        self._height_offset_m = altitude_m - HEIGHT_MODE_BASE_M
        self.next_poll_step = ASAP

    def describe(self) -> dict[str, Any]:
        pad = self.pad
        return {
            "name": self.name,
            "mapping": asdict(self.mapping),
            "device": pad.name if pad is not None else None,
            "device_kind": pad.kind.value if pad is not None else None,
        }
