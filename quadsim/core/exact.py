"""Small linear algebra in exact rational arithmetic, rounded to floats once at the end: the same
bits on every machine.

NumPy hands `inv`, `pinv`, `solve` and `@` to OpenBLAS, which picks its kernels for the CPU it
finds (Haswell, SkylakeX, Zen...): the same matrix inverted on two machines can differ in the
last bits, and a flight that starts from those bits re-flies at 1e-16 m instead of 0 on another
machine (docs/reference/determinism.md, "On another machine"). The matrices quadsim
inverts are small (the mixer's 4 x N allocation, the turbulence filter's 4 x 4 Lyapunov system)
and are inverted once per run, so exact arithmetic costs well under a millisecond, and its
result is the correctly rounded inverse, as close as a float can be.
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction

Matrix = Sequence[Sequence[float]]


def _exact(rows: Matrix) -> list[list[Fraction]]:
    return [[Fraction(float(x)) for x in row] for row in rows]


def _rounded(rows: list[list[Fraction]]) -> list[list[float]]:
    return [[float(x) for x in row] for row in rows]


def _solve_exact(a: list[list[Fraction]], b: list[list[Fraction]]) -> list[list[Fraction]]:
    """X with A X = B, A square and invertible (Gauss-Jordan elimination; in exact arithmetic a
    pivot only has to be non-zero). ValueError if A is singular."""
    n = len(a)
    if any(len(row) != n for row in a) or len(b) != n:
        raise ValueError("expected a square matrix and as many right-hand rows")
    m = [list(a[i]) + list(b[i]) for i in range(n)]
    for col in range(n):
        pivot = next((r for r in range(col, n) if m[r][col] != 0), None)
        if pivot is None:
            raise ValueError("singular matrix")
        m[col], m[pivot] = m[pivot], m[col]
        lead = m[col][col]
        m[col] = [x / lead for x in m[col]]
        for r in range(n):
            factor = m[r][col]
            if r != col and factor != 0:
                m[r] = [x - factor * y for x, y in zip(m[r], m[col])]
    return [row[n:] for row in m]


def _identity(n: int) -> list[list[Fraction]]:
    return [[Fraction(int(i == j)) for j in range(n)] for i in range(n)]


def inverse(rows: Matrix) -> list[list[float]]:
    """The inverse of a square matrix, each entry correctly rounded. ValueError if singular."""
    return _rounded(_solve_exact(_exact(rows), _identity(len(rows))))


def pseudo_inverse(rows: Matrix) -> list[list[float]]:
    """The Moore-Penrose pseudo-inverse of an M x N matrix of full row rank (M <= N):
    A^T (A A^T)^-1, each entry correctly rounded. The inverse when M = N. ValueError if the rows
    are not independent."""
    a = _exact(rows)
    m = len(a)
    n = len(a[0]) if m else 0
    if m == n:
        return inverse(rows)
    gram = [[sum((a[i][k] * a[j][k] for k in range(n)), Fraction(0)) for j in range(m)] for i in range(m)]
    gram_inverse = _solve_exact(gram, _identity(m))
    return _rounded(
        [[sum((a[k][i] * gram_inverse[k][j] for k in range(m)), Fraction(0)) for j in range(m)] for i in range(n)]
    )


def solve(rows: Matrix, vector: Sequence[float]) -> list[float]:
    """x with A x = b, A square and invertible, each entry correctly rounded."""
    x = _solve_exact(_exact(rows), [[Fraction(float(v))] for v in vector])
    return [float(row[0]) for row in x]


def quadratic_form(vector: Sequence[float], rows: Matrix) -> float:
    """v^T A v, correctly rounded."""
    v = [Fraction(float(x)) for x in vector]
    a = _exact(rows)
    return float(sum((v[i] * a[i][j] * v[j] for i in range(len(v)) for j in range(len(v))), Fraction(0)))
