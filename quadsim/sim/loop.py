"""The simulation loop: the one owner of the step counter and of every rate.

Stepping order, once per physics step n (time n / physics_hz):
  1. input   (n % input_every == 0, or n >= driver.next_poll_step):
                                       poll the driver; the gate takes its command, stamped n
                                       (with a goal, the pilot's at input ticks while the driver
                                       says nothing: quadsim.drivers.goal)
  2. control (n % control_every == 0): the landing layer and the controller turn state + active
                                       command into rotor forces (take-off, landed: events at n)
  3. physics:                          motors, forces, one step (quadsim's own while the vehicle
                                       is clear of everything, else PyBullet's) -> n + 1 (only here)
  4. contacts:                         touchdown and crash events at n + 1 (and the reset after a
                                       crash, if asked for)
  5. publish ((n + 1) % state_every == 0): the IMU noise takes its sample (sinks or not), and
                                       sinks receive the state at step n + 1
  6. taps    ((n + 1) % every == 0):       e.g. the cameras capture the state at step n + 1
Nothing here reads the wall clock; only a window paces these steps to real time. Stage 3 is the
body's (quadsim.physics.pybullet_world.PhysicsWorld).

`run` does stages 1-2 (`_take_input`, `_control`), 3 and 4-6 (`after_physics`) step after step; a fleet
(quadsim.sim.fleet) does stages 1-2 for every vehicle, their steps (one PyBullet step of the
world if any of them needs it), then 4-6 for every vehicle. Where the steps up to the next
moment the loop acts in Python (a poll, a state published, a tap, the dead-man firing) are only
stage 2's cascade and stage 3's own step of a flying vehicle, alone and clear of everything,
`run` takes them in one compiled call (quadsim.sim.clear_flight), the same arithmetic to the
bit, and then stages 5-6 for the last of them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from quadsim.control import Controller
from quadsim.control.cascade import CascadeController
from quadsim.control.gate import CommandGate
from quadsim.control.landing import FlightPhase, LandingLayer, LandingSettings
from quadsim.core.compiled import specialize
from quadsim.core.types import RotorForces, Twist, VehicleState, ZMode
from quadsim.drivers import InputDriver
from quadsim.drivers.goal import Goal, GoalPilot
from quadsim.errors import ConfigError
from quadsim.physics.pybullet_world import PhysicsWorld
from quadsim.sensors.imu import ImuNoise
from quadsim.sim.clear_flight import fly_clear
from quadsim.sim.config import Rates
from quadsim.sim.flight_events import WALL_NORMAL_Z, ContactMonitor, EventKind, FlightEvent

#: the IMU noise's walk in compiled steps without an IMU (quadsim.sensors.imu.ImuNoise.walk)
_NO_WALK = (np.zeros((0, 12)), 0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


class Sink(Protocol):
    """Receives what the loop publishes (a recorder, a window, a test log)."""

    def on_command(self, step: int, twist: Twist) -> None:
        """A command as the controller received it (after the gate), at `step`."""

    def on_state(self, state: VehicleState) -> None:
        """The vehicle's state, at the state rate."""

    # optional: def on_event(self, step: int, kind: str, value: str) -> None, a flight event
    # (take-off, touchdown, landed, crash, reset; see sim/flight_events.py) at `step`


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
        landing: LandingSettings = LandingSettings(),
        reset_on_crash: bool = False,
        imu: ImuNoise | None = None,
    ) -> None:
        if abs(physics.dt_s * rates.physics_hz - 1.0) > 1e-12:
            raise ConfigError("the physics world and the loop disagree on the physics rate")
        self.physics = physics
        self.gate = gate
        self.rates = rates
        self.driver = driver
        self.imu = imu
        self.sinks: list[Sink] = []
        self.landing = LandingLayer(
            controller, physics.vehicle.limits, physics.rest_height_m, len(physics.vehicle.rotors), landing
        )
        self.contact_monitor = ContactMonitor(rates.physics_hz)
        #: every flight event since the start (or the last reset), in order
        self.events: list[FlightEvent] = []
        #: called with each flight event as it happens (a Gymnasium env ends an episode on a crash)
        self.event_callbacks: list[Callable[[FlightEvent], None]] = []
        #: put the vehicle back at its start pose after a crash (the clock and the command go on)
        self.reset_on_crash = reset_on_crash
        self._on_ground = True
        #: flies the vehicle to a goal while there is one and the driver says nothing
        self.pilot = GoalPilot(physics.vehicle.limits)
        self._next_goal: Goal | None = None  # given since the last input stage (fly_to)
        self._taps: list[tuple[int, Callable[[VehicleState], None]]] = []
        self.step_count = 0
        self._input_every = rates.every(rates.input_hz)
        self._control_every = rates.every(rates.control_hz)
        self._state_every = rates.every(rates.state_hz)
        self._control_dt_s = 1.0 / rates.control_hz
        self._idle: RotorForces = (0.0,) * len(physics.vehicle.rotors)
        self._rotor_command = self._idle
        #: fly_clear made for this vehicle's arguments, now: a first compile is waited for while
        #: the run is built (and said), not in the middle of its flight
        self._fly_clear: Any = fly_clear
        if type(controller) is CascadeController:
            command, landing, cascade, constants, kinematics, clearance, _, imu, walk = self.quiet_vehicle(
                physics.clear_flight_arguments
            )
            sample = (0, command, landing, cascade, constants, kinematics, clearance, (imu, 0, 1), walk)
            self._fly_clear = specialize(fly_clear, *sample)

    @property
    def controller(self) -> Controller:
        """The controller, under the landing layer."""
        return self.landing.controller

    @controller.setter
    def controller(self, controller: Controller) -> None:
        self.landing.controller = controller

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

    def state(self) -> VehicleState:
        """The vehicle's state now, stamped with the loop's step count."""
        return self.physics.state(self.step_count)

    def reset(self) -> None:
        """Back to step 0: vehicle at its start pose, controller and gate cleared."""
        self.physics.reset()
        self.landing.reset()
        self.contact_monitor.reset()
        self.gate.reset()
        if self.imu is not None:
            self.imu.reset()
        self.step_count = 0
        self._rotor_command = self._idle
        self._on_ground = True
        self.pilot.stop()
        self._next_goal = None
        self.events.clear()

    def fly_to(self, goal: Goal) -> None:
        """Fly to `goal` from the next step on (quadsim.drivers.goal): until the driver publishes a
        Twist, another goal comes or the vehicle is reset. ValueError for a goal that is not one."""
        self._next_goal = goal.checked()

    def _emit(self, event: FlightEvent) -> None:
        self.events.append(event)
        for sink in self.sinks:
            on_event = getattr(sink, "on_event", None)
            if on_event is not None:
                on_event(event.step, event.kind.value, event.value)
        for callback in self.event_callbacks:
            callback(event)

    def _after_contact(self, n: int) -> bool:
        """Contacts after the physics step that ended at `n`: events, and the reset after a crash
        if asked for. True if the vehicle was put back at its start pose."""
        physics = self.physics
        contacts = physics.contacts()
        monitor = self.contact_monitor
        if not contacts:  # in the air, most steps
            self._on_ground = False
            if not monitor.touching:
                return False
        else:
            self._on_ground = any(c.normal_z >= WALL_NORMAL_Z for c in contacts)
        events = monitor.update(n, contacts, physics.velocity_before_step_mps, physics.body_z_up)
        for event in events:
            self._emit(event)
        if self.reset_on_crash and any(e.kind is EventKind.CRASH for e in events):
            physics.reset()
            self.landing.reset()
            monitor.reset()
            self._on_ground = True
            self._rotor_command = self._idle
            self._emit(FlightEvent(n, EventKind.RESET, "back at the start after a crash"))
            return True
        return False

    def run(self, steps: int) -> None:
        """Advance `steps` physics steps (see the module docstring for the order)."""
        physics, after = self.physics, self.after_physics
        # the state after a step is built once, only if someone takes it: the sinks and taps of
        # that step, then the controller at the start of the next one (nothing moves in between)
        state: VehicleState | None = None
        while steps > 0:
            self._take_input()
            quiet = self._quiet_steps(steps)
            if quiet:
                flown = self._fly_quiet_steps(quiet)
                if flown:
                    steps -= flown
                    state = self._publish(self.step_count) if self.sinks or self._taps else None
                    continue
            physics._step(self._control(state))
            state = after()
            steps -= 1

    def _quiet_steps(self, steps: int) -> int:
        """How many of the next `steps` steps, the driver polled for this one, do nothing in
        Python but the cascade's update and the body's own step: the vehicle flying, armed and
        off the ground, with no poll, no state to publish, no tap and no dead-man firing before
        the last of them (0: not now)."""
        landing, n = self.landing, self.step_count
        if (
            not self.physics.steps_itself  # (first: PyBullet stepping every step asks nothing more)
            or self._control_every != 1
            or landing.phase is not FlightPhase.FLYING
            or self._on_ground
            or self.contact_monitor.touching
            or type(landing.controller) is not CascadeController
            or not landing.controller.armed
        ):
            return 0
        last = self.gate.last_receive_step
        if last is None:
            return 0
        quiet = steps
        driver = self.driver
        if self.pilot.goal is not None:  # the pilot speaks at every input tick
            quiet = min(quiet, self._input_every - n % self._input_every)
        if driver is not None:
            if getattr(driver, "polled_anytime", False):
                return 0
            quiet = min(quiet, self._input_every - n % self._input_every, max(driver.next_poll_step - n, 1))
        timeout = self.gate.timeout_steps
        if timeout is not None and n - last <= timeout:
            quiet = min(quiet, last + timeout + 1 - n)  # the hold starts at that step
        # where a state is published; with no one to take it, the IMU noise walks in the compiled steps
        if self.sinks or (self._taps and self.imu is not None):
            quiet = min(quiet, self._state_every - n % self._state_every)
        for every, _ in self._taps:
            quiet = min(quiet, every - n % every)
        return quiet

    def _fly_quiet_steps(self, quiet: int) -> int:
        """Up to `quiet` steps in one compiled call (quadsim.sim.clear_flight), if the vehicle is
        alone and clear of everything; the steps taken (it stops where the clearance ends)."""
        physics = self.physics
        body = physics._clear_flight()
        if body is None or physics._others:  # a fleet's vehicles fly their quiet steps together (Fleet.step)
            return 0
        command, landing, cascade, constants, kinematics, clearance, _, imu, walk = self.quiet_vehicle(body)
        sampling = (imu, self.step_count, self._state_every)
        flown, kinematics, previous, (_, *walked) = self._fly_clear(
            quiet, command, landing, cascade, constants, kinematics, clearance, sampling, walk
        )
        if flown:
            self.took_quiet_steps(flown, kinematics, previous, walked)
        return flown

    def quiet_vehicle(self, body: tuple[Any, ...]) -> tuple[Any, ...]:
        """What the compiled quiet steps take of this vehicle (quadsim.sim.clear_flight), `body`
        being its PhysicsWorld's clear_flight_arguments: the gate's command now, the landing
        layer's numbers, the cascade's state and step, the body's constants, base_link's state,
        the clearances from the scenery and from the other vehicles, whether the IMU noise walks
        in them (no one takes its readings: no sink, no tap) and its walk."""
        command = self.gate.active(self.step_count)
        tw = command.twist
        twist = (float(tw.linear_x), float(tw.linear_y), float(tw.linear_z), float(tw.angular_z))
        cascade: CascadeController = self.landing.controller  # type: ignore[assignment]
        imu = self.imu if not (self.sinks or self._taps) else None  # else the loop samples it as it publishes
        return (
            (twist, command.z_mode is ZMode.HEIGHT, command.hold), self.landing.numbers,
            (*cascade.compiled_state, self._control_dt_s), *body, imu is not None,
            _NO_WALK if imu is None else imu.walk,
        )  # fmt: skip

    def took_quiet_steps(self, flown: int, kinematics: Any, previous: Any, walked: Any) -> None:
        """After `flown` compiled quiet steps: base_link's state after them, the velocity before
        the last one, and the IMU noise's walk (its next sample and biases, if it walked)."""
        self.physics._flown_clear(kinematics, previous)
        self.step_count += flown
        cascade: CascadeController = self.landing.controller  # type: ignore[assignment]
        self._rotor_command = cascade.last_forces
        if self.imu is not None and not (self.sinks or self._taps):
            next_sample, gyro_bias, accel_bias = walked
            self.imu.walked(int(next_sample), tuple(gyro_bias), tuple(accel_bias))

    def _take_input(self) -> None:
        """Stage 1 at step n: the driver polled, if due, and the gate takes its command."""
        n, driver = self.step_count, self.driver
        twist = None
        if driver is not None and (n % self._input_every == 0 or n >= driver.next_poll_step):
            twist = driver.poll(n, n / self.rates.physics_hz)
            take_goal = getattr(driver, "take_goal", None)
            if take_goal is not None:
                self._next_goal = take_goal() or self._next_goal
        if self._next_goal is not None or self.pilot.goal is not None:
            twist = self._piloted(n, twist)
        if twist is not None:
            accepted = self.gate.receive(twist, n)
            if accepted is not None:
                for sink in self.sinks:
                    sink.on_command(n, accepted)

    def _piloted(self, n: int, twist: Twist | None) -> Twist | None:
        """The command at step n with a goal given or flown: a new goal starts (and is flown at
        once), a Twist from the driver drops the goal, and at input ticks the pilot's Twist is
        published while the driver says nothing."""
        pilot, goal = self.pilot, self._next_goal
        if goal is None and twist is not None:  # a Twist comes from a driver
            pilot.stop()
            self._emit(FlightEvent(n, EventKind.GOAL, f"dropped: {self.driver.name} published a Twist"))  # type: ignore[union-attr]
            return twist
        if goal is None and n % self._input_every:  # the pilot speaks at input ticks
            return None
        state = self.physics.state(n)
        if goal is not None:
            self._next_goal = None
            flown = pilot.start(goal, state, self.landing.phase is not FlightPhase.FLYING)
            self._emit(FlightEvent(n, EventKind.GOAL, f"flying to {flown.describe()}"))
            if twist is not None:  # came with the goal: published, the goal flown from the next tick
                return twist
        reached = pilot.reached
        twist = pilot.command(state, self.gate.z_mode)
        if pilot.reached and not reached:
            self._emit(FlightEvent(n, EventKind.GOAL_REACHED, f"at {pilot.goal.describe()}"))  # type: ignore[union-attr]
        return twist

    def _control(self, state: VehicleState | None) -> RotorForces:
        """Stage 2 at step n: the landing layer and the controller's rotor forces, if a control
        step (take-off and landed events at n)."""
        n = self.step_count
        if n % self._control_every == 0:
            landing = self.landing
            phase = landing.phase
            self._rotor_command = landing.update(
                self.physics.state(n) if state is None else state,
                self.gate.active(n),
                self._on_ground,
                self._control_dt_s,
            )
            if landing.phase is not phase:
                if landing.phase is FlightPhase.FLYING:
                    self._emit(FlightEvent(n, EventKind.TAKEOFF, "climbing from the ground"))
                else:
                    self._emit(FlightEvent(n, EventKind.LANDED, "on the ground, rotors idle"))
        return self._rotor_command

    def after_physics(self) -> VehicleState | None:
        """Stages 4 to 6, once the physics has stepped: the step count moves on to n + 1, then
        contacts, publishing and taps. The state at n + 1 if one was built (None otherwise)."""
        n = self.step_count = self.step_count + 1
        if self._after_contact(n):
            self._rotor_command = self._idle
        return self._publish(n)

    def _publish(self, n: int) -> VehicleState | None:
        """Stages 5 and 6 at step count `n`: the IMU's sample and the sinks at the state rate,
        the taps at theirs. The state at `n` if one was built (None otherwise)."""
        physics = self.physics
        state: VehicleState | None = None
        if n % self._state_every == 0:
            if self.imu is not None:
                state = self.imu.measure(physics.state(n))
            if self.sinks:
                if state is None:
                    state = physics.state(n)
                for sink in self.sinks:
                    sink.on_state(state)
        for every, tap in self._taps:
            if n % every == 0:
                if state is None:
                    state = physics.state(n)
                tap(state)
        return state
