"""A vehicle's state at base_link's origin, from that of its base as PyBullet keeps it (the
inertial frame, at the centre of mass), in one compiled call: what the wrench of the next step
and the state the loop publishes need, every step.

The arithmetic is the one the simulator has always used (quadsim.core.kinematics's rotation
matrix, then the offset and the velocity of the origin, the body rates and the specific force),
operation for operation, so states are the same to the bit as before it was compiled.
"""

from __future__ import annotations

from quadsim.core.compiled import jit
from quadsim.core.kinematics import Mat3, Quat, Vec3


@jit
def base_link_state(
    x: float,
    y: float,
    z: float,
    qx: float,
    qy: float,
    qz: float,
    qw: float,
    vx: float,
    vy: float,
    vz: float,
    wx: float,
    wy: float,
    wz: float,
    ox: float,
    oy: float,
    oz: float,
    ux: float,
    uy: float,
    uz: float,
    at_rest_before: bool,
    gravity_mps2: float,
    inv_dt: float,
) -> tuple[Vec3, Quat, Vec3, Vec3, Mat3, Vec3, Vec3]:
    """From the base's position, orientation (x y z w), velocity and spin (world frame) and
    base_link's origin's offset (ox, oy, oz) from it in body axes: base_link's position, the
    orientation, its velocity, the spin, the rotation matrix (world <- body, rows first), the body
    rates and the specific force (body frame) over the step from velocity (ux, uy, uz), or from
    rest relative to it (`at_rest_before`: the velocity did not change)."""
    xx, yy, zz = qx * qx, qy * qy, qz * qz
    xy, xz, yz, wxq, wyq, wzq = qx * qy, qx * qz, qy * qz, qw * qx, qw * qy, qw * qz
    m00, m01, m02 = 1.0 - 2.0 * (yy + zz), 2.0 * (xy - wzq), 2.0 * (xz + wyq)
    m10, m11, m12 = 2.0 * (xy + wzq), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wxq)
    m20, m21, m22 = 2.0 * (xz - wyq), 2.0 * (yz + wxq), 1.0 - 2.0 * (xx + yy)
    dx, dy, dz = m00 * ox + m01 * oy + m02 * oz, m10 * ox + m11 * oy + m12 * oz, m20 * ox + m21 * oy + m22 * oz
    px, py, pz = x - dx, y - dy, z - dz
    # the origin moves with the inertial frame's velocity, less the turn about it: w x d
    lx, ly, lz = vx - (wy * dz - wz * dy), vy - (wz * dx - wx * dz), vz - (wx * dy - wy * dx)
    if at_rest_before:
        ux, uy, uz = lx, ly, lz
    # specific force: (dv/dt - gravity) in world, then into base_link
    fx, fy, fz = (lx - ux) * inv_dt, (ly - uy) * inv_dt, (lz - uz) * inv_dt + gravity_mps2
    return (
        (px, py, pz),
        (qx, qy, qz, qw),
        (lx, ly, lz),
        (wx, wy, wz),
        ((m00, m01, m02), (m10, m11, m12), (m20, m21, m22)),
        (m00 * wx + m10 * wy + m20 * wz, m01 * wx + m11 * wy + m21 * wz, m02 * wx + m12 * wy + m22 * wz),
        (m00 * fx + m10 * fy + m20 * fz, m01 * fx + m11 * fy + m21 * fz, m02 * fx + m12 * fy + m22 * fz),
    )
