"""A run's vehicles in one world, on one clock: a fleet (a run of one vehicle is a fleet of one).

Each vehicle is a Drone (its own command gate, controller, landing layer, motors, flight events,
IMU noise and wind streams, sinks and taps) whose body is in the fleet's one PyBullet world. The
fleet steps them together: every vehicle's input and control, every vehicle's forces, one world
step, then every vehicle's contacts, publishing and taps. Vehicles collide with each other; a
collision is a flight event on both, naming the other. A vehicle without a name flies alone: its
topics are the recording contract's, unprefixed, and its random streams are the run's own
(quadsim.sim.simulator.Simulator is that fleet of one).

    from quadsim import Fleet, FleetVehicle, StartPose, Twist
    with Fleet([FleetVehicle("alpha"), FleetVehicle("bravo", start=StartPose(3.0, 0.0))]) as fleet:
        fleet["alpha"].send(Twist(linear_z=1.0))
        fleet.run_for(2.0)
        print(fleet["alpha"].state.position_m, fleet["bravo"].events)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from quadsim.control import Controller, ControllerKind
from quadsim.control.cascade import CascadeController
from quadsim.control.landing import LandingSettings
from quadsim.core.types import LidarMode, StartPose, VehicleState, ZMode
from quadsim.drivers import InputDriver
from quadsim.errors import ConfigError, QuadsimError
from quadsim.physics.client import WorldClient
from quadsim.physics.wind import WindModel
from quadsim.physics.world_spec import WorldSpec, load_world
from quadsim.sim.clear_flight import QuietFleet
from quadsim.sim.config import MAX_SEED, SimConfig, steps_of, whole_steps
from quadsim.sim.description import (
    FLEET_SCHEMA_VERSION,
    MAX_FLEET,
    VEHICLE_NAME,
    VEHICLE_NAME_NEEDED,
    RunDescription,
    WindModelDescription,
)
from quadsim.sim.drone import Drone
from quadsim.vehicle.params import VehicleParams

if TYPE_CHECKING:
    from typing_extensions import Self  # typing's own from Python 3.11


@dataclass(frozen=True)
class FleetVehicle:
    """One vehicle of a fleet: its name, start pose, input and gains, and where it differs from
    the fleet's config: airframe (URDF and parameter file), controller (a built-in kind, or a
    controller object of one's own: the Controller protocol, one per vehicle), z-mode (None: the
    fleet's), a range finder and a LiDAR (None: the fleet's config says; a vehicle may add a LiDAR
    to a fleet without, not take the fleet's away). The name "" is a vehicle flying alone (a
    Simulator's): the contract's topics, unprefixed."""

    name: str
    start: StartPose = StartPose()
    urdf: Path | None = None
    vehicle_params: Path | None = None
    controller: ControllerKind | Controller | None = None
    z_mode: ZMode | None = None
    driver: InputDriver | None = None
    controller_gains: dict[str, Any] | None = field(default=None, compare=False)
    range_finder: bool | None = None
    lidar: LidarMode | None = None


class Fleet:
    """Vehicles in one world, stepped together on one clock; `fleet["alpha"]` is one of them (a Drone)."""

    def __init__(
        self,
        vehicles: Sequence[FleetVehicle],
        config: SimConfig = SimConfig(),
        landing: LandingSettings = LandingSettings(),
        reset_on_crash: bool = False,
        texture_required: bool = True,
        wind: WindModel | None = None,
        say: Callable[[str], None] | None = None,
    ) -> None:
        """`config`: what the vehicles share (world, rates, wind, sensor noise, the run's seed);
        its vehicle, controller, z-mode and start are each vehicle's own. `texture_required`:
        False lets a world whose floor texture is missing load (a re-flight draws nothing).
        `wind`: a wind of your own (the WindModel protocol: the wind at a time and place), for
        every vehicle, instead of the config's. `say`: told before a slow part of building (a
        first compile of the flight core), for a person waiting."""
        _check(vehicles, config)
        if wind is not None and config.wind.enabled:
            raise ConfigError("a wind model and the config's wind: give one (SimConfig's wind stays off with a model)")
        #: the run's wind of the user's own (None: the config's)
        self.wind_model = wind
        world = load_world(config.world, texture_required)
        gravity = VehicleParams.gravity_mps2  # what every vehicle carries; each is checked against the world's
        self.client = WorldClient(world, config.rates.physics_hz, gravity, config.gui)
        self.vehicles: dict[str, Drone] = {}
        try:
            for index, v in enumerate(vehicles):
                own = _own_config(config, v, index)
                own_controller = (
                    None if v.controller is None or isinstance(v.controller, ControllerKind) else v.controller
                )
                self.vehicles[v.name] = Drone(
                    own,
                    self.client,
                    v.driver,
                    v.controller_gains,
                    landing,
                    reset_on_crash,
                    v.name,
                    index,
                    own_controller,
                    wind,
                    say if index == 0 else None,  # the flight core compiles with the first vehicle, once
                )
        except BaseException:
            self.close()
            raise
        _check_apart(self.vehicles)
        self._members = tuple(self.vehicles.values())
        #: the one vehicle of a run of one, unnamed (its description is the run's), else None
        self._alone = self._members[0] if not self._members[0].name else None
        #: the run's settings; a vehicle flying alone's own (its z-mode as its driver asked)
        self.config = self._alone.config if self._alone is not None else config
        self._states: list[VehicleState | None] = [None] * len(self._members)
        self._reset_wind_model()
        #: the vehicles' quiet steps in one compiled call for all (a fleet of cascade-flown vehicles)
        loops = [m.loop for m in self._members]
        quiet = len(loops) > 1 and all(type(loop.controller) is CascadeController for loop in loops)
        self._quiet = QuietFleet(loops) if quiet else None

    def _reset_wind_model(self) -> None:
        """A wind model of the user's own starts again with a generator of the run's seed."""
        reset = getattr(self.wind_model, "reset", None)
        if callable(reset):
            reset(np.random.default_rng(self.config.seed))

    def __getitem__(self, name: str) -> Drone:
        try:
            return self.vehicles[name]
        except KeyError:
            raise KeyError(f"no vehicle named {name!r} in this fleet; it has {', '.join(self.vehicles)}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.vehicles)

    def __len__(self) -> int:
        return len(self.vehicles)

    @property
    def members(self) -> tuple[Drone, ...]:
        """The vehicles, in the fleet's order."""
        return self._members

    @property
    def world(self) -> WorldSpec:
        """The world every vehicle flies in."""
        return self.client.world

    @property
    def scene_client(self) -> WorldClient:
        """The PyBullet client holding the world, for rendering in-process (its `posed()` gives
        its id with every vehicle where it flew to)."""
        return self.client

    # --- stepping ---------------------------------------------------------------------------

    def step(self, steps: int = 1) -> None:
        """Advance every vehicle `steps` physics steps together: each one's input and control,
        each one's forces, one world step, then each one's contacts, publishing and taps."""
        steps = whole_steps(steps)
        self._check_open()
        if len(self._members) == 1:  # the same order, without the lists of a fleet's step
            self._members[0].loop.run(steps)
            return
        loops = [m.loop for m in self._members]
        bodies = [m.physics for m in self._members]
        world_step, states = self.client.step, self._states
        while steps > 0:
            for loop in loops:
                loop._take_input()
            flown = self._quiet.fly(steps) if self._quiet is not None else 0
            if flown:  # every vehicle's, in one compiled call
                steps -= flown
                states = [loop._publish(loop.step_count) if loop.sinks or loop._taps else None for loop in loops]
                continue
            commands = [loop._control(state) for loop, state in zip(loops, states)]
            stepped = [body._apply(command) for body, command in zip(bodies, commands)]
            if not all(stepped):
                world_step()
            for body in bodies:
                body._finish_step()
            states = [loop.after_physics() for loop in loops]
            steps -= 1
        self._states = states

    def run_for(self, seconds: float) -> None:
        """Advance by `seconds` of simulation time (rounded to whole physics steps)."""
        self.step(steps_of(seconds, self.config.rates.physics_hz))

    @property
    def step_count(self) -> int:
        """The fleet's one clock, in physics steps."""
        return self._members[0].step_count

    @property
    def time_s(self) -> float:
        """Simulation time in seconds (step_count / physics rate)."""
        return self.step_count / self.config.rates.physics_hz

    def reset(self, seed: int | None = None) -> None:
        """Every vehicle back at its start at step 0; with `seed`, the run's random streams start
        again from it (each vehicle's derived from it as at the start)."""
        self._check_open()
        if seed is not None:
            self.config = replace(self.config, seed=seed)  # validated like any SimConfig
        for index, member in enumerate(self._members):
            member.reset(None if seed is None else _vehicle_seed(seed, index, member.name))
        self._states = [None] * len(self._members)
        self._reset_wind_model()

    def restart(self, drivers: Mapping[str, InputDriver], seed: int | None = None) -> None:
        """Back to step 0 (as `reset`), each vehicle named in `drivers` flown by its driver from
        now on, in the z-mode the run was made with: the next run of a sweep worker, which loads
        the world and the vehicles once. It flies bit for bit as a new fleet would."""
        for name, driver in drivers.items():
            self[name].drive_with(driver)
        self.reset(seed)

    def description(self) -> RunDescription:
        """The whole run: a vehicle flying alone's own description; for named vehicles, the
        fleet's config (with the run's seed) and each vehicle's own description, in order (its
        vehicle, controller and driver are the first vehicle's)."""
        wind = WindModelDescription.of(self.wind_model) if self.wind_model is not None else None
        if self._alone is not None:
            return replace(self._alone.description(), wind_model=wind)
        # written as a fleet's (version 3), each vehicle's part as read back from it
        members = tuple(
            (name, replace(drone.description(), schema_version=FLEET_SCHEMA_VERSION))
            for name, drone in self.vehicles.items()
        )
        first = members[0][1]
        # the top level's z-mode is the first vehicle's, as are its vehicle, controller and driver
        config = replace(self.config, z_mode=first.z_mode)
        return replace(first, config=config, fleet=members, wind_model=wind)

    # --- lifetime ---------------------------------------------------------------------------

    def close(self) -> None:
        """Close every vehicle and the world: nothing steps afterwards (`with` calls this)."""
        for member in self.vehicles.values():
            member.close()
        self.client.close()

    @property
    def closed(self) -> bool:
        """Whether `close()` was called (stepping or resetting then raises QuadsimError)."""
        return self.client.cid < 0

    def _check_open(self) -> None:
        if self.closed:
            raise QuadsimError("this Simulator is closed (close() or the end of its with-block): make a new one")

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __reduce_ex__(self, protocol: object) -> Any:  # what copy.deepcopy and pickle ask
        # a copy would fly the same PyBullet bodies as the original (deepcopy), or none (pickle)
        raise TypeError(
            f"a {type(self).__name__} (and an env holding one) cannot be copied or pickled: it flies bodies in a "
            "PyBullet world of this process. Make another the way this one was made (gymnasium's async vector "
            "envs make theirs in each worker)"
        )


def _own_config(config: SimConfig, v: FleetVehicle, index: int) -> SimConfig:
    """Vehicle `v`'s settings: the run's, with its own airframe, controller, z-mode, start and seed."""
    return replace(
        config,
        urdf=v.urdf if v.urdf is not None else config.urdf,
        vehicle_params=v.vehicle_params if v.urdf is not None else config.vehicle_params,
        controller=v.controller if isinstance(v.controller, ControllerKind) else config.controller,
        z_mode=v.z_mode if v.z_mode is not None else config.z_mode,
        start=v.start,
        seed=_vehicle_seed(config.seed, index, v.name),
        range_finder=v.range_finder if v.range_finder is not None else config.range_finder,
        lidar=v.lidar if v.lidar is not None else config.lidar,
    )


def _vehicle_seed(seed: int, index: int, name: str) -> int:
    """Vehicle `index`'s seed: its own random streams, all from the run's seed (a vehicle flying
    alone, unnamed, has the run's seed itself)."""
    if not name:
        return seed
    return int(np.random.SeedSequence([seed, index]).generate_state(1, np.uint64)[0] % (MAX_SEED + 1))


def _check(vehicles: Sequence[FleetVehicle], config: SimConfig) -> None:
    if not vehicles:
        raise ConfigError("a fleet needs at least one vehicle")
    if len(vehicles) > MAX_FLEET:
        raise ConfigError(f"a fleet of {len(vehicles)} vehicles: at most {MAX_FLEET} fly in one world")
    seen: set[str] = set()
    for v in vehicles:
        if v.name == "" and len(vehicles) == 1:  # flying alone: the contract's names
            continue
        if not isinstance(v.name, str) or not VEHICLE_NAME.fullmatch(v.name):
            raise ConfigError(f"vehicle name {v.name!r}: {VEHICLE_NAME_NEEDED}")
        if v.name in seen:
            raise ConfigError(f"two vehicles are named {v.name!r}: each name must be unique")
        seen.add(v.name)
    if config.gui and len(vehicles) > 1:
        raise ConfigError(
            "PyBullet's own window (gui=True) shows one vehicle's run; leave it out for a fleet",
            "PyBullet's own window (--gui) shows one vehicle's run; leave it out for a fleet",
        )


def _check_apart(vehicles: dict[str, Drone]) -> None:
    """No two vehicles start inside each other's reach (their rotors would touch)."""
    placed = [(name, sim.physics.state(0).position_m, sim.physics.reach_m) for name, sim in vehicles.items()]
    for i, (a, pa, ra) in enumerate(placed):
        for b, pb_, rb in placed[i + 1 :]:
            gap = math.dist(pa[:2], pb_[:2])
            if gap < ra + rb:
                raise ConfigError(
                    f"vehicles {a!r} and {b!r} start {gap:.2f} m apart: they would overlap (at least "
                    f"{ra + rb:.2f} m between their start positions)"
                )
