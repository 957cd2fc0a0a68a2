"""The cascade controller: velocity -> attitude (thrust direction) -> body rate -> mixer.

Each axis either tracks the commanded rate (horizontal velocity in the heading frame, climb
rate, heading rate about world z) or, when that part of the command is zero or the dead-man has fired, holds
what it had once the vehicle has slowed down (position, altitude, heading). Hover thrust is fed
forward, less near the ground by the airframe's ground-effect ratio (or a vehicle armed on the
ground would lift off its skids before the integrator caught up); tilt, climb rate and body rates are saturated; integrators stop while saturated.

The update is one function of floats and arrays (quadsim.control.cascade_step), compiled where
numba is installed: at 240 Hz it is the hot path.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, ClassVar

from quadsim.control import ControllerKind
from quadsim.control.cascade_step import IX, K_FIELDS, S_FIELDS, X_HOLD, Y_HOLD, Z_HOLD, cascade_update
from quadsim.control.gains import load_gains
from quadsim.core.compiled import COMPILED, float_tuple, floats, specialize
from quadsim.core.kinematics import matrix_from_quaternion
from quadsim.core.types import HEIGHT_MODE_BASE_M, ActiveCommand, RotorForces, VehicleState, ZMode
from quadsim.vehicle.aero import rotor_speed_radps
from quadsim.vehicle.mixer import Mixer
from quadsim.vehicle.params import VehicleParams


@dataclass(frozen=True)
class CascadeGains:
    """Gains and saturations of the cascade; units in the names (1/s is a loop bandwidth).
    Their values are data: the [cascade] table of the airframe's NAME.gains.toml."""

    #: every one is a magnitude (a gain, a limit, a band): none may be negative
    NON_NEGATIVE: ClassVar[bool] = True

    position_p_per_s: float
    altitude_p_per_s: float
    heading_p_per_s: float
    velocity_p_xy_per_s: float
    velocity_i_xy_per_s2: float
    velocity_p_z_per_s: float
    velocity_i_z_per_s2: float
    velocity_i_limit_mps2: float
    velocity_i_band_mps: float
    attitude_p_per_s: float
    rate_p_rp_per_s: float
    rate_p_yaw_per_s: float
    max_tilt_rad: float
    max_rate_rp_radps: float
    max_up_accel_mps2: float
    max_down_accel_mps2: float
    hold_latch_speed_mps: float
    hold_latch_yaw_rate_radps: float


_HEIGHT = ZMode.HEIGHT


#: the command while the dead-man holds: nothing wanted, every hold keeps its place
_NO_COMMAND = (0.0, 0.0, 0.0, 0.0)


def _constants(vehicle: VehicleParams, gains: CascadeGains) -> dict[str, float]:
    """What `cascade_update` reads from its `k`, by name (cascade_step.K_FIELDS)."""
    # drag feed-forward: the acceleration lost to drag at the wanted velocity in still air,
    # level, in hover (body drag, linear and quadratic, and rotor drag at hover speed)
    aero, m, lim = vehicle.aero, vehicle.mass_kg, vehicle.limits
    hover_speed_sum = len(vehicle.rotors) * rotor_speed_radps(
        vehicle.hover_thrust_per_rotor_n, vehicle.thrust_coefficient_n_per_rad2s2
    )
    # the rotor hubs' mean position relative to the base origin, for their height above the floor
    hubs = vehicle.rotor_hubs_m
    hub = [sum(h[i] for h in hubs) / len(hubs) for i in range(3)]
    (jxx, _, _), (_, jyy, _), (_, _, jzz) = vehicle.inertia_kgm2
    return {
        **asdict(gains),
        "max_horizontal_speed_mps": lim.max_horizontal_speed_mps,
        "max_climb_rate_mps": lim.max_climb_rate_mps,
        "max_descent_rate_mps": lim.max_descent_rate_mps,
        "max_yaw_rate_radps": lim.max_yaw_rate_radps,
        "mass_kg": m,
        "gravity_mps2": vehicle.gravity_mps2,
        "jxx": jxx,
        "jyy": jyy,
        "jzz": jzz,
        "drag_xy": (aero.body_drag_linear_ns_per_m[0] + aero.rotor_drag_ns_per_m_rad * hover_speed_sum) / m,
        "drag_z": (aero.body_drag_linear_ns_per_m[2] + aero.rotor_axial_drag_ns_per_m_rad * hover_speed_sum) / m,
        "drag_q_xy": aero.body_drag_quadratic_ns2_per_m2[0] / m,
        "drag_q_z": aero.body_drag_quadratic_ns2_per_m2[2] / m,
        "tan_max_tilt": math.tan(gains.max_tilt_rad),
        "hub_x_m": hub[0],
        "hub_y_m": hub[1],
        "hub_z_m": hub[2],
        "ground_effect": 1.0 if aero.ground_effect else 0.0,
        "rotor_radius_m": aero.rotor_radius_m,
        "ground_effect_max_ratio": aero.ground_effect_max_ratio,
        "height_mode_base_m": HEIGHT_MODE_BASE_M,
        "max_thrust_n": vehicle.max_thrust_n,
    }


class CascadeController:
    kind = ControllerKind.CASCADE

    def __init__(self, vehicle: VehicleParams, gains: CascadeGains | None = None) -> None:
        if gains is None:
            gains = load_gains(vehicle, ControllerKind.CASCADE.value, CascadeGains)
        self.vehicle = vehicle
        self.gains = gains
        self.mixer = Mixer(vehicle)
        self._idle: RotorForces = (0.0,) * len(vehicle.rotors)
        constants = _constants(vehicle, gains)
        self._k = floats(constants[name] for name in K_FIELDS)
        self._rows = self.mixer.rows
        self._s = floats([0.0] * len(S_FIELDS))
        self._out = floats([0.0] * len(vehicle.rotors))
        xyz = (0.0, 0.0, 0.0)
        #: cascade_update for the states the loop builds (tuples of floats), without type dispatch
        self._update = specialize(
            cascade_update,
            self._k,
            self._rows,
            self._s,
            xyz,
            (xyz, xyz, xyz),
            xyz,
            xyz,
            _NO_COMMAND,
            True,
            True,
            1.0,
            self._out,
        )
        self.reset()

    def describe(self) -> dict[str, Any]:
        return {"name": self.kind.value, "gains": asdict(self.gains)}

    @property
    def armed(self) -> bool:
        """Whether it flies (its holds latched at the first update after the gate armed)."""
        return self._armed

    @property
    def compiled_state(self) -> tuple[Any, Any, Any, Any]:
        """Its gains, the mixer's rows, its state and its output, as `cascade_update` takes them
        (quadsim.sim.clear_flight calls it with them)."""
        return self._k, self._rows, self._s, self._out

    @property
    def last_forces(self) -> RotorForces:
        """The rotor forces of its last update."""
        return tuple(self._out.tolist()) if COMPILED else tuple(self._out)

    def reset(self) -> None:
        self._armed = False
        s = self._s
        for i in range(len(s)):
            s[i] = math.nan if i < IX else 0.0  # the holds, not latched; the integrators

    def update(self, state: VehicleState, command: ActiveCommand, dt_s: float) -> RotorForces:
        """Rotor forces for this control step: the set-points of the command (or the holds), then
        the velocity, attitude and rate loops, outermost first (quadsim.control.cascade_step)."""
        if not command.armed:
            self._armed = False
            return self._idle
        s = self._s
        if not self._armed:  # hold where it stands, heading latched once it stops turning
            self.reset()
            self._armed = True
            s[X_HOLD], s[Y_HOLD], s[Z_HOLD] = state.position_m
        if command.hold:
            wanted = _NO_COMMAND
        else:
            tw = command.twist
            wanted = (tw.linear_x, tw.linear_y, tw.linear_z, tw.angular_z)
        out = self._out
        position, r = state.position_m, matrix_from_quaternion(state.orientation_xyzw)
        velocity, rates = state.linear_velocity_mps, state.angular_velocity_body_rps
        height, hold = command.z_mode is _HEIGHT, command.hold
        try:
            self._update(self._k, self._rows, s, position, r, velocity, rates, wanted, height, hold, dt_s, out)
        except (TypeError, ValueError):  # a state built by hand, with lists or integers: as the loop builds it
            position, velocity, rates = float_tuple(position), float_tuple(velocity), float_tuple(rates)
            r = matrix_from_quaternion(float_tuple(state.orientation_xyzw))
            wanted = float_tuple(wanted)
            self._update(self._k, self._rows, s, position, r, velocity, rates, wanted, height, hold, float(dt_s), out)
        return self.last_forces
