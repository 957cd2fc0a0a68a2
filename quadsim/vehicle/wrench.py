"""What acts on the airframe in one physics step, as one force and one torque: the motors move
toward the commanded forces, each rotor pushes along body z at its hub (times its ground-effect
ratio) with its yaw reaction torque, body and rotor drag (in the rotor plane and along the rotor
axis) act at the centre of mass; and the torque that has PyBullet step the body's rotation
exactly instead of by its explicit gyroscopic term (quadsim.core.rigid_body). One function of
floats and arrays, compiled where numba is installed (quadsim.core.compiled).

quadsim.physics.pybullet_world applies the result to the body each step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from quadsim.core.compiled import Floats, MutableFloats, jit
from quadsim.core.rigid_body import add_gyroscopic_correction
from quadsim.vehicle.aero import drag_body, ground_effect_ratio
from quadsim.vehicle.motors import advance_motors
from quadsim.vehicle.params import VehicleParams

#: the constants `airframe_wrench` reads from `c`, in order
C_FIELDS = (
    "motor_alpha",
    "max_thrust_n",
    "inverse_thrust_coefficient",
    "ground_effect",
    "rotor_radius_m",
    "ground_effect_max_ratio",
    "body_drag_linear_x",
    "body_drag_linear_y",
    "body_drag_linear_z",
    "body_drag_quadratic_x",
    "body_drag_quadratic_y",
    "body_drag_quadratic_z",
    "rotor_drag_ns_per_m_rad",
    "rotor_axial_drag_ns_per_m_rad",
    "com_x_m",
    "com_y_m",
    "com_z_m",
    "exact_rotation",
    "inertia_x_kgm2",
    "inertia_y_kgm2",
    "inertia_z_kgm2",
    "step_s",
)
# where each of those is in `c` (constants in the compiled code)
(
    MOTOR_ALPHA,
    MAX_THRUST,
    INVERSE_KF,
    GROUND_EFFECT,
    ROTOR_RADIUS,
    GROUND_EFFECT_MAX,
    LINEAR_X,
    LINEAR_Y,
    LINEAR_Z,
    QUADRATIC_X,
    QUADRATIC_Y,
    QUADRATIC_Z,
    ROTOR_DRAG,
    ROTOR_AXIAL_DRAG,
    COM_X,
    COM_Y,
    COM_Z,
    EXACT_ROTATION,
    INERTIA_X,
    INERTIA_Y,
    INERTIA_Z,
    STEP,
) = range(len(C_FIELDS))


def airframe_constants(
    vehicle: VehicleParams, motor_alpha: float, step_s: float, exact_rotation: bool = True
) -> list[float]:
    """What `airframe_wrench` reads from `c`, in the order of C_FIELDS; `motor_alpha`: the
    motors' step response (quadsim.vehicle.motors.MotorBank.alpha); `step_s`: the physics step;
    `exact_rotation`: the body is one rigid body with the URDF's principal inertia (the merged
    flight body), whose rotation the wrench has PyBullet step exactly; else PyBullet's own
    gyroscopic term stands."""
    aero, inertia = vehicle.aero, vehicle.inertia_kgm2
    values = {
        "motor_alpha": motor_alpha,
        "max_thrust_n": vehicle.max_thrust_n,
        "inverse_thrust_coefficient": 1.0 / vehicle.thrust_coefficient_n_per_rad2s2,
        "ground_effect": 1.0 if aero.ground_effect else 0.0,
        "rotor_radius_m": aero.rotor_radius_m,
        "ground_effect_max_ratio": aero.ground_effect_max_ratio,
        **dict(zip(C_FIELDS[LINEAR_X : LINEAR_Z + 1], aero.body_drag_linear_ns_per_m)),
        **dict(zip(C_FIELDS[QUADRATIC_X : QUADRATIC_Z + 1], aero.body_drag_quadratic_ns2_per_m2)),
        "rotor_drag_ns_per_m_rad": aero.rotor_drag_ns_per_m_rad,
        "rotor_axial_drag_ns_per_m_rad": aero.rotor_axial_drag_ns_per_m_rad,
        **dict(zip(C_FIELDS[COM_X : COM_Z + 1], vehicle.com_m)),
        "exact_rotation": 1.0 if exact_rotation else 0.0,
        # the principal moments, as the merged body has them (physics.scene.load_vehicle_body)
        **dict(zip(C_FIELDS[INERTIA_X : INERTIA_Z + 1], (inertia[0][0], inertia[1][1], inertia[2][2]))),
        "step_s": step_s,
    }
    return [values[name] for name in C_FIELDS]


def hub_table(vehicle: VehicleParams) -> list[tuple[float, float, float, float]]:
    """Per rotor: its hub relative to base_link's origin (for its height above the floor) and its
    reaction torque per newton about body z (a CCW rotor turns the body the other way)."""
    c = vehicle.yaw_torque_per_thrust_m
    return [(*hub, -r.spin.sign * c) for hub, r in zip(vehicle.rotor_hubs_m, vehicle.rotors)]


@jit
def airframe_wrench(
    c: Floats,
    hubs: Sequence[Floats],
    thrusts: MutableFloats,
    command: Floats,
    rotation: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]],
    pz: float,
    air: tuple[float, float, float],
    spin: tuple[float, float, float],
    out: MutableFloats,
) -> None:
    """Advance the motors' `thrusts` (in place) toward `command`, then write the step's force
    and torque, world frame, about base_link's origin, into `out` (fx, fy, fz, tx, ty, tz).
    `hubs`: per rotor (x, y, z of its hub from base_link's origin, yaw torque per newton);
    `rotation`: world <- body; `pz`: base_link's height; `air`: the airspeed, world frame;
    `spin`: the body's rates, world frame."""
    advance_motors(thrusts, command, c[MOTOR_ALPHA], c[MAX_THRUST])
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = rotation
    inv_kf, ground = c[INVERSE_KF], c[GROUND_EFFECT] != 0.0
    yaw = thrust_sum = roll = pitch = omega_sum = 0.0
    for i in range(len(thrusts)):
        thrust = thrusts[i]
        hub = hubs[i]
        hx, hy = hub[0], hub[1]
        yaw += hub[3] * thrust
        if thrust > 0.0:
            omega_sum += math.sqrt(thrust * inv_kf)
            if ground:
                thrust *= ground_effect_ratio(
                    pz + m20 * hx + m21 * hy + m22 * hub[2], c[ROTOR_RADIUS], c[GROUND_EFFECT_MAX]
                )
            thrust_sum += thrust
            roll += hy * thrust  # hub x (0, 0, thrust)
            pitch -= hx * thrust
    vx, vy, vz = air
    dx, dy, dz = drag_body(
        c[LINEAR_X],
        c[LINEAR_Y],
        c[LINEAR_Z],
        c[QUADRATIC_X],
        c[QUADRATIC_Y],
        c[QUADRATIC_Z],
        c[ROTOR_DRAG] * omega_sum,
        c[ROTOR_AXIAL_DRAG] * omega_sum,
        m00 * vx + m10 * vy + m20 * vz,
        m01 * vx + m11 * vy + m21 * vz,
        m02 * vx + m12 * vy + m22 * vz,
    )
    cx, cy, cz = c[COM_X], c[COM_Y], c[COM_Z]
    fx, fy, fz = dx, dy, dz + thrust_sum
    tx, ty, tz = roll + cy * dz - cz * dy, pitch + cz * dx - cx * dz, yaw + cx * dy - cy * dx
    out[0] = m00 * fx + m01 * fy + m02 * fz
    out[1] = m10 * fx + m11 * fy + m12 * fz
    out[2] = m20 * fx + m21 * fy + m22 * fz
    out[3] = m00 * tx + m01 * ty + m02 * tz
    out[4] = m10 * tx + m11 * ty + m12 * tz
    out[5] = m20 * tx + m21 * ty + m22 * tz
    if c[EXACT_ROTATION] != 0.0:
        add_gyroscopic_correction(c[INERTIA_X], c[INERTIA_Y], c[INERTIA_Z], c[STEP], rotation, spin, out)
