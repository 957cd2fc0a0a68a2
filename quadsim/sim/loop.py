"""The simulation loop: the one owner of the step counter and of every rate.

Stepping order, once per physics step n (time n / physics_hz):
  1. input   (n % input_every == 0, or n >= driver.next_poll_step):
                                       poll the driver; the gate takes its command, stamped n
  2. control (n % control_every == 0): the controller turns state + active command into rotor forces
  3. physics:                          motors, forces, one PyBullet step -> step n + 1 (only here)
  4. publish ((n + 1) % state_every == 0): the IMU noise takes its sample (sinks or not), and
                                       sinks receive the state at step n + 1
  5. taps    ((n + 1) % every == 0):       e.g. the cameras capture the state at step n + 1
Nothing here reads the wall clock; only a window paces these steps to real time.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from quadsim.control import Controller
from quadsim.control.gate import CommandGate
from quadsim.core.types import RotorForces, Twist, VehicleState
from quadsim.drivers import InputDriver
from quadsim.errors import ConfigError
from quadsim.physics.pybullet_world import PhysicsWorld
from quadsim.sensors.imu import ImuNoise
from quadsim.sim.config import Rates


class Sink(Protocol):
    """Receives what the loop publishes (a recorder, a window, a test log)."""

    def on_command(self, step: int, twist: Twist) -> None:
        """A command as the controller received it (after the gate), at `step`."""

    def on_state(self, state: VehicleState) -> None:
        """The vehicle's state, at the state rate."""


class OutputPort(Protocol):
    """Where outputs (recorder, cameras, bridges, the window) attach to a running simulation,
    without holding the simulator itself. The Simulator is one."""

    @property
    def step_count(self) -> int:
        """The loop's step count: simulation time in physics steps."""

    @property
    def scene_client(self) -> int | None:
        """A PyBullet client holding the scene, for rendering in-process (None: there is none)."""

    def add_sink(self, sink: Sink) -> None: ...

    def remove_sink(self, sink: Sink) -> None: ...

    def add_tap(self, every_steps: int, callback: Callable[[VehicleState], None]) -> None: ...

    def remove_tap(self, callback: Callable[[VehicleState], None]) -> None: ...


class StateLog:
    """A sink that keeps everything in memory: for tests, summaries and autonomy code."""

    def __init__(self) -> None:
        self.states: list[VehicleState] = []
        self.commands: list[tuple[int, Twist]] = []

    def on_command(self, step: int, twist: Twist) -> None:
        """Keep (step, command)."""
        self.commands.append((step, twist))

    def on_state(self, state: VehicleState) -> None:
        """Keep the state."""
        self.states.append(state)


class SimLoop:
    def __init__(
        self,
        physics: PhysicsWorld,
        controller: Controller,
        gate: CommandGate,
        rates: Rates,
        driver: InputDriver | None = None,
        imu: ImuNoise | None = None,
    ) -> None:
        if abs(physics.dt_s * rates.physics_hz - 1.0) > 1e-12:
            raise ConfigError("the physics world and the loop disagree on the physics rate")
        self.physics = physics
        self.controller = controller
        self.gate = gate
        self.rates = rates
        self.driver = driver
        self.imu = imu
        self.sinks: list[Sink] = []
        self._taps: list[tuple[int, Callable[[VehicleState], None]]] = []
        self.step_count = 0
        self._input_every = rates.every(rates.input_hz)
        self._control_every = rates.every(rates.control_hz)
        self._state_every = rates.every(rates.state_hz)
        self._control_dt_s = 1.0 / rates.control_hz
        self._idle: RotorForces = (0.0,) * len(physics.vehicle.rotors)
        self._rotor_command = self._idle

    def add_tap(self, every_steps: int, callback: Callable[[VehicleState], None]) -> None:
        """Call `callback(state)` after every `every_steps`-th physics step (cameras use this)."""
        if every_steps <= 0:
            raise ConfigError(f"a tap needs a positive step interval, got {every_steps}")
        self._taps.append((every_steps, callback))

    def remove_tap(self, callback: Callable[[VehicleState], None]) -> None:
        """Stop calling `callback` (no error if it was not registered)."""
        self._taps = [(every, tap) for every, tap in self._taps if tap != callback]

    @property
    def time_s(self) -> float:
        return self.step_count / self.rates.physics_hz

    @property
    def rotor_command_n(self) -> RotorForces:
        """The rotor forces the controller asked for at its last update."""
        return self._rotor_command

    def state(self) -> VehicleState:
        """The vehicle's state now, stamped with the loop's step count."""
        return self.physics.state(self.step_count)

    def reset(self) -> None:
        """Back to step 0: vehicle at its start pose, controller and gate cleared."""
        self.physics.reset()
        self.controller.reset()
        self.gate.reset()
        if self.imu is not None:
            self.imu.reset()
        self.step_count = 0
        self._rotor_command = self._idle

    def run(self, steps: int) -> None:
        """Advance `steps` physics steps (see the module docstring for the order)."""
        physics, controller, gate, driver = self.physics, self.controller, self.gate, self.driver
        input_every, control_every, state_every = self._input_every, self._control_every, self._state_every
        control_dt, hz = self._control_dt_s, self.rates.physics_hz
        sinks, taps, imu = self.sinks, self._taps, self.imu
        n = self.step_count
        command = self._rotor_command
        # the state after a step is built once, only if someone takes it: the sinks and taps of
        # that step, then the controller at the start of the next one (nothing moves in between)
        state: VehicleState | None = None
        for _ in range(steps):
            if driver is not None and (n % input_every == 0 or n >= driver.next_poll_step):
                twist = driver.poll(n, n / hz)
                if twist is not None:
                    accepted = gate.receive(twist, n)
                    if accepted is not None:
                        for sink in sinks:
                            sink.on_command(n, accepted)
            if n % control_every == 0:
                command = controller.update(physics.state(n) if state is None else state, gate.active(n), control_dt)
            physics._step(command)
            n += 1
            state = None
            if n % state_every == 0:
                if imu is not None:
                    state = imu.measure(physics.state(n))
                if sinks:
                    if state is None:
                        state = physics.state(n)
                    for sink in sinks:
                        sink.on_state(state)
            for every, tap in taps:
                if n % every == 0:
                    if state is None:
                        state = physics.state(n)
                    tap(state)
        self.step_count = n
        self._rotor_command = command
