"""A run's settings: its rates and everything the Simulator is built from (all recorded)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from quadsim.control import ControllerKind
from quadsim.core.types import StartPose, ZMode
from quadsim.errors import ConfigError


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
        for name, value in asdict(self).items():
            if self.physics_hz % value:
                divisors = [d for d in range(1, self.physics_hz + 1) if self.physics_hz % d == 0]
                raise ConfigError(
                    f"rate {name}={value} Hz does not divide the physics rate {self.physics_hz} Hz; "
                    f"choose one of {divisors}"
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
    z_mode: ZMode = ZMode.VELOCITY
    rates: Rates = field(default_factory=Rates)
    command_timeout_s: float | None = 0.5  # dead-man switch; None disables it
    start: StartPose = field(default_factory=StartPose)
    gui: bool = False

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able data (RunDescription reads it back with validation)."""
        return {
            "urdf": str(self.urdf) if self.urdf else None,
            "vehicle_params": str(self.vehicle_params) if self.vehicle_params else None,
            "world": str(self.world) if self.world else None,
            "controller": self.controller.value,
            "z_mode": self.z_mode.value,
            "rates": self.rates.to_dict(),
            "command_timeout_s": self.command_timeout_s,
            "start": {"x_m": self.start.x_m, "y_m": self.start.y_m, "yaw_rad": self.start.yaw_rad},
        }
