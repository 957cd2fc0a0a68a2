"""Controllers: pure numeric code turning (state, command) into one force per rotor.

Nothing here imports pybullet. Pick a built-in one with `make_controller`; a controller of your
own is any object with the `Controller` protocol's methods (docs/vehicles.md shows one).
"""

from __future__ import annotations

import enum
from typing import Any, Protocol

from quadsim.core.parts import part_class
from quadsim.core.types import ActiveCommand, RotorForces, VehicleState
from quadsim.errors import QuadsimError
from quadsim.vehicle.params import VehicleParams


class ControllerKind(enum.Enum):
    CASCADE = "cascade"  # velocity -> attitude -> body rate (default)
    SEED = "seed"  # port of the original V-REP quadricopter controller


class Controller(Protocol):
    """What the simulation loop calls once per control step (under the landing layer, which
    hands it the gate's command near the ground and resets it on landing). A controller of your
    own has these three methods; a recording names its class (module:Class), and `check` makes it
    again as `Class(vehicle)` (a VehicleParams), or `Class.from_description(vehicle, details)`
    (details: what its describe() returned) where it has that classmethod."""

    def reset(self) -> None:
        """Forget all internal state (integrators, holds); the next armed update re-arms."""

    def update(self, state: VehicleState, command: ActiveCommand, dt_s: float) -> RotorForces:
        """Rotor forces (N) for this control step."""

    def describe(self) -> dict[str, Any]:
        """The controller's name and every gain (JSON-able), as plain data for recordings."""


#: the methods a controller of one's own must have
CONTROLLER_METHODS = ("reset", "update", "describe")


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


def builtin_kind(controller: object) -> ControllerKind | None:
    """The kind of a shipped controller (None: a controller of the user's own)."""
    kind = getattr(controller, "kind", None)
    shipped = type(controller).__module__.startswith(f"{__name__}.")
    return kind if shipped and isinstance(kind, ControllerKind) else None


def remake_controller(path: str, vehicle: VehicleParams, details: dict[str, Any]) -> Controller:
    """A user's controller made again from a recording: the class at `path` (module:Class), as
    `Class.from_description(vehicle, details)` where it has that, else `Class(vehicle)`; one
    QuadsimError line where it cannot be."""
    cls = part_class(path, "controller", CONTROLLER_METHODS)
    make = getattr(cls, "from_description", None)
    try:
        made: Controller = make(vehicle, details) if callable(make) else cls(vehicle)
    except Exception as exc:  # the user's constructor
        raise QuadsimError(
            f"the controller {path} could not be made again ({type(exc).__name__}: {str(exc)[:120]})"
        ) from None
    return made
