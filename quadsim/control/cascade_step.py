"""One update of the cascade controller as a function of floats: compiled where numba is
installed (quadsim.core.compiled), the same Python function where it is not.

`cascade_update` reads the gains and vehicle constants from `k` (laid out by `K_FIELDS`), keeps the
holds and integrators in `s` (laid out by `S_FIELDS`; a hold not latched is NaN) and writes the rotor
forces into `out`. quadsim.control.cascade.CascadeController builds those and documents the loops.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from quadsim.core.compiled import Floats, MutableFloats, jit
from quadsim.vehicle.aero import ground_effect_ratio
from quadsim.vehicle.mixer import mix

#: the constants `k` holds, in order
K_FIELDS = (
    "position_p_per_s",
    "altitude_p_per_s",
    "heading_p_per_s",
    "velocity_p_xy_per_s",
    "velocity_i_xy_per_s2",
    "velocity_p_z_per_s",
    "velocity_i_z_per_s2",
    "velocity_i_limit_mps2",
    "velocity_i_band_mps",
    "attitude_p_per_s",
    "rate_p_rp_per_s",
    "rate_p_yaw_per_s",
    "max_rate_rp_radps",
    "max_up_accel_mps2",
    "max_down_accel_mps2",
    "hold_latch_speed_mps",
    "hold_latch_yaw_rate_radps",
    "max_horizontal_speed_mps",
    "max_climb_rate_mps",
    "max_descent_rate_mps",
    "max_yaw_rate_radps",
    "mass_kg",
    "gravity_mps2",
    "jxx",
    "jyy",
    "jzz",
    "drag_xy",
    "drag_z",
    "drag_q_xy",
    "drag_q_z",
    "tan_max_tilt",
    "hub_x_m",
    "hub_y_m",
    "hub_z_m",
    "ground_effect",
    "rotor_radius_m",
    "ground_effect_max_ratio",
    "height_mode_base_m",
    "max_thrust_n",
)
#: the holds and integrators `s` holds, in order (NaN: that hold is not latched)
S_FIELDS = ("x_hold", "y_hold", "z_hold", "z_target", "yaw_hold", "ix", "iy", "iz")

# where each of those is in `k` and `s` (constants in the compiled code)
(
    POSITION_P,
    ALTITUDE_P,
    HEADING_P,
    VELOCITY_P_XY,
    VELOCITY_I_XY,
    VELOCITY_P_Z,
    VELOCITY_I_Z,
    I_LIMIT,
    I_BAND,
    ATTITUDE_P,
    RATE_P_RP,
    RATE_P_YAW,
    MAX_RATE_RP,
    MAX_UP_ACCEL,
    MAX_DOWN_ACCEL,
    LATCH_SPEED,
    LATCH_YAW_RATE,
    MAX_SPEED,
    MAX_CLIMB,
    MAX_DESCENT,
    MAX_YAW_RATE,
    MASS,
    GRAVITY,
    JXX,
    JYY,
    JZZ,
    DRAG_XY,
    DRAG_Z,
    DRAG_Q_XY,
    DRAG_Q_Z,
    TAN_MAX_TILT,
    HUB_X,
    HUB_Y,
    HUB_Z,
    GROUND_EFFECT,
    ROTOR_RADIUS,
    GROUND_EFFECT_MAX,
    HEIGHT_MODE_BASE,
    MAX_THRUST,
) = range(len(K_FIELDS))
(X_HOLD, Y_HOLD, Z_HOLD, Z_TARGET, YAW_HOLD, IX, IY, IZ) = range(len(S_FIELDS))


@jit
def _clamp(value: float, low: float, high: float) -> float:
    return low if value < low else (high if value > high else value)


Mat3 = tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]


@jit
def cascade_update(
    k: Floats,
    rows: Sequence[Floats],
    s: MutableFloats,
    position: tuple[float, float, float],
    r: Mat3,
    velocity: tuple[float, float, float],
    body_rates: tuple[float, float, float],
    command: tuple[float, float, float, float],
    height_mode: bool,
    hold: bool,
    dt_s: float,
    out: MutableFloats,
) -> None:
    """The cascade's update for an armed vehicle: set-points (command or holds), then the velocity,
    attitude and rate loops, then the mixer. `r`: the attitude, world <- body; `command`: (linear x, y, z, angular z), zeros when
    `hold`; `height_mode`: linear.z is an altitude (quadsim.core.types.ZMode.HEIGHT)."""
    px, py, pz = position
    vx, vy, vz = velocity
    wp, wq, wr = body_rates
    ux, uy, uz, ur = command
    (r00, _, _), (r10, _, _), (r20, r21, r22) = r
    heading_rate = r20 * wp + r21 * wq + r22 * wr  # the body rates' world-z component
    yaw = math.atan2(r10, r00)
    vsx, vsy, turn_ax, turn_ay = _horizontal_setpoint(k, s, ux, uy, yaw, heading_rate, px, py, vx, vy)
    vsz = _vertical_setpoint(k, s, uz, height_mode, hold, pz, vz)
    hs = _heading_setpoint(k, s, ur, yaw, heading_rate)
    ax, ay, az = _velocity_loop(k, s, vsx, vsy, vsz, vx, vy, vz, turn_ax, turn_ay, dt_s)
    thrust, ps, qs = _attitude_loop(k, ax, ay, az, r, pz)
    tx, ty, tz = _rate_loop(k, ps, qs, hs, r20, r21, r22, wp, wq, wr)
    mix(rows, k[MAX_THRUST], thrust, tx, ty, tz, out)


@jit
def _horizontal_setpoint(
    k: Floats,
    s: MutableFloats,
    ux: float,
    uy: float,
    yaw: float,
    heading_rate: float,
    px: float,
    py: float,
    vx: float,
    vy: float,
) -> tuple[float, float, float, float]:
    """The wanted world velocity: the commanded one (heading frame -> world) with the turn's
    feed-forward acceleration, or back to the held position once slowed down."""
    if ux != 0.0 or uy != 0.0:
        s[X_HOLD] = s[Y_HOLD] = math.nan
        c, sn = math.cos(yaw), math.sin(yaw)
        vsx, vsy = c * ux - sn * uy, sn * ux + c * uy
        # while turning, that set-point rotates with the heading: feed its rate of change
        # (heading rate x velocity) forward, or the loop lags it and the vehicle slips sideways
        return vsx, vsy, -heading_rate * vsy, heading_rate * vsx
    if math.isnan(s[X_HOLD]) and vx * vx + vy * vy < k[LATCH_SPEED] * k[LATCH_SPEED]:
        s[X_HOLD], s[Y_HOLD] = px, py
    if math.isnan(s[X_HOLD]):
        return 0.0, 0.0, 0.0, 0.0
    vsx = k[POSITION_P] * (s[X_HOLD] - px)
    vsy = k[POSITION_P] * (s[Y_HOLD] - py)
    sp = math.sqrt(vsx * vsx + vsy * vsy)
    if sp > k[MAX_SPEED]:
        scale = k[MAX_SPEED] / sp
        vsx, vsy = vsx * scale, vsy * scale
    return vsx, vsy, 0.0, 0.0


@jit
def _vertical_setpoint(
    k: Floats, s: MutableFloats, uz: float, height_mode: bool, hold: bool, pz: float, vz: float
) -> float:
    """The wanted climb rate: commanded, back to the held altitude, or to the height mode's
    altitude; within the vehicle's climb and descent limits."""
    if height_mode:
        s[Z_HOLD] = math.nan
        if not hold or math.isnan(s[Z_TARGET]):
            s[Z_TARGET] = k[HEIGHT_MODE_BASE] + uz if not hold else pz
        vsz = k[ALTITUDE_P] * (s[Z_TARGET] - pz)
    else:
        s[Z_TARGET] = math.nan
        if uz != 0.0:
            s[Z_HOLD] = math.nan
            vsz = uz
        else:
            if math.isnan(s[Z_HOLD]) and vz * vz < k[LATCH_SPEED] * k[LATCH_SPEED]:
                s[Z_HOLD] = pz
            vsz = 0.0 if math.isnan(s[Z_HOLD]) else k[ALTITUDE_P] * (s[Z_HOLD] - pz)
    if vsz > k[MAX_CLIMB]:
        vsz = k[MAX_CLIMB]
    elif vsz < -k[MAX_DESCENT]:
        vsz = -k[MAX_DESCENT]
    return vsz


@jit
def _heading_setpoint(k: Floats, s: MutableFloats, ur: float, yaw: float, heading_rate: float) -> float:
    """The wanted heading rate (about world z): commanded, or back to the held heading."""
    if ur != 0.0:
        s[YAW_HOLD] = math.nan
        return ur
    if math.isnan(s[YAW_HOLD]) and -k[LATCH_YAW_RATE] < heading_rate < k[LATCH_YAW_RATE]:
        s[YAW_HOLD] = yaw
    if math.isnan(s[YAW_HOLD]):
        return 0.0
    return k[HEADING_P] * ((s[YAW_HOLD] - yaw + math.pi) % (2.0 * math.pi) - math.pi)


@jit
def _velocity_loop(
    k: Floats,
    s: MutableFloats,
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
    ex, ey, ez = vsx - vx, vsy - vy, vsz - vz
    drag_xy = k[DRAG_XY] + k[DRAG_Q_XY] * math.sqrt(vsx * vsx + vsy * vsy)
    ax = k[VELOCITY_P_XY] * ex + s[IX] + drag_xy * vsx + turn_ax
    ay = k[VELOCITY_P_XY] * ey + s[IY] + drag_xy * vsy + turn_ay
    az = k[VELOCITY_P_Z] * ez + s[IZ] + (k[DRAG_Z] + k[DRAG_Q_Z] * abs(vsz)) * vsz
    sat_z = False
    if az > k[MAX_UP_ACCEL]:
        az, sat_z = k[MAX_UP_ACCEL], True
    elif az < -k[MAX_DOWN_ACCEL]:
        az, sat_z = -k[MAX_DOWN_ACCEL], True
    a_max = (az + k[GRAVITY]) * k[TAN_MAX_TILT]  # the tilt limit, as a horizontal acceleration
    ah = math.sqrt(ax * ax + ay * ay)
    sat_xy = ah > a_max
    if sat_xy:
        scale = a_max / ah
        ax, ay = ax * scale, ay * scale
    # anti-windup: integrate only while the output is not saturated and the error is small
    # (a transient's large error would otherwise wind the integrator up and overshoot)
    ilim, band = k[I_LIMIT], k[I_BAND]
    if not sat_xy and -band < ex < band and -band < ey < band:
        s[IX] = _clamp(s[IX] + k[VELOCITY_I_XY] * ex * dt_s, -ilim, ilim)
        s[IY] = _clamp(s[IY] + k[VELOCITY_I_XY] * ey * dt_s, -ilim, ilim)
    if not sat_z and -band < ez < band:
        s[IZ] = _clamp(s[IZ] + k[VELOCITY_I_Z] * ez * dt_s, -ilim, ilim)
    return ax, ay, az


@jit
def _attitude_loop(k: Floats, ax: float, ay: float, az: float, r: Mat3, pz: float) -> tuple[float, float, float]:
    """The wanted acceleration as collective thrust along the current body z (less near the
    ground by the ground-effect ratio) and the roll and pitch rates that tilt the body z
    toward it."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = r
    m = k[MASS]
    fx, fy, fz = m * ax, m * ay, m * (az + k[GRAVITY])
    thrust = fx * r02 + fy * r12 + fz * r22
    if thrust < 0.0:
        thrust = 0.0
    if k[GROUND_EFFECT] != 0.0:
        thrust /= ground_effect_ratio(
            pz + r20 * k[HUB_X] + r21 * k[HUB_Y] + r22 * k[HUB_Z], k[ROTOR_RADIUS], k[GROUND_EFFECT_MAX]
        )
    norm = math.sqrt(fx * fx + fy * fy + fz * fz)
    bx, by, bz = fx / norm, fy / norm, fz / norm
    # wanted body z expressed in the body frame; tilt error about e3 x d
    dx = r00 * bx + r10 * by + r20 * bz
    dy = r01 * bx + r11 * by + r21 * bz
    dz = r02 * bx + r12 * by + r22 * bz
    sin_t = math.sqrt(dx * dx + dy * dy)
    k_att = k[ATTITUDE_P] * (math.atan2(sin_t, dz) / sin_t if sin_t > 1e-9 else 1.0)
    mr = k[MAX_RATE_RP]
    return thrust, _clamp(-k_att * dy, -mr, mr), _clamp(k_att * dx, -mr, mr)


@jit
def _rate_loop(
    k: Floats, ps: float, qs: float, hs: float, r20: float, r21: float, r22: float, wp: float, wq: float, wr: float
) -> tuple[float, float, float]:
    """The body yaw rate that gives the wanted heading rate in a bank, then the rate loop ->
    body torques (with the gyroscopic term)."""
    mr, my = k[MAX_RATE_RP], k[MAX_YAW_RATE]
    # the heading rate is the body rates' world-z component (r20 p + r21 q + r22 r): in a bank,
    # the body z rate that gives the wanted heading rate, with the roll/pitch rates wanted
    hs = _clamp(hs, -my, my)
    rs = _clamp((hs - r20 * ps - r21 * qs) / max(r22, 0.5), -mr, mr)
    ap = k[RATE_P_RP] * (ps - wp)
    aq = k[RATE_P_RP] * (qs - wq)
    ar = k[RATE_P_YAW] * (rs - wr)
    jxx, jyy, jzz = k[JXX], k[JYY], k[JZZ]
    tx = jxx * ap + (jzz - jyy) * wq * wr
    ty = jyy * aq + (jxx - jzz) * wp * wr
    tz = jzz * ar + (jyy - jxx) * wp * wq
    return tx, ty, tz
