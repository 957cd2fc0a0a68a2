"""Rotation helpers in plain floats (the controllers' and physics' hot paths avoid numpy)."""

from __future__ import annotations

Mat3 = tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]


def matrix_from_quaternion(q: tuple[float, float, float, float]) -> Mat3:
    """The rotation matrix of a unit quaternion (x, y, z, w), rows first: world <- body."""
    x, y, z, w = q
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    return (
        (1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy)),
        (2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx)),
        (2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy)),
    )
