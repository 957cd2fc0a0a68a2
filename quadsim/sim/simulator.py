"""The simulator, assembled: vehicle, world, physics, command gate, controller, driver, loop.

This is also the API for autonomy code:

    from quadsim import Simulator, SimConfig, Twist
    with Simulator(SimConfig()) as sim:
        sim.send(Twist(linear_z=1.0))   # climb at 1 m/s
        sim.run_for(2.0)
        print(sim.state.position_m)
"""

from __future__ import annotations

from typing import Any

from quadsim.control import make_controller
from quadsim.control.gate import CommandGate
from quadsim.core.types import Twist, VehicleState, ZMode
from quadsim.drivers import InputDriver
from quadsim.drivers.programmatic import ProgrammaticDriver
from quadsim.errors import ConfigError, QuadsimError
from quadsim.physics.pybullet_world import PhysicsWorld
from quadsim.physics.world_spec import load_world
from quadsim.sim.config import SimConfig
from quadsim.sim.loop import SimLoop, Sink
from quadsim.vehicle.params import load_vehicle


class Simulator:
    """One simulated vehicle in one world, stepped by a SimLoop that owns the clock."""

    def __init__(
        self,
        config: SimConfig = SimConfig(),
        driver: InputDriver | None = None,
        controller_gains: dict[str, Any] | None = None,
        texture_required: bool = True,
    ) -> None:
        self.config = config
        self.vehicle = load_vehicle(config.urdf, config.vehicle_params)
        self.world = load_world(config.world, texture_required)
        rates = config.rates
        timeout = config.command_timeout_s
        if timeout is not None and not timeout > 0:
            raise ConfigError(f"command timeout must be > 0 s (or None to disable), got {timeout}")
        self.controller = make_controller(config.controller, self.vehicle, controller_gains)
        self.gate = CommandGate(
            self.vehicle.limits, config.z_mode, None if timeout is None else round(timeout * rates.physics_hz)
        )
        self.driver: InputDriver = driver if driver is not None else ProgrammaticDriver()
        self.physics = PhysicsWorld(self.vehicle, self.world, rates.physics_hz, config.start, config.gui)
        self.loop = SimLoop(self.physics, self.controller, self.gate, rates, self.driver)

    # --- commanding -------------------------------------------------------------------------

    def send(self, twist: Twist) -> None:
        """Publish `twist` from now on, at the input rate (autonomy code's way in)."""
        if not isinstance(self.driver, ProgrammaticDriver):
            raise QuadsimError(f"send() needs the programmatic driver; this simulator is driven by {self.driver.name}")
        self.driver.send(twist)

    def set_z_mode(self, z_mode: ZMode) -> None:
        self.gate.set_z_mode(z_mode)

    # --- stepping ---------------------------------------------------------------------------

    def step(self, steps: int = 1) -> VehicleState:
        self.loop.run(steps)
        return self.state

    def run_for(self, seconds: float) -> VehicleState:
        """Advance by `seconds` of simulation time (rounded to whole physics steps)."""
        return self.step(round(seconds * self.config.rates.physics_hz))

    def add_sink(self, sink: Sink) -> None:
        self.loop.sinks.append(sink)

    def reset(self) -> None:
        self.loop.reset()

    @property
    def state(self) -> VehicleState:
        return self.loop.state()

    @property
    def step_count(self) -> int:
        return self.loop.step_count

    @property
    def time_s(self) -> float:
        return self.loop.time_s

    def describe(self) -> dict[str, Any]:
        """Every parameter of the run, as plain data for a recording's metadata."""
        return {
            "config": self.config.to_dict(),
            "vehicle": self.vehicle.to_dict(),
            "controller": self.controller.describe(),
            "driver": self.driver.describe(),
        }

    # --- lifetime ---------------------------------------------------------------------------

    def close(self) -> None:
        self.physics.close()

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
