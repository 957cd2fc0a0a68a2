"""The torque-free rotation of a rigid body over one physics step, and the torque that makes
PyBullet's step follow it instead of its own explicit gyroscopic term.

PyBullet steps a floating base's body rates with an explicit Euler step of Euler's equations,
w' = w + h I^-1 (tau - w x I w), then turns the body by h w'. The explicit gyroscopic term adds
energy at every step of a rotation about an axis that is not a principal one: at 240 Hz a
Crazyflie tumbling about its body diagonal gained 18 % of its kinetic energy in 10 s at 6 rad/s
and its energy grew 13.7-fold at 20 rad/s (docs/vehicles.md has the figures).

Instead, the body's angular momentum L = I w is stepped by symmetric splitting (McLachlan,
"Explicit Lie-Poisson integration and the Euler equations", Phys. Rev. Lett. 71, 1993; Dullweber,
Leimkuhler and McLachlan, J. Chem. Phys. 107, 1997): the kinetic energy is the sum of the three
terms L_i^2 / 2 I_i, and the flow of each turns L about one body axis; composed x/2, y/2, z,
y/2, x/2, the step is reversible, keeps |L| exactly and the energy within a small bounded error
(2e-5 of it at 20 rad/s, not growing). The world-frame momentum drifts a little, as PyBullet
turns the body by the new rates over the whole step (0.7 % in 10 s at 6 rad/s). Each turn is a Cayley rotation, (1 - t^2, 2t) / (1 + t^2)
for t = angle / 2: only + - * /, so the compiled and the Python arithmetic agree to the bit and
an exact copy of PyBullet's step reproduces it.
"""

from __future__ import annotations

from quadsim.core.compiled import MutableFloats, jit


@jit
def _turn(a: float, b: float, angle: float) -> tuple[float, float]:
    """(a, b) turned by `angle` (its Cayley rotation): the flow of one axis' energy term on the
    other two components of the angular momentum."""
    t = 0.5 * angle
    d = 1.0 / (1.0 + t * t)
    c, s = (1.0 - t * t) * d, 2.0 * t * d
    return c * a + s * b, c * b - s * a


@jit
def free_rotation(
    ixx: float, iyy: float, izz: float, lx: float, ly: float, lz: float, step_s: float
) -> tuple[float, float, float]:
    """The body-frame angular momentum (lx, ly, lz) of a body with principal inertia (ixx, iyy,
    izz), after `step_s` of torque-free rotation (the symmetric splitting)."""
    half = 0.5 * step_s
    ly, lz = _turn(ly, lz, half * lx / ixx)
    lz, lx = _turn(lz, lx, half * ly / iyy)
    lx, ly = _turn(lx, ly, step_s * lz / izz)
    lz, lx = _turn(lz, lx, half * ly / iyy)
    ly, lz = _turn(ly, lz, half * lx / ixx)
    return lx, ly, lz


@jit
def add_gyroscopic_correction(
    ixx: float,
    iyy: float,
    izz: float,
    step_s: float,
    rotation: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]],
    spin: tuple[float, float, float],
    out: MutableFloats,
) -> None:
    """Add to the world-frame torque out[3:6] what makes PyBullet's explicit step of the body rates
    `spin` (world frame; `rotation`: world <- body) land on `free_rotation`'s: in the body frame,
    w x L (cancelling PyBullet's -w x I w) plus the splitting's change of L over the step. The
    other torques then add to the rates as before."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = rotation
    sx, sy, sz = spin
    wx = m00 * sx + m10 * sy + m20 * sz
    wy = m01 * sx + m11 * sy + m21 * sz
    wz = m02 * sx + m12 * sy + m22 * sz
    lx, ly, lz = ixx * wx, iyy * wy, izz * wz
    nx, ny, nz = free_rotation(ixx, iyy, izz, lx, ly, lz, step_s)
    inv = 1.0 / step_s
    cx = wy * lz - wz * ly + (nx - lx) * inv
    cy = wz * lx - wx * lz + (ny - ly) * inv
    cz = wx * ly - wy * lx + (nz - lz) * inv
    out[3] += m00 * cx + m01 * cy + m02 * cz
    out[4] += m10 * cx + m11 * cy + m12 * cz
    out[5] += m20 * cx + m21 * cy + m22 * cz
