"""The closed-form contact wrench cone of a rectangular sole (`symdyn.apps.wrench_cone`) is the cone
its sixteen corner rays span: a random wrench satisfies the rows exactly when a non-negative
combination of the rays (a linear programme) gives it."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import linprog

from symdyn.apps.wrench_cone import rows
from tests.conftest import tiered


def _generators(X: float, Y: float, mu: float) -> np.ndarray:
    """(6, 16): the wrench about the centre of a force along each edge of the friction pyramid
    (f_z = 1) at each corner."""
    out = []
    for cx, cy in itertools.product((X, -X), (Y, -Y)):
        for dx, dy in itertools.product((mu, -mu), repeat=2):  # the pyramid |f_x|, |f_y| <= mu f_z
            f = np.array([dx, dy, 1.0])
            out.append(np.concatenate([f, np.cross([cx, cy, 0.0], f)]))
    return np.array(out).T


def _spanned(w: np.ndarray, G: np.ndarray) -> bool:
    res = linprog(np.zeros(G.shape[1]), A_eq=G, b_eq=w, bounds=(0, None), method="highs")
    return res.status == 0


# one sole in the main suite, two more shapes in make test-all
@pytest.mark.parametrize("X, Y, mu", tiered([(0.1, 0.05, 0.7), (0.05, 0.12, 0.3), (0.2, 0.2, 1.0)], 1))
def test_the_rows_are_the_cone_the_corner_rays_span(X, Y, mu):
    rng = np.random.default_rng(0)
    G = _generators(X, Y, mu)
    agree = inside = 0
    for _ in range(600):
        if rng.random() < 0.5:  # a wrench of the cone, moved a little: near its faces
            w = G @ (rng.exponential(size=16) * (rng.random(16) < 0.5))
            w = w + rng.normal(scale=0.02 * (1 + np.abs(w).max()), size=6)
        else:
            w = rng.normal(size=6) * np.array([1, 1, 1, X, Y, 0.1]) + np.array([0, 0, 2, 0, 0, 0])
        g = np.array(rows(w[:3], w[3:], X, Y, mu))
        if np.abs(g).min() < 1e-9 * (1 + np.abs(w).max()):
            continue  # on a face: either answer is right in floating point
        closed = bool((g <= 0).all())
        assert closed == _spanned(w, G), (w, g.max())
        agree += 1
        inside += closed
    assert agree > 500 and 50 < inside < agree - 50  # both sides were tried


def test_the_rows_take_casadi_expressions_and_refuse_a_degenerate_sole():
    import casadi as ca

    f, t = ca.SX.sym("f", 3), ca.SX.sym("t", 3)
    g = ca.Function("g", [f, t], [ca.vertcat(*rows(f, t, 0.1, 0.05, 0.7))])
    w = np.array([0.1, -0.2, 10.0, 0.05, -0.1, 0.02])
    np.testing.assert_allclose(g(w[:3], w[3:]).full().ravel(), rows(w[:3], w[3:], 0.1, 0.05, 0.7))
    with pytest.raises(ValueError, match="half_width must be a positive finite number, got 0"):
        rows(w[:3], w[3:], 0.1, 0, 0.7)
