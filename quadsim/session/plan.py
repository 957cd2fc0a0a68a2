"""A run's plan: what flies (the settings and each vehicle with its driver), for how long, and what
it feeds (recording, cameras, live bridges). One plan type for every run: a run of one vehicle is
a fleet of one (a vehicle without a name, whose topics are the contract's, unprefixed)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from quadsim.control.landing import LandingSettings
from quadsim.core.types import ZMode
from quadsim.drivers import InputDriver
from quadsim.errors import QuadsimError
from quadsim.physics.wind import WindModel
from quadsim.sensors.camera import CameraSpec
from quadsim.session.outputs import OutputOptions
from quadsim.sim.config import SimConfig
from quadsim.sim.fleet import FleetVehicle

if TYPE_CHECKING:
    from quadsim.session.outputs import LiveOutput


@dataclass(frozen=True)
class RunPlan:
    """Everything a run is made of. `vehicles`: the fleet's (one unnamed vehicle: `alone`);
    `cameras`: each vehicle's by name (None: a run of one vehicle has `outputs.cameras`);
    `z_switches`: (step, vehicle name, z-mode) switches made at those steps and recorded, as the
    window's Tab makes them (a re-flight replays a recording's); `wind`: a wind of the user's
    own (quadsim.physics.wind.WindModel) in place of the config's."""

    config: SimConfig
    vehicles: tuple[FleetVehicle, ...]
    duration_s: float = math.inf
    outputs: OutputOptions = field(default_factory=lambda: OutputOptions(record=False, cameras=()))
    cameras: Mapping[str, tuple[CameraSpec, ...]] | None = None
    live: tuple[LiveOutput, ...] = ()
    label: str = "run"
    run_info: Mapping[str, Any] = field(default_factory=dict)
    landing: LandingSettings = LandingSettings()
    reset_on_crash: bool = False
    texture_required: bool = True
    z_switches: tuple[tuple[int, str, ZMode], ...] = ()
    wind: WindModel | None = None

    def __post_init__(self) -> None:
        if not self.duration_s > 0:
            raise QuadsimError(f"a run must fly for more than 0 s, got {self.duration_s}")

    @classmethod
    def alone(
        cls,
        config: SimConfig,
        driver: InputDriver | None = None,
        controller_gains: dict[str, Any] | None = None,
        **rest: Any,
    ) -> RunPlan:
        """A run of one vehicle (the config's airframe, controller and start), flown by `driver`."""
        vehicle = FleetVehicle("", start=config.start, driver=driver, controller_gains=controller_gains)
        return cls(config, (vehicle,), **rest)

    @property
    def drivers(self) -> dict[str, InputDriver | None]:
        """What drives each vehicle, by name."""
        return {v.name: v.driver for v in self.vehicles}
