"""One vehicle of a run: its driver, command gate, controller, landing layer, flight loop and body,
in a world it shares with the run's other vehicles.

A run's fleet (quadsim.sim.fleet.Fleet) builds its drones and steps them together; a Simulator is
the fleet of one. `fleet["alpha"]` is a Drone: send it commands, read its state and events, attach
outputs to it (its sinks and taps). Its steps are its loop's (quadsim.sim.loop); its body is
quadsim.physics.pybullet_world's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, replace
from typing import Any

import numpy as np

from quadsim.control import Controller, builtin_kind, make_controller
from quadsim.control.gate import CommandGate
from quadsim.control.landing import FlightPhase, LandingSettings
from quadsim.core.compiled import FIRST_COMPILE, will_compile
from quadsim.core.parts import import_path
from quadsim.core.types import Twist, VehicleState, ZMode
from quadsim.drivers import InputDriver
from quadsim.drivers.goal import Goal
from quadsim.drivers.programmatic import ProgrammaticDriver
from quadsim.errors import ConfigError, QuadsimError
from quadsim.physics.client import WorldClient
from quadsim.physics.pybullet_world import PhysicsWorld
from quadsim.physics.wind import WindModel
from quadsim.sensors import ranging
from quadsim.sensors.beams import beam_directions
from quadsim.sensors.imu import ImuNoise
from quadsim.sim.config import SimConfig, divisors_shown, enum_choice
from quadsim.sim.description import ControllerDescription, RunDescription, VehicleDescription
from quadsim.sim.flight_events import FlightEvent
from quadsim.sim.loop import SimLoop, Sink
from quadsim.vehicle.params import load_vehicle


class VehicleApi:
    """What one vehicle answers to, whether a fleet's (a Drone) or a Simulator's own: commands,
    the sinks and taps outputs attach to, flight events and state, all of it its flight loop's
    (`loop`, which holds its driver and its command gate); and its run's parameters (`describe`)."""

    #: the vehicle's flight loop, which counts the steps
    loop: SimLoop
    #: everything its run is made with, typed (a Drone's own, a Simulator's the fleet's)
    description: Callable[[], RunDescription]

    # --- commanding -------------------------------------------------------------------------

    def send(self, twist: Twist) -> None:
        """Publish `twist` from now on, at the input rate (autonomy code's way in)."""
        self._programmatic("send").send(twist)

    def fly_to(self, x: float, y: float, z: float | None = None, yaw: float | None = None) -> None:
        """Fly to (x, y, z), world frame, heading `yaw` (rad), through the command path
        (quadsim.drivers.goal): z None keeps the altitude flown (1 m from the ground), yaw None the
        heading. It holds there until `send`, another goal or a reset; a `goal_reached` event
        says when it is there. ValueError for a goal that is not a finite place within 10 km."""
        self._programmatic("fly_to").stop()  # its standing Twist would take over at the next poll
        self.loop.fly_to(Goal(x, y, z, yaw))

    def _programmatic(self, what: str) -> ProgrammaticDriver:
        """The driver, which `what()` needs to be the programmatic one."""
        driver = self.loop.driver
        if not isinstance(driver, ProgrammaticDriver):
            raise QuadsimError(f"{what}() needs the programmatic driver; this vehicle is driven by {driver.name}")  # type: ignore[union-attr]
        return driver

    def set_z_mode(self, z_mode: ZMode | str) -> None:
        """How linear.z is read from now on (the standing command is re-clamped under the new mode):
        a ZMode or its name ("height"); anything else is a ConfigError."""
        self.loop.gate.set_z_mode(enum_choice(ZMode, z_mode, "z_mode"))

    # --- where outputs attach: sinks and taps ----------------------------------------------

    def add_sink(self, sink: Sink) -> None:
        """Receive every command (as the controller got it) and every published state."""
        self.loop.sinks.append(sink)

    def remove_sink(self, sink: Sink) -> None:
        """Stop sending commands and states to `sink` (no error if it was not added)."""
        if sink in self.loop.sinks:
            self.loop.sinks.remove(sink)

    def add_tap(self, every_steps: int, callback: Callable[[VehicleState], None]) -> None:
        """Call `callback(state)` after every `every_steps`-th physics step (cameras use this)."""
        self.loop.add_tap(every_steps, callback)

    def remove_tap(self, callback: Callable[[VehicleState], None]) -> None:
        """Stop calling `callback` (no error if it was not added)."""
        self.loop.remove_tap(callback)

    # --- flight events and state --------------------------------------------------------------

    @property
    def events(self) -> list[FlightEvent]:
        """Every flight event (take-off, touchdown, landed, crash, reset) since the start or the last
        reset, in order; each has its step, kind, text, impact speed and what was hit."""
        return self.loop.events

    def add_event_callback(self, callback: Callable[[FlightEvent], None]) -> None:
        """Call `callback(event)` as each flight event happens (a Gymnasium env ends on a crash)."""
        self.loop.event_callbacks.append(callback)

    @property
    def phase(self) -> FlightPhase:
        """Landed (rotors idle) or flying."""
        return self.loop.landing.phase

    @property
    def reset_on_crash(self) -> bool:
        """Whether a crash puts the vehicle back at its start pose (the clock and commands go on)."""
        return self.loop.reset_on_crash

    @property
    def state(self) -> VehicleState:
        """The vehicle's state after the last step (ground truth, REP 103 frames, SI units)."""
        return self.loop.state()

    def describe(self) -> dict[str, Any]:
        """Every parameter of the run as plain data: the layout recordings carry (see description())."""
        return self.description().to_parameters()


class Drone(VehicleApi):
    """One vehicle in a shared world, stepped by its run's fleet (which owns the clock)."""

    def __init__(
        self,
        config: SimConfig,
        client: WorldClient,
        driver: InputDriver | None = None,
        controller_gains: dict[str, Any] | None = None,
        landing: LandingSettings = LandingSettings(),
        reset_on_crash: bool = False,
        name: str = "",
        index: int = 0,
        controller: Controller | None = None,
        wind_model: WindModel | None = None,
        say: Callable[[str], None] | None = None,
    ) -> None:
        """`config`: this vehicle's (its airframe, controller, z-mode, start, seed; the rates and
        the world are the run's); `client`: the world it flies in; `name`: what its topics and
        TF frames are prefixed with ("": a run of one vehicle, the contract's names unchanged);
        `index`: its place in the fleet; `controller`: a controller of the user's own (the
        Controller protocol), in place of the config's built-in one; `wind_model`: the run's
        wind of the user's own, in place of the config's; `say`: told before a slow part of
        building it (a first compile of the flight core), for a person waiting."""
        self.name = name
        self.driver: InputDriver = driver if driver is not None else ProgrammaticDriver()
        self.config = config = _as_driven(config, self.driver)
        self.z_mode: ZMode = config.z_mode or ZMode.VELOCITY
        self.vehicle = load_vehicle(config.urdf, config.vehicle_params)
        if say is not None and will_compile():  # the vehicle's files are good: the wait is the compile's
            say(f"compiling the flight core (numba; the first run after an install: {FIRST_COMPILE})")
        self.world = client.world
        rates, timeout = config.rates, config.command_timeout_s
        self.controller: Controller = (
            controller if controller is not None else make_controller(config.controller, self.vehicle, controller_gains)
        )
        timeout_steps = None if timeout is None else round(timeout * rates.physics_hz)
        self.gate = CommandGate(self.vehicle.limits, self.z_mode, timeout_steps)
        wind_seed, imu_seed, range_seed, lidar_seed = _streams(config.seed)
        self.physics = PhysicsWorld(
            self.vehicle,
            client,
            config.start,
            config.wind,
            wind_seed,
            name or "vehicle",
            index,
            wind_model,
            config.physics,
        )
        imu = ImuNoise(self.vehicle.imu_noise, rates.state_hz, imu_seed) if config.sensor_noise else None
        self.loop = SimLoop(
            self.physics,
            self.controller,
            self.gate,
            rates,
            self.driver,
            landing=landing,
            reset_on_crash=reset_on_crash,
            imu=imu,
        )
        self._add_ranging(client, range_seed, lidar_seed)

    def _add_ranging(
        self, client: WorldClient, range_seed: np.random.SeedSequence, lidar_seed: np.random.SeedSequence
    ) -> None:
        """The range finder and the LiDAR the config asks for, sampled by loop taps at their rates
        whether or not anyone listens (their noise depends on the seed and the steps alone)."""
        config, rates, v = self.config, self.config.rates, self.vehicle
        body, noisy = (self.physics.body_id, self.physics.reach_m), config.sensor_noise
        #: the range finder and the LiDAR, where the config turns them on (None: not carried)
        self.range_finder: ranging.RangingSensor | None = None
        self.lidar: ranging.RangingSensor | None = None
        if config.range_finder:
            beam = np.asarray([v.range_finder.direction], dtype=float)
            self.range_finder = ranging.mounted(v.range_finder, beam, client, body, range_seed, noisy)
        if config.lidar is not None:
            beams = beam_directions(v.lidar, config.lidar)
            self.lidar = ranging.mounted(v.lidar, beams, client, body, lidar_seed, noisy)
        for sensor, table, hz in (
            (self.range_finder, "range", self.vehicle.range_finder.rate_hz),
            (self.lidar, "lidar", self.vehicle.lidar.rate_hz),
        ):
            if sensor is not None:
                if rates.physics_hz % hz:
                    raise ConfigError(
                        f"{self.vehicle.params_path.name}: [{table}] rate_hz = {hz} does not divide the physics rate "
                        f"{rates.physics_hz} Hz; choose a divisor of it ({divisors_shown(rates.physics_hz)})"
                    )
                self.loop.add_tap(rates.every(hz), sensor.tap)

    # --- the fleet's clock --------------------------------------------------------------------

    def step(self, steps: int = 1) -> None:
        """Refused: the fleet steps every vehicle at once, on its one clock."""
        raise QuadsimError(f"{self.name} flies in a fleet, which steps every vehicle at once: step the fleet")

    run_for = step

    @property
    def scene_client(self) -> WorldClient:
        """The PyBullet client holding the world this vehicle flies in, for rendering in-process
        (its `posed()` gives its id with every vehicle where it flew to)."""
        return self.physics.client

    @property
    def step_count(self) -> int:
        """Simulation time in physics steps since the start (or the last reset)."""
        return self.loop.step_count

    @property
    def time_s(self) -> float:
        """Simulation time in seconds (step_count / physics rate)."""
        return self.loop.time_s

    # --- starting again -------------------------------------------------------------------------

    def reset(self, seed: int | None = None) -> None:
        """Back to step 0: the vehicle at its start pose, rotors idle, controller and gate cleared.
        With `seed`, its random streams (turbulence, sensor noise) start again from that seed
        instead of its own (a Gymnasium env's seeded reset); the description says so."""
        self._check_open()
        if seed is not None:
            self.config = replace(self.config, seed=seed)  # validated like any SimConfig
            wind_seed, *noise_seeds = _streams(seed)
            self.physics.reseed(wind_seed)
            for noise, noise_seed in zip((self.loop.imu, self.range_finder, self.lidar), noise_seeds):
                if noise is not None:
                    noise.reseed(noise_seed)
        self.loop.reset()
        for sensor in (self.range_finder, self.lidar):
            if sensor is not None:
                sensor.reset()
        rewind = getattr(self.driver, "rewind", None)
        if rewind is not None:  # a script plays from its start again, as the clock does
            rewind()

    def drive_with(self, driver: InputDriver) -> None:
        """Flown from now on by `driver`, in the z-mode the run was made with: with a reset
        after it (Fleet.restart), the next run of a sweep worker, which loads the world and the
        vehicle once, and flies bit for bit as a new vehicle with the same config would."""
        self.driver = driver
        self.loop.driver = driver
        if self.gate.z_mode is not self.z_mode:
            self.gate.set_z_mode(self.z_mode)

    # --- what it is made of -----------------------------------------------------------------------

    def description(self) -> RunDescription:
        """Everything this vehicle's run is made with, typed (outputs complete it with their own part)."""
        v, ctrl = self.vehicle, self.controller.describe()
        kind = builtin_kind(self.controller)
        return RunDescription(
            config=self.config,
            vehicle=VehicleDescription(
                v.name, v.urdf_path.name, v.params_path.name, v.mass_kg, len(v.rotors), v.to_dict()
            ),
            controller=ControllerDescription(
                kind,
                dict(ctrl.get("gains", {})) if kind is not None else {},
                {**ctrl, "landing": asdict(self.loop.landing.settings), "reset_on_crash": self.loop.reset_on_crash},
                import_path(self.controller) if kind is None else "",
            ),
            driver=self.driver.describe(),
            vehicle_model=v,
            world_model=self.world,
        )

    # --- lifetime ---------------------------------------------------------------------------

    def close(self) -> None:
        """Let go of the world (the fleet disconnects it): this vehicle cannot step afterwards."""
        self.physics.close()

    @property
    def closed(self) -> bool:
        """Whether the run was closed (stepping or resetting then raises QuadsimError)."""
        return self.physics.client.cid < 0 or self.physics.closed

    def _check_open(self) -> None:
        if self.closed:
            raise QuadsimError("this Simulator is closed (close() or the end of its with-block): make a new one")


def _as_driven(config: SimConfig, driver: InputDriver) -> SimConfig:
    """`config` with what its driver asks for: its z-mode where the config leaves it open (a
    script's z_mode line; else velocity), and its own dead-man timeout (a Foxglove input's),
    recorded as the run's."""
    if config.z_mode is None:
        config = replace(config, z_mode=getattr(driver, "preferred_z_mode", None) or ZMode.VELOCITY)
    timeout_s = getattr(driver, "command_timeout_s", None)
    if timeout_s is not None:
        config = replace(config, command_timeout_s=timeout_s)
    return config


def _streams(seed: int) -> tuple[np.random.SeedSequence, ...]:
    """One seed per vehicle; each random stream (wind, IMU noise, range finder, LiDAR) gets its own
    child of it, so adding a stream or turning one off leaves the others unchanged (SeedSequence's
    children are numbered: the first two are what they were before the ranging sensors)."""
    return tuple(np.random.SeedSequence(seed).spawn(4))
