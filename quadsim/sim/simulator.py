"""The simulator: one vehicle in its world, the fleet of one every run of one vehicle is.

This is also the API for autonomy code:

    from quadsim import Simulator, SimConfig, Twist
    with Simulator(SimConfig()) as sim:
        sim.send(Twist(linear_z=1.0))   # climb at 1 m/s
        sim.run_for(2.0)
        print(sim.state.position_m)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from quadsim.control import Controller
from quadsim.control.gate import CommandGate
from quadsim.control.landing import FlightPhase, LandingSettings
from quadsim.core.types import Twist, VehicleState, ZMode
from quadsim.drivers import InputDriver
from quadsim.physics.pybullet_world import PhysicsWorld
from quadsim.physics.wind import WindModel
from quadsim.sim.config import SimConfig
from quadsim.sim.fleet import Fleet, FleetVehicle
from quadsim.sim.flight_events import FlightEvent
from quadsim.sim.loop import SimLoop, Sink
from quadsim.vehicle.params import VehicleParams


class Simulator(Fleet):
    """One simulated vehicle in one world: a fleet of one whose vehicle has no name (its topics
    are the recording contract's, unprefixed). Stepping, resetting and closing are the fleet's;
    commanding, state and events are its vehicle's (`drone`)."""

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

    # --- its vehicle --------------------------------------------------------------------------

    def send(self, twist: Twist) -> None:
        """Publish `twist` from now on, at the input rate (autonomy code's way in)."""
        self.drone.send(twist)

    def fly_to(self, x: float, y: float, z: float | None = None, yaw: float | None = None) -> None:
        """Fly to (x, y, z) in the world frame, heading `yaw` (rad), through the command path
        (quadsim.drivers.goal): z None keeps the altitude flown (1 m from the ground), yaw None
        the heading. A `goal_reached` event says when it is there; it holds there until `send`,
        another goal or a reset."""
        self.drone.fly_to(x, y, z, yaw)

    def set_z_mode(self, z_mode: ZMode | str) -> None:
        """How linear.z is read from now on (the standing command is re-clamped under the new mode):
        a ZMode or its name ("height"); anything else is a ConfigError."""
        self.drone.set_z_mode(z_mode)

    @property
    def state(self) -> VehicleState:
        """The vehicle's state after the last step (ground truth, REP 103 frames, SI units)."""
        return self.drone.state

    @property
    def events(self) -> list[FlightEvent]:
        """Every flight event (take-off, touchdown, landed, crash, reset) since the start or the last
        reset, in order; each has its step, kind, text, impact speed and what was hit."""
        return self.drone.events

    def add_event_callback(self, callback: Callable[[FlightEvent], None]) -> None:
        """Call `callback(event)` as each flight event happens (a Gymnasium env ends on a crash)."""
        self.drone.add_event_callback(callback)

    @property
    def phase(self) -> FlightPhase:
        """Landed (rotors idle) or flying."""
        return self.drone.phase

    @property
    def reset_on_crash(self) -> bool:
        """Whether a crash puts the vehicle back at its start pose (the clock and commands go on)."""
        return self.drone.reset_on_crash

    def add_sink(self, sink: Sink) -> None:
        """Receive every command (as the controller got it) and every published state."""
        self.drone.add_sink(sink)

    def remove_sink(self, sink: Sink) -> None:
        """Stop sending commands and states to `sink` (no error if it was not added)."""
        self.drone.remove_sink(sink)

    def add_tap(self, every_steps: int, callback: Callable[[VehicleState], None]) -> None:
        """Call `callback(state)` after every `every_steps`-th physics step (cameras use this)."""
        self.drone.add_tap(every_steps, callback)

    def remove_tap(self, callback: Callable[[VehicleState], None]) -> None:
        """Stop calling `callback` (no error if it was not added)."""
        self.drone.remove_tap(callback)

    def describe(self) -> dict[str, Any]:
        """Every parameter of the run as plain data: the layout recordings carry (see description())."""
        return self.description().to_parameters()

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
    def loop(self) -> SimLoop:
        """The flight loop, which counts the steps."""
        return self.drone.loop

    @property
    def z_mode(self) -> ZMode:
        """How linear.z was read when the run started (`gate.z_mode`: now)."""
        return self.drone.z_mode
