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
from quadsim.core.compiled import Floats, jit, specialize
from quadsim.core.types import HEIGHT_MODE_BASE_M, ActiveCommand, RotorForces, Twist, VehicleState, ZMode
from quadsim.vehicle.params import CommandLimits

#: the landing layer's numbers, in this order, as `landing_command` takes them (`LandingLayer.numbers`)
NUMBERS = (
    "max_descent_rate_mps",
    "min_altitude_m",
    "max_altitude_m",
    "touchdown_rate_mps",
    "slow_down_per_s",
    "ceiling_gain_per_s",
    "rest_height_m",
    "hard_landing",
)


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
        #: the limits, the settings and the resting height as `landing_command` takes them (NUMBERS)
        self.numbers = (
            float(limits.max_descent_rate_mps),
            float(limits.min_altitude_m),
            float(limits.max_altitude_m),
            float(settings.touchdown_rate_mps),
            float(settings.slow_down_per_s),
            float(settings.ceiling_gain_per_s),
            float(rest_height_m),
            1.0 if settings.hard_landing else 0.0,
        )
        self._command = specialize(landing_command, 0.0, (0.0, 0.0, 0.0, 0.0), True, True, self.numbers)

    def reset(self) -> None:
        """On the ground, at rest (the start pose)."""
        self.phase = FlightPhase.LANDED
        self.controller.reset()

    def command(self, state: VehicleState, command: ActiveCommand) -> tuple[ActiveCommand, bool]:
        """The command the controller should fly while flying, and whether a climb is wanted
        (`landing_command`'s arithmetic)."""
        tw = command.twist
        height = command.z_mode is ZMode.HEIGHT
        vz = float(tw.linear_z)
        _, _, flown_z, _, _, _, climb, same = self._command(
            float(state.position_m[2]), (0.0, 0.0, vz, 0.0), height, command.hold, self.numbers
        )
        if same:
            return command, climb
        base = Twist() if command.hold else tw
        return ActiveCommand(base._replace(linear_z=flown_z), ZMode.VELOCITY, True, False), climb

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


@jit
def landing_command(
    z: float, twist: tuple[float, float, float, float], height: bool, hold: bool, numbers: Floats
) -> tuple[float, float, float, float, bool, bool, bool, bool]:
    """What the controller flies while flying, at height `z`, for the command `twist` (linear x,
    y, z and angular z, its z read as a height if `height`; `hold`: the dead-man's hold): the
    command flown (its four values, whether its z is a height, whether it holds), whether a
    climb is wanted, and whether the command flown is the one given (`numbers`: NUMBERS)."""
    max_descent, min_altitude, max_altitude = numbers[0], numbers[1], numbers[2]
    touchdown, slow_down, ceiling_gain, rest, hard = numbers[3], numbers[4], numbers[5], numbers[6], numbers[7]
    vx, vy, vz, wz = twist
    # the descent rate allowed near the ground: slowed to the touchdown rate, unless landings are hard
    allowed = max_descent if hard != 0.0 else min(max_descent, max(touchdown, slow_down * (z - rest)))
    if height:
        if hold:
            return vx, vy, vz, wz, True, True, z >= min_altitude, True
        if HEIGHT_MODE_BASE_M + vz >= min_altitude:
            return vx, vy, vz, wz, True, False, True, True
        # an altitude below the lowest held one (the ground included): land, in velocity terms
        return vx, vy, -allowed, wz, False, False, False, False
    wanted = 0.0 if hold else vz
    climb = wanted > 0.0
    ceiling = ceiling_gain * (max_altitude - z)
    if wanted > ceiling:
        wanted = ceiling
    elif wanted <= 0.0 and z < min_altitude:
        wanted = -max_descent  # too low to hold an altitude: go down and land
    if wanted < 0.0:
        wanted = max(wanted, -allowed)
    if wanted == vz or (hold and wanted == 0.0):
        return vx, vy, vz, wz, False, hold, climb, True
    if hold:  # from the hold: nothing else wanted
        return 0.0, 0.0, wanted, 0.0, False, False, climb, False
    return vx, vy, wanted, wz, False, False, climb, False
