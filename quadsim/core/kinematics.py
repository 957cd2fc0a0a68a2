"""Small math in plain floats: rotations (matrices, quaternions), frame changes, clamping.

The controllers' and physics' hot paths avoid numpy: for 3-vectors and 3x3 matrices, tuples of
floats are several times faster. Quaternions are (x, y, z, w), as ROS and PyBullet order them;
a rotation matrix is a tuple of rows and maps vectors of the child frame into the parent frame.
"""

from __future__ import annotations

import math

Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]
Quat = tuple[float, float, float, float]

IDENTITY: Mat3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def clamp(value: float, low: float, high: float) -> float:
    """`value` limited to [low, high] (low <= high)."""
    return low if value < low else (high if value > high else value)


#: the last quaternion turned into a matrix, and its matrix: the physics turns each step's
#: attitude into a matrix, then the controller turns the same tuple again (a tuple cannot change)
_last: tuple[Quat | None, Mat3] = (None, IDENTITY)


def yaw_of(q: Quat) -> float:
    """The heading of a world <- body quaternion (x, y, z, w): rotation about world z,
    counter-clockwise from world x, in (-pi, pi]."""
    x, y, z, w = q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def matrix_from_quaternion(q: Quat) -> Mat3:
    """The rotation matrix of a unit quaternion (x, y, z, w), rows first: world <- body."""
    global _last
    last = _last
    if q is last[0]:
        return last[1]
    x, y, z, w = q
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    m = (
        (1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy)),
        (2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx)),
        (2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy)),
    )
    if type(q) is tuple:  # a list could change under the same identity
        _last = (q, m)
    return m


def known_matrix(q: Quat, m: Mat3) -> None:
    """Tell `matrix_from_quaternion` that `m` is the matrix of the tuple `q` (the physics, which
    computed both in its compiled step, so that the controller's call for the same tuple finds it)."""
    global _last
    _last = (q, m)


def quaternion_from_matrix(m: Mat3) -> Quat:
    """(x, y, z, w) of a rotation matrix (Shepperd's method, numerically safe)."""
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr > 0:
        s = (tr + 1.0) ** 0.5 * 2
        return ((m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s)
    if m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = (1.0 + m[0][0] - m[1][1] - m[2][2]) ** 0.5 * 2
        return (0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s)
    if m[1][1] > m[2][2]:
        s = (1.0 + m[1][1] - m[0][0] - m[2][2]) ** 0.5 * 2
        return ((m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s)
    s = (1.0 + m[2][2] - m[0][0] - m[1][1]) ** 0.5 * 2
    return ((m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s)


def matrix_from_rpy(roll: float, pitch: float, yaw: float) -> Mat3:
    """URDF's fixed-axis roll, pitch, yaw (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    return (
        (cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr),
        (sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr),
        (-sp, cp * sr, cp * cr),
    )


def mat_mul(a: Mat3, b: Mat3) -> Mat3:
    """The product a b."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = b
    return (
        (a00 * b00 + a01 * b10 + a02 * b20, a00 * b01 + a01 * b11 + a02 * b21, a00 * b02 + a01 * b12 + a02 * b22),
        (a10 * b00 + a11 * b10 + a12 * b20, a10 * b01 + a11 * b11 + a12 * b21, a10 * b02 + a11 * b12 + a12 * b22),
        (a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21, a20 * b02 + a21 * b12 + a22 * b22),
    )


def transpose(a: Mat3) -> Mat3:
    """The transpose (for a rotation, its inverse)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    return ((a00, a10, a20), (a01, a11, a21), (a02, a12, a22))


def rotate(a: Mat3, v: Vec3) -> Vec3:
    """a v: a vector of the child frame expressed in the parent frame."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    x, y, z = v
    return (a00 * x + a01 * y + a02 * z, a10 * x + a11 * y + a12 * z, a20 * x + a21 * y + a22 * z)


def rotate_back(a: Mat3, v: Vec3) -> Vec3:
    """a^T v: a vector of the parent frame expressed in the child frame."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    x, y, z = v
    return (a00 * x + a10 * y + a20 * z, a01 * x + a11 * y + a21 * z, a02 * x + a12 * y + a22 * z)


def body_velocity(orientation_xyzw: Quat, velocity_world: Vec3) -> Vec3:
    """A world-frame velocity expressed in the body frame of the given orientation."""
    return rotate_back(matrix_from_quaternion(orientation_xyzw), velocity_world)
