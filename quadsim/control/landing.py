"""Landing, the landed state and the altitude limits, as a layer between the gate and either controller.

The controllers fly; this layer decides what they are asked near the ground and at the ceiling:
- A descent near the ground is slowed: the descent rate allowed is the larger of the touchdown
  rate and `slow_down_per_s` x the height above the resting height, so the vehicle touches down at
  about `touchdown_rate_mps` (unless hard landings are allowed: then nothing is slowed).
- Below `min_altitude_m` no altitude is held: with no climb wanted the vehicle goes down and
  lands. In height z-mode an altitude wanted below `min_altitude_m` (the ground included) lands.
- In velocity z-mode the climb rate is cut so the vehicle never rises above `max_altitude_m`
  (height z-mode already clamps the altitude wanted).
- On the ground with no climb wanted, the vehicle is landed: rotors at idle, controller cleared.
  A climb (or, in height z-mode, an altitude of at least `min_altitude_m`) takes off again.
Touching the ground is the physics' finding, handed in by the loop: this stays pure numeric code.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from quadsim.control import Controller
from quadsim.core.types import HEIGHT_MODE_BASE_M, ActiveCommand, RotorForces, Twist, VehicleState, ZMode
from quadsim.vehicle.params import CommandLimits


class FlightPhase(enum.Enum):
    LANDED = "landed"  # on the ground, rotors idle
    FLYING = "flying"


@dataclass(frozen=True)
class LandingSettings:
    """How the vehicle lands; units in the names."""

    touchdown_rate_mps: float = 0.3  # the descent rate allowed at contact
    slow_down_per_s: float = 1.0  # descent allowed above that: this x height above the ground
    ceiling_gain_per_s: float = 2.0  # climb allowed below max_altitude_m: this x the distance to it
    hard_landing: bool = False  # True: descents are not slowed near the ground


class LandingLayer:
    """Wraps a controller: the command it sees near the ground and the ceiling, and idle rotors
    while landed. `phase` says which; `update` returns the rotor forces."""

    def __init__(
        self,
        controller: Controller,
        limits: CommandLimits,
        rest_height_m: float,
        rotor_count: int,
        settings: LandingSettings = LandingSettings(),
    ) -> None:
        self.controller = controller
        self.limits = limits
        self.rest_height_m = rest_height_m
        self.settings = settings
        self._idle: RotorForces = (0.0,) * rotor_count
        self.phase = FlightPhase.LANDED

    def reset(self) -> None:
        """On the ground, at rest (the start pose)."""
        self.phase = FlightPhase.LANDED
        self.controller.reset()

    def _descent_allowed(self, z: float) -> float:
        s = self.settings
        if s.hard_landing:
            return self.limits.max_descent_rate_mps
        return min(
            self.limits.max_descent_rate_mps, max(s.touchdown_rate_mps, s.slow_down_per_s * (z - self.rest_height_m))
        )

    def command(self, state: VehicleState, command: ActiveCommand) -> tuple[ActiveCommand, bool]:
        """The command the controller should fly while flying, and whether a climb is wanted."""
        lim = self.limits
        z = state.position_m[2]
        tw = command.twist
        if command.z_mode is ZMode.HEIGHT:
            if command.hold:
                return command, z >= lim.min_altitude_m
            if HEIGHT_MODE_BASE_M + tw.linear_z >= lim.min_altitude_m:
                return command, True
            # an altitude below the lowest held one (the ground included): land, in velocity terms
            landing = tw._replace(linear_z=-self._descent_allowed(z))
            return ActiveCommand(landing, ZMode.VELOCITY, True, False), False
        vz = 0.0 if command.hold else tw.linear_z
        climb = vz > 0.0
        ceiling = self.settings.ceiling_gain_per_s * (lim.max_altitude_m - z)
        if vz > ceiling:
            vz = ceiling
        elif vz <= 0.0 and z < lim.min_altitude_m:
            vz = -lim.max_descent_rate_mps  # too low to hold an altitude: go down and land
        if vz < 0.0:
            vz = max(vz, -self._descent_allowed(z))
        if vz == tw.linear_z or (command.hold and vz == 0.0):
            return command, climb
        base = Twist() if command.hold else tw
        return ActiveCommand(base._replace(linear_z=vz), ZMode.VELOCITY, True, False), climb

    def update(self, state: VehicleState, command: ActiveCommand, on_ground: bool, dt_s: float) -> RotorForces:
        """Rotor forces for this control step. `on_ground`: the vehicle rests on something below it."""
        if not command.armed:
            self.phase = FlightPhase.LANDED
            return self.controller.update(state, command, dt_s)
        flown, climb = self.command(state, command)
        if self.phase is FlightPhase.LANDED:
            if not climb:
                return self._idle
            self.controller.reset()  # take off from here, with nothing wound up on the ground
            self.phase = FlightPhase.FLYING
        elif on_ground and not climb:
            self.phase = FlightPhase.LANDED
            self.controller.reset()
            return self._idle
        return self.controller.update(state, flown, dt_s)
