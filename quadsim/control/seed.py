"""A port of the original V-REP quadricopter Twist controller (its Lua child script).

The structure, gains and mixer pattern are the original's:
    altitude PID around the hover command 5.335 with a vertical-velocity term;
    velocity errors in the heading frame fed into PD corrections of the body's two tilt angles;
    a yaw-rate loop; and m1 = T(1-a+b+r), m2 = T(1-a-b-r), m3 = T(1+a-b+r), m4 = T(1+a+b-r).

Mapping to an explicit time step. The original ran once per V-REP step, DT_REF = 50 ms (V-REP's
default), and its difference terms are only right at that step. Here, at any control step dt:
    cumul = cumul + e                 ->  cumul += e * dt / DT_REF        (same integral)
    k * (x - x_prev)                  ->  k * (x - x_prev) * DT_REF / dt  (same derivative)
so the loop has the same gains in continuous time and stays stable at 240 Hz.

Units. The original's outputs are propeller commands of the V-REP model, whose hover value is
5.335. They are mapped linearly to newtons, 5.335 -> this vehicle's hover thrust per rotor,
so every gain keeps its meaning as a fraction of hover thrust.

Rotor numbering (from the signs of the mixer): 1 front-left CCW, 2 rear-left CW, 3 rear-right CCW,
4 front-right CW; the vehicle must have that layout (checked at construction).

Angles. The original reads the body's Euler angles relative to a frame that follows only its
heading, with V-REP's X-Y-Z convention (R = Rx(alpha) Ry(beta) Rz(gamma)); the heading is the
gamma of the body's own X-Y-Z angles. Both are computed the same way here.

z-modes. In `height` mode linear.z is, as in the original, an offset above 2 m. In `velocity`
mode (the original had none) the height reference sits linear.z x (-vParam / pParam) = 1 s away
from the current altitude, so the altitude PID's P and vertical-velocity terms make a climb-rate
loop with the original's gains (thrust change 2 x (wanted - actual climb rate)), its integral
paused; released, the altitude reached is held. Altitude limits and landing are the landing layer's (control/landing.py).
When the dead-man holds, the velocity and yaw-rate references are zero and the height stands.

Heading rate. angular.z is compared with the original's vel_ang[3], the world-frame z component
of the angular velocity (V-REP's simGetObjectVelocity), which is the heading rate: the port
keeps that, so in a banked turn the heading turns at the rate asked (no change was needed).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from quadsim.control import ControllerKind
from quadsim.control.gains import load_gains
from quadsim.core.kinematics import clamp, matrix_from_quaternion
from quadsim.core.types import HEIGHT_MODE_BASE_M, ActiveCommand, RotorForces, VehicleState, ZMode
from quadsim.errors import ConfigError
from quadsim.vehicle.params import Spin, VehicleParams

DT_REF_S = 0.05  # the V-REP simulation step the original's difference terms assumed
HOVER_COMMAND = 5.335  # the original's hover propeller command
#: how fast the original quad (quadsim_x) turns per unit of its rotors' hover thrust moved from
#: one side to the other (rad/s^2): roll (hover thrust x arm / Ixx) and yaw (hover thrust x k_m/k_f
#: / Izz). The original's constants are gains on commands, not on the physics: they fly a
#: vehicle that turns within SEED_RESPONSE_RANGE of these, and none other
SEED_ROLL_RESPONSE = 34.08
SEED_YAW_RESPONSE = 2.49
SEED_RESPONSE_RANGE = 2.0

_IDLE: RotorForces = (0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class SeedGains:
    """The original script's constants, unchanged: the [seed] table of the airframe's NAME.gains.toml."""

    p: float
    i: float
    d: float
    v: float
    attitude_p: float
    attitude_d: float
    velocity_p: float
    velocity_d: float
    yaw_p: float
    yaw_d: float


def _check_layout(vehicle: VehicleParams) -> None:
    expected = ((1, 1, Spin.CCW), (-1, 1, Spin.CW), (-1, -1, Spin.CCW), (1, -1, Spin.CW))
    if len(vehicle.rotors) != len(expected):
        raise ConfigError(
            f"{vehicle.urdf_path.name}: the seed controller flies only the original quadrotor layout "
            f"(4 rotors: 1 front-left ccw, 2 rear-left cw, 3 rear-right ccw, 4 front-right cw); "
            f"this vehicle has {len(vehicle.rotors)} rotors: use the cascade controller"
        )
    for rotor, (sx, sy, spin) in zip(vehicle.rotors, expected):
        x, y, _ = rotor.position_m
        if x * sx <= 0 or y * sy <= 0 or rotor.spin is not spin:
            raise ConfigError(
                f"{vehicle.params_path}: the seed controller needs the original rotor layout "
                f"(1 front-left ccw, 2 rear-left cw, 3 rear-right ccw, 4 front-right cw); "
                f"{rotor.link_name} is at x={x:.3f}, y={y:.3f}, {rotor.spin.value}"
            )


def seed_responses(vehicle: VehicleParams) -> tuple[float, float]:
    """The vehicle's roll and yaw response to its hover thrust (as SEED_ROLL_RESPONSE)."""
    hover = vehicle.hover_thrust_per_rotor_n
    arm = min(abs(r.position_m[1]) for r in vehicle.rotors)
    return (
        hover * arm / vehicle.inertia_kgm2[0][0],
        hover * vehicle.yaw_torque_per_thrust_m / vehicle.inertia_kgm2[2][2],
    )


def _check_response(vehicle: VehicleParams) -> None:
    roll, yaw = seed_responses(vehicle)
    off = [
        f"{name} {value / reference:.2g}x"
        for name, value, reference in (("roll", roll, SEED_ROLL_RESPONSE), ("yaw", yaw, SEED_YAW_RESPONSE))
        if not 1.0 / SEED_RESPONSE_RANGE <= value / reference <= SEED_RESPONSE_RANGE
    ]
    if off:
        raise ConfigError(
            f"{vehicle.urdf_path.name}: the seed controller's constants (the original script's, "
            f"unchanged) fly only a vehicle that turns about as the original quad does; this one turns "
            f"{' and '.join(off)} as fast for its hover thrust: use the cascade controller"
        )


class SeedController:
    kind = ControllerKind.SEED

    def __init__(self, vehicle: VehicleParams, gains: SeedGains | None = None) -> None:
        _check_layout(vehicle)
        _check_response(vehicle)
        if gains is None:
            gains = load_gains(vehicle, ControllerKind.SEED.value, SeedGains)
        self.vehicle = vehicle
        self.gains = gains
        self._newton_per_command = vehicle.hover_thrust_per_rotor_n / HOVER_COMMAND
        self._climb_lead_s = -gains.v / gains.p
        self._max = vehicle.max_thrust_n
        self.reset()

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.kind.value,
            "gains": asdict(self.gains),
            "dt_ref_s": DT_REF_S,
            "hover_command": HOVER_COMMAND,
            "newton_per_command": self._newton_per_command,
        }

    def reset(self) -> None:
        self._armed = False
        self._height: float | None = None
        self._climbing = False
        self._cumul = 0.0
        self._last_e = 0.0
        self._p_alpha = self._p_beta = 0.0
        self._old_vx = self._old_vy = 0.0
        self._old_wz = 0.0

    def update(self, state: VehicleState, command: ActiveCommand, dt_s: float) -> RotorForces:
        """Rotor forces for this control step.

        It is one piece on purpose: it follows the original Lua child script line for line, in
        its order (altitude, tilt corrections, yaw, mixer), so that it reads against the original
        and a difference from it is easy to see."""
        if not command.armed:
            self._armed = False
            return _IDLE
        gn = self.gains
        px, py, pz = state.position_m
        vx, vy, vz = state.linear_velocity_mps
        bp, bq, br = state.angular_velocity_body_rps
        if not self._armed:
            self.reset()
            self._armed = True
            self._height = pz
        k = DT_REF_S / dt_s  # differences per control step -> per original step

        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = matrix_from_quaternion(state.orientation_xyzw)

        # heading: gamma of the body's X-Y-Z Euler angles; velocities in the heading frame
        gamma = math.atan2(-r01, r00)
        cg, sg = math.cos(gamma), math.sin(gamma)
        vel_local_x = cg * vx + sg * vy
        vel_local_y = -sg * vx + cg * vy
        vel_local_z = vz
        # attitude relative to the heading frame: M = Rz(gamma)^T R, X-Y-Z angles of M
        m02 = cg * r02 + sg * r12
        m12 = -sg * r02 + cg * r12
        m22 = r22
        alpha = math.atan2(-m12, m22)
        beta = math.asin(clamp(m02, -1.0, 1.0))
        wz_world = r20 * bp + r21 * bq + r22 * br  # V-REP's vel_ang[3] is in the world frame

        tw = command.twist
        if command.hold:
            ref_vx = ref_vy = ref_wz = ref_vz = 0.0
        else:
            ref_vx, ref_vy, ref_wz, ref_vz = tw.linear_x, tw.linear_y, tw.angular_z, tw.linear_z
            if command.z_mode is ZMode.HEIGHT:
                self._height = HEIGHT_MODE_BASE_M + ref_vz
        if command.z_mode is ZMode.VELOCITY:
            if ref_vz:  # a climb-rate loop (see the module docstring)
                self._height = pz + ref_vz * self._climb_lead_s
                self._climbing = True
            elif self._climbing:  # stopped: hold the altitude reached
                self._height = pz
                self._climbing = False
        height = self._height

        # vertical control
        e = height - pz  # type: ignore[operator]
        if not self._climbing:  # a climb's lead is no altitude error to integrate
            self._cumul += e / k
        thrust = HOVER_COMMAND + gn.p * e + gn.i * self._cumul + gn.d * (e - self._last_e) * k + vel_local_z * gn.v
        self._last_e = e

        # horizontal control
        vel_error_x = ref_vx - vel_local_x
        vel_error_y = ref_vy - vel_local_y
        alpha_e = alpha
        alpha_corr = gn.attitude_p * alpha_e + gn.attitude_d * (alpha_e - self._p_alpha) * k
        beta_e = -beta
        beta_corr = -gn.attitude_p * beta_e - gn.attitude_d * (beta_e - self._p_beta) * k
        self._p_alpha, self._p_beta = alpha_e, beta_e
        alpha_corr += vel_error_y * gn.velocity_p + (vel_local_y - self._old_vy) * gn.velocity_d * k
        beta_corr -= vel_error_x * gn.velocity_p + (vel_local_x - self._old_vx) * gn.velocity_d * k
        self._old_vx, self._old_vy = vel_local_x, vel_local_y

        # rotational (yaw-rate) control
        rot_corr = -(ref_wz - wz_world) * gn.yaw_p - (wz_world - self._old_wz) * gn.yaw_d * k
        self._old_wz = wz_world

        scale, top = self._newton_per_command, self._max
        m1 = thrust * (1.0 - alpha_corr + beta_corr + rot_corr) * scale
        m2 = thrust * (1.0 - alpha_corr - beta_corr - rot_corr) * scale
        m3 = thrust * (1.0 + alpha_corr - beta_corr + rot_corr) * scale
        m4 = thrust * (1.0 + alpha_corr + beta_corr - rot_corr) * scale
        return (clamp(m1, 0.0, top), clamp(m2, 0.0, top), clamp(m3, 0.0, top), clamp(m4, 0.0, top))
