"""One physics step of a body that touches nothing, as PyBullet steps it: quadsim's own compiled
copy of the floating-base step of Bullet's btMultiBody, for a vehicle clear of all geometry.

What PyBullet 3.2.x does in `stepSimulation` for a multibody with no links and no contacts
(bullet3 src/BulletDynamics/Featherstone: btMultiBodyDynamicsWorld, btMultiBody), in order:
  1. the external force F (applied at a point p: it adds the torque (p - c) x F about the centre
     of mass c) and torque T, world frame, and gravity's m g on the base;
  2. the accelerations, in the body frame B (R: world <- body): the angular one
     I^-1 (R^T T - w_B x I w_B), the linear one (R^T F) / m less w_B x v_B, turned back to the
     world with the linear one's w_B x v_B added back; the damping terms are zero (quadsim sets
     linear and angular damping to 0);
  3. velocities first: v += h a, w += h alpha, each component clamped to +-100 (the body's
     maximum coordinate velocity);
  4. then the pose with the new velocities: c += h v; the orientation by the exponential map
     of h w, its angle limited to pi/4 a step, with Taylor's expansion of sin(x)/x below
     0.001 rad/s, then normalised.
The arithmetic follows Bullet's order, so a flight agrees with PyBullet's to about 1e-12 m
(docs/reference/determinism.md has the figures); it is not the same to the bit, and need not be: a
run flies one way or the other from its first step (quadsim.physics.pybullet_world).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from quadsim.core.compiled import Floats, MutableFloats, jit
from quadsim.physics.base_link import base_link_state
from quadsim.vehicle.wrench import airframe_wrench

#: where each quantity is in a body's state (PyBullet's base: its inertial frame, world frame)
POSITION, ORIENTATION, VELOCITY, SPIN = 0, 3, 7, 10
#: how long a body's state is
STATE_SIZE = 13
#: btMultiBody's default maximum coordinate velocity (m/s and rad/s, per component)
MAX_COORDINATE_VELOCITY = 100.0
#: Bullet's ANGULAR_MOTION_THRESHOLD: the most a body turns in one step (rad)
_ANGULAR_MOTION_THRESHOLD = 0.25 * math.pi


@jit
def _clamp(value: float) -> float:
    if value > MAX_COORDINATE_VELOCITY:
        return MAX_COORDINATE_VELOCITY
    if value < -MAX_COORDINATE_VELOCITY:
        return -MAX_COORDINATE_VELOCITY
    return value


@jit
def free_flight_step(
    body: MutableFloats,
    wrench: Floats,
    at: tuple[float, float, float],
    mass_kg: float,
    inertia: Floats,
    gravity_mps2: float,
    step_s: float,
) -> None:
    """Advance `body` (POSITION, ORIENTATION as x y z w, VELOCITY and SPIN, world frame, of the
    inertial frame) by one step of `step_s` under `wrench` (fx, fy, fz, tx, ty, tz, world frame;
    the force acting at the point `at`) and gravity, in place. `inertia`: the principal moments
    about the inertial frame's axes. One piece, as Bullet's step is: the same operations in the
    same order from the state to the state, so that what it leaves can be checked against
    PyBullet's term for term (tests/integration/test_free_flight.py)."""
    px, py, pz = body[0], body[1], body[2]
    qx, qy, qz, qw = body[3], body[4], body[5], body[6]
    vx, vy, vz = body[7], body[8], body[9]
    wx, wy, wz = body[10], body[11], body[12]
    fx, fy, fz = wrench[0], wrench[1], wrench[2]
    # the force at `at` adds its moment about the centre of mass (applyExternalForce)
    rx, ry, rz = at[0] - px, at[1] - py, at[2] - pz
    tx = wrench[3] + (ry * fz - rz * fy)
    ty = wrench[4] + (rz * fx - rx * fz)
    tz = wrench[5] + (rx * fy - ry * fx)
    # gravity on the base (applyGravity)
    fz = fz + mass_kg * -gravity_mps2
    # R (world <- body) from the orientation; Bullet keeps its inverse and builds R^T from it
    xx, yy, zz = qx * qx, qy * qy, qz * qz
    s = 2.0 / (xx + yy + zz + qw * qw)
    xs, ys, zs = qx * s, qy * s, qz * s
    wxs, wys, wzs = qw * xs, qw * ys, qw * zs
    xxs, xys, xzs = qx * xs, qx * ys, qx * zs
    yys, yzs, zzs = qy * ys, qy * zs, qz * zs
    m00, m01, m02 = 1.0 - (yys + zzs), xys - wzs, xzs + wys
    m10, m11, m12 = xys + wzs, 1.0 - (xxs + zzs), yzs - wxs
    m20, m21, m22 = xzs - wys, yzs + wxs, 1.0 - (xxs + yys)
    # into the body frame: R^T
    bwx, bwy, bwz = m00 * wx + m10 * wy + m20 * wz, m01 * wx + m11 * wy + m21 * wz, m02 * wx + m12 * wy + m22 * wz
    bvx, bvy, bvz = m00 * vx + m10 * vy + m20 * vz, m01 * vx + m11 * vy + m21 * vz, m02 * vx + m12 * vy + m22 * vz
    btx, bty, btz = m00 * tx + m10 * ty + m20 * tz, m01 * tx + m11 * ty + m21 * tz, m02 * tx + m12 * ty + m22 * tz
    bfx, bfy, bfz = m00 * fx + m10 * fy + m20 * fz, m01 * fx + m11 * fy + m21 * fz, m02 * fx + m12 * fy + m22 * fz
    ix, iy, iz = inertia[0], inertia[1], inertia[2]
    lx, ly, lz = ix * bwx, iy * bwy, iz * bwz
    # the zero-acceleration force (Featherstone's z^A): minus the applied, plus the velocity terms
    zax = -btx + (bwy * lz - bwz * ly)
    zay = -bty + (bwz * lx - bwx * lz)
    zaz = -btz + (bwx * ly - bwy * lx)
    zlx = -bfx + mass_kg * (bwy * bvz - bwz * bvy)
    zly = -bfy + mass_kg * (bwz * bvx - bwx * bvz)
    zlz = -bfz + mass_kg * (bwx * bvy - bwy * bvx)
    aax, aay, aaz = -(zax / ix), -(zay / iy), -(zaz / iz)
    alx, aly, alz = -(zlx / mass_kg), -(zly / mass_kg), -(zlz / mass_kg)
    alx += bwy * bvz - bwz * bvy
    aly += bwz * bvx - bwx * bvz
    alz += bwx * bvy - bwy * bvx
    # back to the world (R), then velocities first
    wx = _clamp(wx + (m00 * aax + m01 * aay + m02 * aaz) * step_s)
    wy = _clamp(wy + (m10 * aax + m11 * aay + m12 * aaz) * step_s)
    wz = _clamp(wz + (m20 * aax + m21 * aay + m22 * aaz) * step_s)
    vx = _clamp(vx + (m00 * alx + m01 * aly + m02 * alz) * step_s)
    vy = _clamp(vy + (m10 * alx + m11 * aly + m12 * alz) * step_s)
    vz = _clamp(vz + (m20 * alx + m21 * aly + m22 * alz) * step_s)
    body[7], body[8], body[9] = vx, vy, vz
    body[10], body[11], body[12] = wx, wy, wz
    body[0], body[1], body[2] = px + step_s * vx, py + step_s * vy, pz + step_s * vz
    # the orientation: Bullet's exponential map on its inverse, m' = m (-axis, cos), m = conj(q)
    angle = math.sqrt(wx * wx + wy * wy + wz * wz)
    if angle * step_s > _ANGULAR_MOTION_THRESHOLD:
        angle = 0.5 * (0.5 * math.pi) / step_s
    if angle < 0.001:
        k = 0.5 * step_s - (step_s * step_s * step_s) * 0.020833333333 * angle * angle
    else:
        k = math.sin(0.5 * angle * step_s) / angle
    ax, ay, az, aw = -(wx * k), -(wy * k), -(wz * k), math.cos(angle * step_s * 0.5)
    mx, my, mz, mw = -qx, -qy, -qz, qw
    nx = mw * ax + mx * aw + my * az - mz * ay
    ny = mw * ay + my * aw + mz * ax - mx * az
    nz = mw * az + mz * aw + mx * ay - my * ax
    nw = mw * aw - mx * ax - my * ay - mz * az
    norm = math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
    body[3], body[4], body[5], body[6] = -(nx / norm), -(ny / norm), -(nz / norm), nw / norm


#: what `clear_step` takes first, the same every step: the airframe's constants, the hubs, the
#: motors' thrusts, the wrench's output, the body's state, mass, inertia, gravity, the step, its
#: inverse and base_link's offset from the inertial frame (PhysicsWorld._clear_constants)
ClearConstants = tuple[
    Floats, Sequence[Floats], MutableFloats, MutableFloats, MutableFloats, float, Floats, float, float, float,
    tuple[float, float, float],
]  # fmt: skip


@jit
def clear_step(
    c: Floats,
    hubs: Sequence[Floats],
    thrusts: MutableFloats,
    wrench: MutableFloats,
    body: MutableFloats,
    mass_kg: float,
    inertia: Floats,
    gravity_mps2: float,
    step_s: float,
    inv_dt: float,
    offset: tuple[float, float, float],
    command: Floats,
    rotation: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]],
    air: tuple[float, float, float],
    spin: tuple[float, float, float],
    at: tuple[float, float, float],
    previous: tuple[float, float, float],
) -> tuple[Any, ...]:
    """A whole step of a vehicle clear of everything in one compiled call: the motors and the
    wrench (quadsim.vehicle.wrench.airframe_wrench), quadsim's step of the body
    (`free_flight_step`), and base_link's state after it from base_link's position `at` and
    velocity `previous` before it (quadsim.physics.base_link.base_link_state, what it returns).
    The vehicle's constants come first, the same every step."""
    airframe_wrench(c, hubs, thrusts, command, rotation, at[2], air, spin, wrench)
    free_flight_step(body, wrench, at, mass_kg, inertia, gravity_mps2, step_s)
    ox, oy, oz = offset
    ux, uy, uz = previous
    return base_link_state(
        body[0], body[1], body[2], body[3], body[4], body[5], body[6], body[7], body[8], body[9], body[10],
        body[11], body[12], ox, oy, oz, ux, uy, uz, False, gravity_mps2, inv_dt,
    )  # fmt: skip
