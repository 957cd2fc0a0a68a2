"""A run's settings: its rates and everything the Simulator is built from (all recorded)."""

from __future__ import annotations

import math
import numbers
import operator
from dataclasses import asdict, dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any, TypeVar

from quadsim.control import ControllerKind
from quadsim.core.types import LidarMode, StartPose, Stepping, ZMode
from quadsim.errors import ConfigError
from quadsim.physics.wind import WindSettings

#: the highest physics rate accepted (PyBullet steps get unreasonably slow past this)
MAX_PHYSICS_HZ = 10_000
#: the longest dead-man timeout accepted; None disables the dead-man switch altogether
MAX_COMMAND_TIMEOUT_S = 3600.0
#: seeds are whole numbers in [0, MAX_SEED]
MAX_SEED = 2**63 - 1

E = TypeVar("E", bound=Enum)


@dataclass(frozen=True)
class Rates:
    """Every rate of a run, in Hz. Each must divide the physics rate exactly."""

    physics_hz: int = 240
    control_hz: int = 240
    state_hz: int = 60
    input_hz: int = 20

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                raise ConfigError(f"rate {name} must be a positive whole number of Hz, got {value!r}")
        if self.physics_hz > MAX_PHYSICS_HZ:
            raise ConfigError(f"physics rate {self.physics_hz} Hz is beyond {MAX_PHYSICS_HZ} Hz; 240 Hz is the default")
        for name, value in asdict(self).items():
            if self.physics_hz % value:
                raise ConfigError(
                    f"rate {name}={value} Hz does not divide the physics rate {self.physics_hz} Hz; "
                    f"choose a divisor of it ({divisors_shown(self.physics_hz)})"
                )

    def every(self, hz: int) -> int:
        """Physics steps between two events at `hz`."""
        return self.physics_hz // hz

    def to_dict(self) -> dict[str, Any]:
        """The rates as plain data, field name -> Hz."""
        return asdict(self)


@dataclass(frozen=True)
class SimConfig:
    """Every setting of a run (all recorded with it)."""

    urdf: Path | None = None  # None: the shipped vehicle
    vehicle_params: Path | None = None  # None: NAME.params.toml beside the URDF
    world: Path | None = None  # None: assets/worlds/default.toml
    controller: ControllerKind = ControllerKind.CASCADE
    #: how linear.z is read; None: what the driver asks for (a script's `z_mode` line), else velocity
    z_mode: ZMode | None = None
    rates: Rates = field(default_factory=Rates)
    command_timeout_s: float | None = 0.5  # dead-man switch; None disables it
    start: StartPose = field(default_factory=StartPose)
    gui: bool = False
    wind: WindSettings = field(default_factory=WindSettings)  # mean wind and turbulence
    sensor_noise: bool = True  # IMU noise on /quad/imu (the vehicle parameter file's [imu])
    #: the run's one random seed: every random stream (turbulence, sensor noise) derives from it
    seed: int = 0
    #: who steps a vehicle that touches nothing: quadsim's own copy of PyBullet's step (the
    #: default, about twice as fast) or PyBullet itself (for checking; recordings made before
    #: quadsim had its own step re-fly this way)
    physics: Stepping = Stepping.QUADSIM
    #: a range finder on /quad/range (the vehicle parameter file's [range])
    range_finder: bool = False
    #: a LiDAR (the vehicle parameter file's [lidar]): 2D scans on /quad/scan, 3D on /quad/points; None: none
    lidar: LidarMode | None = None

    def __post_init__(self) -> None:
        # the names the command line takes are accepted for the enumerations ("height", "seed")
        object.__setattr__(self, "controller", enum_choice(ControllerKind, self.controller, "controller"))
        object.__setattr__(self, "physics", enum_choice(Stepping, self.physics, "physics"))
        if self.z_mode is not None:
            object.__setattr__(self, "z_mode", enum_choice(ZMode, self.z_mode, "z_mode"))
        if self.lidar is not None:
            object.__setattr__(self, "lidar", enum_choice(LidarMode, self.lidar, "lidar"))
        seed = self.seed
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
            raise ConfigError(f"seed must be a whole number in [0, 2^63 - 1], got {seed!r}")
        for name, kind in (("wind", WindSettings), ("rates", Rates), ("start", StartPose)):
            if not isinstance(getattr(self, name), kind):
                raise ConfigError(f"{name} must be a {kind.__name__}, got {type(getattr(self, name)).__name__}")
        for name in ("gui", "sensor_noise", "range_finder"):
            if not isinstance(getattr(self, name), bool):
                raise ConfigError(f"{name} must be True or False, got {getattr(self, name)!r}")
        timeout = self.command_timeout_s
        if timeout is None:
            return
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not math.isfinite(timeout):
            raise ConfigError(
                f"command timeout must be a finite number of seconds (or None to disable), got {timeout!r}"
            )
        input_period_s = 1.0 / self.rates.input_hz
        if round(timeout * self.rates.physics_hz) < self.rates.every(self.rates.input_hz):
            raise ConfigError(
                f"command timeout {timeout:g} s is shorter than the input period {input_period_s:g} s "
                f"({self.rates.input_hz} Hz): every command would expire before the next one arrives"
            )
        if timeout > MAX_COMMAND_TIMEOUT_S:
            raise ConfigError(
                f"command timeout {timeout:g} s is beyond {MAX_COMMAND_TIMEOUT_S:g} s; use None to disable the dead-man switch"
            )

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able data (RunDescription reads it back with validation)."""
        return {
            "urdf": str(self.urdf) if self.urdf else None,
            "vehicle_params": str(self.vehicle_params) if self.vehicle_params else None,
            "world": str(self.world) if self.world else None,
            "controller": self.controller.value,
            "z_mode": (self.z_mode or ZMode.VELOCITY).value,
            "rates": self.rates.to_dict(),
            "command_timeout_s": self.command_timeout_s,
            "start": {"x_m": self.start.x_m, "y_m": self.start.y_m, "yaw_rad": self.start.yaw_rad},
            "wind": self.wind.to_dict(),
            "sensor_noise": self.sensor_noise,
            "seed": self.seed,
            "physics": self.physics.value,
            # the ranging sensors only where a run has them: a run without is written as before them
            **({"range_finder": True} if self.range_finder else {}),
            **({"lidar": self.lidar.value} if self.lidar is not None else {}),
        }


def divisors_shown(hz: int) -> str:
    """The rates that divide `hz`, as an error message lists them ("1, 2, 3, ..., 12, ...")."""
    divisors = [d for d in range(1, hz + 1) if hz % d == 0]
    return ", ".join(map(str, divisors[:12])) + (", ..." if len(divisors) > 12 else "")


def enum_choice(kind: type[E], value: object, what: str) -> E:
    """`value` as a member of the enumeration `kind`: a member, or its name as the command line
    spells it ("height"); anything else is a ConfigError naming the choices."""
    if isinstance(value, kind):
        return value
    try:
        return kind(value.lower() if isinstance(value, str) else value)
    except ValueError:
        choices = ", ".join(repr(m.value) for m in kind)
        raise ConfigError(f"{what} must be one of {choices} (or {kind.__name__}.X), got {value!r:.60}") from None


def whole_steps(steps: int) -> int:
    """`steps` as a count of physics steps to advance: a whole number (numpy's too), 0 or more."""
    try:
        count = operator.index(steps) if not isinstance(steps, bool) else -1
    except TypeError:
        count = -1
    if count < 0:
        raise ValueError(f"steps must be a whole number of physics steps, 0 or more, got {steps!r}")
    return count


def steps_of(seconds: float, physics_hz: int) -> int:
    """`seconds` of simulation time as whole physics steps (rounded), for run_for."""
    value = float(seconds) if isinstance(seconds, numbers.Real) and not isinstance(seconds, bool) else math.nan
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"seconds must be a finite number, 0 or more, got {seconds!r}")
    return round(value * physics_hz)
