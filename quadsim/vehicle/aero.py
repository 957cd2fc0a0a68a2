"""Aerodynamics of the airframe as pure numbers: body drag, rotor (induced) drag, ground effect.

Physics applies the results every step (quadsim.physics.pybullet_world); nothing here imports
pybullet. Every force acts through the airspeed, the vehicle's velocity relative to the air
(velocity minus wind), and is expressed in base_link, applied at the centre of mass.

- Body drag, per body axis: F = -(c_lin v + c_quad |v| v). The quadratic term is the bluff
  body's 1/2 rho C_d A; the linear one the small skin-friction-like remainder.
- Rotor drag (induced drag, "H-force"): each spinning rotor pushes back against the airspeed
  in its plane in proportion to its speed, F = -k_rd * sum(omega_i) * v_in_plane, omega_i from
  its thrust (T = k_f omega^2). This is what makes a multirotor's drag nearly linear at low speed.
  Along the rotor axis the same holds with its own coefficient, F_z = -k_rz * sum(omega_i) * v_z
  (a climb takes thrust away, a descent gives it back: Foerster 2015 identified both on the
  Crazyflie 2.0).
- Ground effect (Cheeseman & Bennett, 1955): a rotor at height z above the ground gives
  T_ige / T_oge = 1 / (1 - (R / 4z)^2) for the same power; the ratio diverges at z = R/4, so it
  is capped at the parameter file's `ground_effect_max_ratio`.
"""

from __future__ import annotations

import math

from quadsim.core.compiled import jit
from quadsim.core.kinematics import Vec3
from quadsim.vehicle.params import AeroParams


@jit
def ground_effect_ratio(height_m: float, rotor_radius_m: float, max_ratio: float) -> float:
    """Cheeseman-Bennett thrust ratio T_ige / T_oge of a rotor `height_m` above the ground
    (1 far away, capped at `max_ratio` close to it or below it)."""
    if height_m <= 0.0:
        return max_ratio
    k = rotor_radius_m / (4.0 * height_m)
    k2 = k * k
    if k2 >= 1.0:
        return max_ratio
    ratio = 1.0 / (1.0 - k2)
    return ratio if ratio < max_ratio else max_ratio


def drag_force_body_n(params: AeroParams, air_body_mps: Vec3, rotor_speed_sum_radps: float) -> Vec3:
    """Body drag plus rotor drag, N in base_link, for the airspeed `air_body_mps` (vehicle
    velocity minus wind, in base_link) and the rotors' summed speed (rad/s)."""
    vx, vy, vz = air_body_mps
    lx, ly, lz = params.body_drag_linear_ns_per_m
    qx, qy, qz = params.body_drag_quadratic_ns2_per_m2
    rotor = params.rotor_drag_ns_per_m_rad * rotor_speed_sum_radps
    axial = params.rotor_axial_drag_ns_per_m_rad * rotor_speed_sum_radps
    return drag_body(lx, ly, lz, qx, qy, qz, rotor, axial, vx, vy, vz)


@jit
def drag_body(
    lx: float,
    ly: float,
    lz: float,
    qx: float,
    qy: float,
    qz: float,
    rotor: float,
    axial: float,
    vx: float,
    vy: float,
    vz: float,
) -> Vec3:
    """`drag_force_body_n` from its numbers: linear and quadratic body drag per axis, the rotor
    drag coefficients in the rotor plane (`rotor`) and along the rotor axis (`axial`) times the
    rotors' summed speed, the airspeed in base_link."""
    return (
        -(lx + qx * abs(vx) + rotor) * vx,
        -(ly + qy * abs(vy) + rotor) * vy,
        -(lz + qz * abs(vz) + axial) * vz,
    )


def rotor_speed_radps(thrust_n: float, thrust_coefficient_n_per_rad2s2: float) -> float:
    """Rotor speed that gives `thrust_n` (T = k_f omega^2)."""
    return math.sqrt(thrust_n / thrust_coefficient_n_per_rad2s2) if thrust_n > 0.0 else 0.0


def terminal_velocity_mps(params: AeroParams, mass_kg: float, gravity_mps2: float, axis: int = 2) -> float:
    """Speed at which body drag alone (rotors stopped) balances the weight along a body axis:
    the level fall with motors off, for axis 2."""
    lin = params.body_drag_linear_ns_per_m[axis]
    quad = params.body_drag_quadratic_ns2_per_m2[axis]
    weight = mass_kg * gravity_mps2
    if quad <= 0.0:
        return weight / lin if lin > 0.0 else math.inf
    return (-lin + math.sqrt(lin * lin + 4.0 * quad * weight)) / (2.0 * quad)
