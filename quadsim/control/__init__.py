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
    """A controller of `kind`; `gains` (as `describe()` gives them) replace the defaults."""
    import dataclasses

    if kind is ControllerKind.CASCADE:
        from quadsim.control.cascade import CascadeController, CascadeGains

        cls, gains_cls = CascadeController, CascadeGains
    else:
        from quadsim.control.seed import SeedController, SeedGains

        cls, gains_cls = SeedController, SeedGains  # type: ignore[assignment]
    if not gains:
        return cls(vehicle)
    known = {f.name for f in dataclasses.fields(gains_cls)}
    unknown = set(gains) - known
    if unknown:
        raise ValueError(f"unknown {kind.value} gains: {', '.join(sorted(unknown))}")
    return cls(vehicle, gains_cls(**gains))
