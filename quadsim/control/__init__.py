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


def make_controller(kind: ControllerKind, vehicle: VehicleParams, gains: dict[str, Any] | None = None) -> Controller:
    """A controller of `kind` with the gains of the vehicle's gains file (NAME.gains.toml);
    `gains` (as `describe()` gives them, e.g. from a recording) replace any of them."""
    from quadsim.control.gains import load_gains

    if kind is ControllerKind.CASCADE:
        from quadsim.control.cascade import CascadeController, CascadeGains

        return CascadeController(vehicle, load_gains(vehicle, kind.value, CascadeGains, gains))
    from quadsim.control.seed import SeedController, SeedGains

    return SeedController(vehicle, load_gains(vehicle, kind.value, SeedGains, gains))
