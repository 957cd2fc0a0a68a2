"""Controllers: pure numeric code turning (state, command) into one force per rotor.

Nothing here imports pybullet. Pick one with `make_controller`.
"""

from __future__ import annotations

import enum
from typing import Any, Protocol

from quadsim.core.types import ActiveCommand, RotorForces, VehicleState
from quadsim.vehicle.params import VehicleParams


class ControllerKind(enum.Enum):
    CASCADE = "cascade"  # velocity -> attitude -> body rate (default)
    SEED = "seed"  # port of the original V-REP quadricopter controller


class Controller(Protocol):
    """What the simulation loop calls once per control step."""

    kind: ControllerKind

    def reset(self) -> None:
        """Forget all internal state (integrators, holds); the next armed update re-arms."""

    def update(self, state: VehicleState, command: ActiveCommand, dt_s: float) -> RotorForces:
        """Rotor forces (N) for this control step."""

    def describe(self) -> dict[str, Any]:
        """The controller's name and every gain, as plain data for recordings."""


def gains_type(kind: ControllerKind) -> type:
    """The frozen dataclass of `kind`'s gains (its fields are the gain names a gains file and a
    recording use)."""
    if kind is ControllerKind.CASCADE:
        from quadsim.control.cascade import CascadeGains

        return CascadeGains
    from quadsim.control.seed import SeedGains

    return SeedGains


def make_controller(kind: ControllerKind, vehicle: VehicleParams, gains: dict[str, Any] | None = None) -> Controller:
    """A controller of `kind` with the gains of the vehicle's gains file (NAME.gains.toml);
    `gains` (as `describe()` gives them, e.g. from a recording) replace any of them."""
    from quadsim.control.gains import load_gains

    loaded: Any = load_gains(vehicle, kind.value, gains_type(kind), gains)  # CascadeGains or SeedGains
    if kind is ControllerKind.CASCADE:
        from quadsim.control.cascade import CascadeController

        return CascadeController(vehicle, loaded)
    from quadsim.control.seed import SeedController

    return SeedController(vehicle, loaded)
