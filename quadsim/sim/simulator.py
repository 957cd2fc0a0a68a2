"""The simulator: one vehicle in its world, the fleet of one every run of one vehicle is.

This is also the API for autonomy code:

    from quadsim import Simulator, SimConfig, Twist
    with Simulator(SimConfig()) as sim:
        sim.send(Twist(linear_z=1.0))   # climb at 1 m/s
        sim.run_for(2.0)
        print(sim.state.position_m)
"""

from __future__ import annotations

from typing import Any

from quadsim.control import Controller
from quadsim.control.gate import CommandGate
from quadsim.control.landing import LandingSettings
from quadsim.core.types import VehicleState, ZMode
from quadsim.drivers import InputDriver
from quadsim.physics.pybullet_world import PhysicsWorld
from quadsim.physics.wind import WindModel
from quadsim.sim.config import SimConfig
from quadsim.sim.drone import VehicleApi
from quadsim.sim.fleet import Fleet, FleetVehicle
from quadsim.vehicle.params import VehicleParams


class Simulator(Fleet, VehicleApi):
    """One simulated vehicle in one world: a fleet of one whose vehicle has no name (its topics
    are the recording contract's, unprefixed). Stepping, resetting and closing are the fleet's;
    commanding, state and events are its vehicle's (`drone`), answered as a Drone answers them."""

    def __init__(
        self,
        config: SimConfig = SimConfig(),
        driver: InputDriver | None = None,
        controller_gains: dict[str, Any] | None = None,
        texture_required: bool = True,
        landing: LandingSettings = LandingSettings(),
        reset_on_crash: bool = False,
        controller: Controller | None = None,
        wind: WindModel | None = None,
    ) -> None:
        """`driver`: where commands come from (default: `send`); `controller_gains`: gains that
        replace those of the vehicle's gains file; `texture_required`: False lets a world whose
        floor texture is missing load; `landing` and `reset_on_crash`: the landing layer's
        settings and whether a crash puts the vehicle back at its start; `controller`: a
        controller of your own (the Controller protocol: reset, update, describe) instead of the
        config's built-in one; `wind`: a wind of your own (the WindModel protocol: velocity_mps at
        a time and place) instead of the config's."""
        alone = FleetVehicle(
            "", start=config.start, controller=controller, driver=driver, controller_gains=controller_gains
        )
        super().__init__([alone], config, landing, reset_on_crash, texture_required, wind)
        #: the one vehicle
        self.drone = self.members[0]
        self.loop = self.drone.loop

    # --- stepping: the fleet's, returning the state ------------------------------------------

    def step(self, steps: int = 1) -> VehicleState:  # type: ignore[override]
        """Advance `steps` physics steps through the loop (input, control, physics, outputs); the new state."""
        super().step(steps)
        return self.drone.state

    def run_for(self, seconds: float) -> VehicleState:  # type: ignore[override]
        """Advance by `seconds` of simulation time (rounded to whole physics steps); the new state."""
        super().run_for(seconds)
        return self.drone.state

    def restart(self, driver: InputDriver, seed: int | None = None) -> None:  # type: ignore[override]
        """Back to step 0 (as `reset`), flown from now on by `driver`, in the z-mode the run was
        made with: the next run of a sweep worker, which loads the world and the vehicle once.
        It flies bit for bit as a new Simulator with the same config and this seed would."""
        super().restart({"": driver}, seed)

    # --- what it is made of: its vehicle's parts, for tests, tools and autonomy code ------------

    @property
    def driver(self) -> InputDriver:
        """Where the commands come from."""
        return self.drone.driver

    @property
    def vehicle(self) -> VehicleParams:
        """The airframe's parameters."""
        return self.drone.vehicle

    @property
    def controller(self) -> Controller:
        """The controller, under the landing layer."""
        return self.drone.controller

    @property
    def gate(self) -> CommandGate:
        """The command gate: clamping, NaN rejection, the dead-man timeout."""
        return self.drone.gate

    @property
    def physics(self) -> PhysicsWorld:
        """The vehicle's body in the world."""
        return self.drone.physics

    @property
    def z_mode(self) -> ZMode:
        """How linear.z was read when the run started (`gate.z_mode`: now)."""
        return self.drone.z_mode
