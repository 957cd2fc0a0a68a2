"""The cascade controller: velocity -> attitude (thrust direction) -> body rate -> mixer.

Each axis either tracks the commanded rate (horizontal velocity in the heading frame, climb
rate, heading rate about world z) or, when that part of the command is zero or the dead-man has fired, holds
what it had once the vehicle has slowed down (position, altitude, heading). Hover thrust is fed
forward, less near the ground by the airframe's ground-effect ratio (or a vehicle armed on the
ground would lift off its skids before the integrator caught up); tilt, climb rate and body rates are saturated; integrators stop while saturated.

The update is written with plain floats, not numpy: at 240 Hz it is the hot path.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, ClassVar

from quadsim.control import ControllerKind
from quadsim.control.gains import load_gains
from quadsim.core.kinematics import Mat3, clamp, matrix_from_quaternion
from quadsim.core.types import HEIGHT_MODE_BASE_M, ActiveCommand, RotorForces, VehicleState, ZMode
from quadsim.vehicle.aero import ground_effect_ratio, rotor_speed_radps
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


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class CascadeController:
    kind = ControllerKind.CASCADE

    def __init__(self, vehicle: VehicleParams, gains: CascadeGains | None = None) -> None:
        if gains is None:
            gains = load_gains(vehicle, ControllerKind.CASCADE.value, CascadeGains)
        self.vehicle = vehicle
        self.gains = gains
        self.mixer = Mixer(vehicle)
        self._idle: RotorForces = (0.0,) * len(vehicle.rotors)
        self._mass = vehicle.mass_kg
        self._g = vehicle.gravity_mps2
        self._jxx = vehicle.inertia_kgm2[0][0]
        self._jyy = vehicle.inertia_kgm2[1][1]
        self._jzz = vehicle.inertia_kgm2[2][2]
        # drag feed-forward: the acceleration lost to drag at the wanted velocity in still air,
        # level, in hover (body drag, linear and quadratic, and rotor drag at hover speed)
        aero, m = vehicle.aero, vehicle.mass_kg
        hover_speed_sum = len(vehicle.rotors) * rotor_speed_radps(
            vehicle.hover_thrust_per_rotor_n, vehicle.thrust_coefficient_n_per_rad2s2
        )
        self._drag_xy = (aero.body_drag_linear_ns_per_m[0] + aero.rotor_drag_ns_per_m_rad * hover_speed_sum) / m
        self._drag_z = aero.body_drag_linear_ns_per_m[2] / m
        self._drag_q_xy = aero.body_drag_quadratic_ns2_per_m2[0] / m
        self._drag_q_z = aero.body_drag_quadratic_ns2_per_m2[2] / m
        self._tan_tilt = math.tan(gains.max_tilt_rad)
        # the rotor hubs' mean position relative to the base origin, for their height above the floor
        hubs = vehicle.rotor_hubs_m
        self._hub = tuple(sum(hub[i] for hub in hubs) / len(hubs) for i in range(3))
        self._ground_effect = aero.ground_effect
        self.reset()

    def describe(self) -> dict[str, Any]:
        return {"name": self.kind.value, "gains": asdict(self.gains)}

    def reset(self) -> None:
        self._armed = False
        self._xy_hold: tuple[float, float] | None = None
        self._z_hold: float | None = None
        self._z_target: float | None = None
        self._yaw_hold: float | None = None
        self._ix = self._iy = self._iz = 0.0

    def update(self, state: VehicleState, command: ActiveCommand, dt_s: float) -> RotorForces:
        """Rotor forces for this control step: the set-points of the command (or the holds), then
        the velocity, attitude and rate loops, outermost first. (Each step is a method taking and
        returning plain floats: this is the hot path, at the control rate.)"""
        if not command.armed:
            self._armed = False
            return self._idle
        px, py, pz = state.position_m
        if not self._armed:
            self.reset()
            self._armed = True
            self._xy_hold = (px, py)
            self._z_hold = pz
            self._yaw_hold = None
        r = matrix_from_quaternion(state.orientation_xyzw)  # rotation world <- body
        (r00, _, _), (r10, _, _), (r20, r21, r22) = r
        if command.hold:
            ux = uy = uz = ur = 0.0
        else:
            tw = command.twist
            ux, uy, uz, ur = tw.linear_x, tw.linear_y, tw.linear_z, tw.angular_z
        vx, vy, vz = state.linear_velocity_mps
        wp, wq, wr = state.angular_velocity_body_rps
        heading_rate = r20 * wp + r21 * wq + r22 * wr  # the body rates' world-z component
        yaw = math.atan2(r10, r00)
        vsx, vsy, turn_ax, turn_ay = self._horizontal_setpoint(ux, uy, yaw, heading_rate, px, py, vx, vy)
        vsz = self._vertical_setpoint(uz, command, pz, vz)
        hs = self._heading_setpoint(ur, yaw, heading_rate)
        ax, ay, az = self._velocity_loop(vsx, vsy, vsz, vx, vy, vz, turn_ax, turn_ay, dt_s)
        thrust, ps, qs = self._attitude_loop(ax, ay, az, r, pz)
        return self._rate_loop(thrust, ps, qs, hs, r20, r21, r22, wp, wq, wr)

    def _horizontal_setpoint(
        self, ux: float, uy: float, yaw: float, heading_rate: float, px: float, py: float, vx: float, vy: float
    ) -> tuple[float, float, float, float]:
        """The wanted world velocity: the commanded one (heading frame -> world) with the turn's
        feed-forward acceleration, or back to the held position once slowed down."""
        turn_ax = turn_ay = 0.0
        if ux != 0.0 or uy != 0.0:
            self._xy_hold = None
            c, s = math.cos(yaw), math.sin(yaw)
            vsx, vsy = c * ux - s * uy, s * ux + c * uy
            # while turning, that set-point rotates with the heading: feed its rate of change
            # (heading rate x velocity) forward, or the loop lags it and the vehicle slips sideways
            turn_ax, turn_ay = -heading_rate * vsy, heading_rate * vsx
            return vsx, vsy, turn_ax, turn_ay
        g = self.gains
        if self._xy_hold is None and vx * vx + vy * vy < g.hold_latch_speed_mps * g.hold_latch_speed_mps:
            self._xy_hold = (px, py)
        if self._xy_hold is None:
            return 0.0, 0.0, turn_ax, turn_ay
        vsx = g.position_p_per_s * (self._xy_hold[0] - px)
        vsy = g.position_p_per_s * (self._xy_hold[1] - py)
        sp = math.hypot(vsx, vsy)
        max_speed = self.vehicle.limits.max_horizontal_speed_mps
        if sp > max_speed:
            k = max_speed / sp
            vsx, vsy = vsx * k, vsy * k
        return vsx, vsy, turn_ax, turn_ay

    def _vertical_setpoint(self, uz: float, command: ActiveCommand, pz: float, vz: float) -> float:
        """The wanted climb rate: commanded, back to the held altitude, or to the height z-mode's
        altitude; within the vehicle's climb and descent limits."""
        g, lim = self.gains, self.vehicle.limits
        if command.z_mode is ZMode.HEIGHT:
            self._z_hold = None
            if not command.hold or self._z_target is None:
                self._z_target = HEIGHT_MODE_BASE_M + uz if not command.hold else pz
            vsz = g.altitude_p_per_s * (self._z_target - pz)
        else:
            self._z_target = None
            if uz != 0.0:
                self._z_hold = None
                vsz = uz
            else:
                if self._z_hold is None and vz * vz < g.hold_latch_speed_mps * g.hold_latch_speed_mps:
                    self._z_hold = pz
                vsz = 0.0 if self._z_hold is None else g.altitude_p_per_s * (self._z_hold - pz)
        if vsz > lim.max_climb_rate_mps:
            vsz = lim.max_climb_rate_mps
        elif vsz < -lim.max_descent_rate_mps:
            vsz = -lim.max_descent_rate_mps
        return vsz

    def _heading_setpoint(self, ur: float, yaw: float, heading_rate: float) -> float:
        """The wanted heading rate (about world z): commanded, or back to the held heading."""
        g = self.gains
        if ur != 0.0:
            self._yaw_hold = None
            return ur
        if self._yaw_hold is None and -g.hold_latch_yaw_rate_radps < heading_rate < g.hold_latch_yaw_rate_radps:
            self._yaw_hold = yaw
        return 0.0 if self._yaw_hold is None else g.heading_p_per_s * _wrap(self._yaw_hold - yaw)

    def _velocity_loop(
        self,
        vsx: float,
        vsy: float,
        vsz: float,
        vx: float,
        vy: float,
        vz: float,
        turn_ax: float,
        turn_ay: float,
        dt_s: float,
    ) -> tuple[float, float, float]:
        """Velocity loop (world frame) -> wanted acceleration, with drag feed-forward, within the
        vertical acceleration and tilt limits; the integrators run only while unsaturated."""
        g = self.gains
        ex, ey, ez = vsx - vx, vsy - vy, vsz - vz
        drag_xy = self._drag_xy + self._drag_q_xy * math.hypot(vsx, vsy)
        ax = g.velocity_p_xy_per_s * ex + self._ix + drag_xy * vsx + turn_ax
        ay = g.velocity_p_xy_per_s * ey + self._iy + drag_xy * vsy + turn_ay
        az = g.velocity_p_z_per_s * ez + self._iz + (self._drag_z + self._drag_q_z * abs(vsz)) * vsz
        sat_z = False
        if az > g.max_up_accel_mps2:
            az, sat_z = g.max_up_accel_mps2, True
        elif az < -g.max_down_accel_mps2:
            az, sat_z = -g.max_down_accel_mps2, True
        a_max = (az + self._g) * self._tan_tilt  # the tilt limit, as a horizontal acceleration
        ah = math.hypot(ax, ay)
        sat_xy = ah > a_max
        if sat_xy:
            k = a_max / ah
            ax, ay = ax * k, ay * k
        # anti-windup: integrate only while the output is not saturated and the error is small
        # (a transient's large error would otherwise wind the integrator up and overshoot)
        ilim, band = g.velocity_i_limit_mps2, g.velocity_i_band_mps
        if not sat_xy and -band < ex < band and -band < ey < band:
            self._ix = clamp(self._ix + g.velocity_i_xy_per_s2 * ex * dt_s, -ilim, ilim)
            self._iy = clamp(self._iy + g.velocity_i_xy_per_s2 * ey * dt_s, -ilim, ilim)
        if not sat_z and -band < ez < band:
            self._iz = clamp(self._iz + g.velocity_i_z_per_s2 * ez * dt_s, -ilim, ilim)
        return ax, ay, az

    def _attitude_loop(self, ax: float, ay: float, az: float, r: Mat3, pz: float) -> tuple[float, float, float]:
        """The wanted acceleration as collective thrust along the current body z (less near the
        ground by the ground-effect ratio) and the roll and pitch rates that tilt the body z
        toward it."""
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = r
        m = self._mass
        fx, fy, fz = m * ax, m * ay, m * (az + self._g)
        thrust = fx * r02 + fy * r12 + fz * r22
        if thrust < 0.0:
            thrust = 0.0
        if self._ground_effect:
            hx, hy, hz = self._hub
            aero = self.vehicle.aero
            thrust /= ground_effect_ratio(
                pz + r20 * hx + r21 * hy + r22 * hz, aero.rotor_radius_m, aero.ground_effect_max_ratio
            )
        norm = math.sqrt(fx * fx + fy * fy + fz * fz)
        bx, by, bz = fx / norm, fy / norm, fz / norm
        # wanted body z expressed in the body frame; tilt error about e3 x d
        dx = r00 * bx + r10 * by + r20 * bz
        dy = r01 * bx + r11 * by + r21 * bz
        dz = r02 * bx + r12 * by + r22 * bz
        sin_t = math.sqrt(dx * dx + dy * dy)
        k_att = self.gains.attitude_p_per_s * (math.atan2(sin_t, dz) / sin_t if sin_t > 1e-9 else 1.0)
        mr = self.gains.max_rate_rp_radps
        return thrust, clamp(-k_att * dy, -mr, mr), clamp(k_att * dx, -mr, mr)

    def _rate_loop(
        self,
        thrust: float,
        ps: float,
        qs: float,
        hs: float,
        r20: float,
        r21: float,
        r22: float,
        wp: float,
        wq: float,
        wr: float,
    ) -> RotorForces:
        """The body yaw rate that gives the wanted heading rate in a bank, then the rate loop ->
        body torques (with the gyroscopic term), then the mixer."""
        g = self.gains
        mr = g.max_rate_rp_radps
        # the heading rate is the body rates' world-z component (r20 p + r21 q + r22 r): in a bank,
        # the body z rate that gives the wanted heading rate, with the roll/pitch rates wanted
        my = self.vehicle.limits.max_yaw_rate_radps
        hs = clamp(hs, -my, my)
        rs = clamp((hs - r20 * ps - r21 * qs) / max(r22, 0.5), -mr, mr)
        ap = g.rate_p_rp_per_s * (ps - wp)
        aq = g.rate_p_rp_per_s * (qs - wq)
        ar = g.rate_p_yaw_per_s * (rs - wr)
        jxx, jyy, jzz = self._jxx, self._jyy, self._jzz
        tx = jxx * ap + (jzz - jyy) * wq * wr
        ty = jyy * aq + (jxx - jzz) * wp * wr
        tz = jzz * ar + (jyy - jxx) * wp * wq
        return self.mixer.to_rotor_forces(thrust, tx, ty, tz)
