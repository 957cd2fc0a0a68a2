"""quadsim.core.exact: small linear algebra in exact arithmetic, rounded once."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from quadsim.core import exact


def test_the_inverse_is_the_correctly_rounded_one():
    a = [[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]]  # det 18: entries like 11/18 are not floats
    inverse = exact.inverse(a)
    # the exact inverse, by its adjugate
    expected = [[11, -4, 1], [-4, 8, -2], [1, -2, 5]]
    assert inverse == [[float(Fraction(v, 18)) for v in row] for row in expected]
    assert np.allclose(np.array(a) @ np.array(inverse), np.eye(3), atol=1e-15)


def test_a_pseudo_inverse_of_full_row_rank_matches_numpys_and_inverts_from_the_right():
    rng = np.random.default_rng(4)
    a = rng.normal(size=(4, 6))
    pinv = np.array(exact.pseudo_inverse(a.tolist()))
    assert pinv.shape == (6, 4)
    assert np.allclose(pinv, np.linalg.pinv(a), rtol=0, atol=1e-13)
    assert np.allclose(a @ pinv, np.eye(4), atol=1e-13)
    square = rng.normal(size=(4, 4))
    assert exact.pseudo_inverse(square.tolist()) == exact.inverse(square.tolist())


def test_solve_and_the_quadratic_form():
    assert exact.solve([[4.0, 0.0], [0.0, 3.0]], [1.0, 1.0]) == [0.25, float(Fraction(1, 3))]
    assert exact.quadratic_form([1.0, 2.0], [[1.0, 0.5], [0.5, 2.0]]) == 1.0 + 2.0 + 8.0


def test_a_singular_matrix_is_refused():
    with pytest.raises(ValueError, match="singular"):
        exact.inverse([[1.0, 2.0], [2.0, 4.0]])
    with pytest.raises(ValueError, match="singular"):
        exact.pseudo_inverse([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
