"""The exact trigonometric-polynomial algebra: identities, calculus, sympy round trips."""

import math

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from symdyn.derivation.trigpoly import TrigSpace, equal, fold, from_expr, space_for

q1, q2, q3 = sp.symbols("q1 q2 q3", real=True)
a, b = sp.symbols("a b", real=True)
S = TrigSpace((q1, q2), (a, b))


def value(expr, point):
    """Numeric value of a sympy expression at {symbol: float}."""
    return float(sp.sympify(expr).xreplace({s: sp.Float(v, 30) for s, v in point.items()}))


POINT = {q1: 0.37, q2: -1.21, a: 0.8, b: -1.7}


def evaluate(p, point):
    """Numeric value of a trig polynomial from its terms (independent of to_expr)."""
    theta = np.array([point[s] for s in p.space.angles])
    gens = [point[s] for s in p.space.gens]
    total = 0.0
    for k, kind, coeff in p.items():
        c = sum(float(x) * math.prod(g**e for g, e in zip(gens, m)) for m, x in coeff.items())
        total += c * (math.cos if kind == "cos" else math.sin)(float(np.dot(k, theta)))
    return total


# --------------------------------------------------------------------------- random polynomials

coefficients = st.fractions(min_value=-5, max_value=5, max_denominator=7)
monomials = st.tuples(st.integers(0, 2), st.integers(0, 2))
terms = st.tuples(
    st.tuples(st.integers(-3, 3), st.integers(-3, 3)), st.sampled_from(["cos", "sin"]), coefficients, monomials
)


@st.composite
def trigpolys(draw):
    p = S.zero
    for k, kind, c, (i, j) in draw(st.lists(terms, max_size=4)):
        p = p + S.term(k, kind, sp.Rational(c.numerator, c.denominator) * a**i * b**j)
    return p


# --------------------------------------------------------------------------- identities


@pytest.mark.parametrize("i", [0, 1])
def test_sin_squared_plus_cos_squared_is_one(i):
    assert S.sin(i) ** 2 + S.cos(i) ** 2 == 1
    assert S.cos(i) ** 2 - S.sin(i) ** 2 == S.term([2 * (i == 0), 2 * (i == 1)], "cos")


def test_product_to_sum_formulas():
    A, B = S.term([1, 0], "cos"), S.term([0, 1], "cos")
    sA, sB = S.term([1, 0], "sin"), S.term([0, 1], "sin")
    half = sp.Rational(1, 2)
    assert A * B == half * (S.term([1, -1], "cos") + S.term([1, 1], "cos"))
    assert sA * sB == half * (S.term([1, -1], "cos") - S.term([1, 1], "cos"))
    assert sA * B == half * (S.term([1, 1], "sin") + S.term([1, -1], "sin"))
    assert A * sB == half * (S.term([1, 1], "sin") - S.term([1, -1], "sin"))
    assert A * B - sA * sB == S.term([1, 1], "cos")  # cos(q1 + q2)


def test_frequency_vectors_are_canonical():
    assert S.term([-1, 2], "cos") == S.term([1, -2], "cos")
    assert S.term([-1, 2], "sin") == -S.term([1, -2], "sin")
    assert S.term([0, 0], "sin").is_zero()
    assert S.term([0, 0], "cos") == 1
    assert [k for k, _, _ in (S.term([-2, 1], "cos") + S.term([0, -3], "sin")).items()] == [(0, 3), (2, -1)]


def test_angle_derivative_is_exact():
    p = S.term([2, 1], "sin", a)  # a sin(2q1 + q2)
    assert p.diff(q1) == S.term([2, 1], "cos", 2 * a)
    assert p.diff(q2) == S.term([2, 1], "cos", a)
    assert S.term([2, 1], "cos", b).diff(q1) == S.term([2, 1], "sin", -2 * b)
    assert p.diff(q3).is_zero()


def test_generator_derivative_and_substitution():
    p = S.term([1, 0], "cos", a**2 * b + 3 * b)
    assert p.diff(a) == S.term([1, 0], "cos", 2 * a * b)
    assert p.diff(b) == S.term([1, 0], "cos", a**2 + 3)
    assert p.subs_gen({a: 2}) == S.term([1, 0], "cos", 7 * b)


def test_embedding_into_a_larger_space_keeps_the_expression():
    p = S.term([1, 1], "sin", a * b) + 2
    big = TrigSpace((q1, q2), (a, b, q3))
    assert p.embed(big).to_expr() == p.to_expr()
    with pytest.raises(ValueError, match="cannot embed"):
        p.embed(TrigSpace((q1, q2), (b, a)))


def test_mixing_spaces_is_an_error():
    with pytest.raises(ValueError, match="different spaces"):
        S.cos(0) + TrigSpace((q1,), ()).cos(0)


# --------------------------------------------------------------------------- properties


@settings(max_examples=30, deadline=None)
@given(trigpolys(), trigpolys(), trigpolys())
def test_ring_axioms(x, y, z):
    assert x * y == y * x
    assert (x * y) * z == x * (y * z)
    assert x * (y + z) == x * y + x * z
    assert x - x == 0
    assert x * 1 == x


@settings(max_examples=40, deadline=None)
@given(trigpolys(), trigpolys())
def test_product_agrees_numerically(x, y):
    expected = evaluate(x, POINT) * evaluate(y, POINT)
    assert evaluate(x * y, POINT) == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert evaluate(x, POINT) == pytest.approx(value(x.to_expr(), POINT), rel=1e-12, abs=1e-12)


@settings(max_examples=25, deadline=None)
@given(trigpolys(), trigpolys())
def test_product_rule(x, y):
    for s in (q1, q2, a):
        assert (x * y).diff(s) == x.diff(s) * y + x * y.diff(s)


@settings(max_examples=25, deadline=None)
@given(trigpolys())
def test_to_expr_from_expr_round_trip(x):
    e = x.to_expr()
    assert from_expr(e, S) == x
    assert sp.expand(sp.diff(e, q1) - x.diff(q1).to_expr()) == 0


atoms = st.sampled_from(
    [sp.cos(q1), sp.sin(q2), sp.cos(q1 - 2 * q2), sp.sin(q1 + q2 + sp.pi / 2), a, b, sp.Rational(3, 4), sp.Integer(-2)]
)


@st.composite
def expressions(draw, depth=3):
    if depth == 0 or draw(st.booleans()):
        return draw(atoms)
    op = draw(st.sampled_from(["add", "mul", "pow"]))
    x = draw(expressions(depth=depth - 1))
    if op == "pow":
        return x ** draw(st.integers(0, 3))
    y = draw(expressions(depth=depth - 1))
    return x + y if op == "add" else x * y


@settings(max_examples=60, deadline=None)
@given(expressions())
def test_from_expr_keeps_the_value_of_random_expressions(e):
    folded = from_expr(e, S).to_expr()
    assert value(folded, POINT) == pytest.approx(value(e, POINT), rel=1e-12, abs=1e-12)


# --------------------------------------------------------------------------- sympy conversion


def test_fold_writes_natural_angles():
    e = sp.cos(q1) * sp.cos(q2) - sp.sin(q1) * sp.sin(q2)
    assert fold(e, (q1, q2)) == sp.cos(q1 + q2)
    assert fold(sp.cos(q2 + sp.pi / 2) * 3, (q2,)) == -3 * sp.sin(q2)


def test_equal_compares_exact_trig_forms():
    assert equal(sp.sin(2 * q1), 2 * sp.sin(q1) * sp.cos(q1), (q1,))
    assert equal(a * sp.cos(q1) ** 2 + a * sp.sin(q1) ** 2, a, (q1,))
    assert not equal(sp.cos(q1) ** 2, 1, (q1,))
    assert not equal(sp.sin(q1 + q2), sp.sin(q1) * sp.cos(q2), (q1, q2))


def test_floats_become_exact_rationals_and_offsets_stay_exact():
    assert from_expr(0.5 * sp.cos(q1) + 0.25, S) == S.term([1, 0], "cos", sp.Rational(1, 2)) + sp.Rational(1, 4)
    T = TrigSpace((q1, q2), (), offsets=(0, sp.pi / 6))
    p = from_expr(sp.cos(q2 + sp.pi / 6) ** 2, T)  # θ2 = q2 + π/6: exact
    assert p == sp.Rational(1, 2) + T.term([0, 2], "cos", sp.Rational(1, 2))
    assert p.to_expr() == sp.cos(2 * q2 + sp.pi / 3) / 2 + sp.Rational(1, 2)
    c = from_expr(sp.cos(q2), T)  # cos(θ2 − π/6): constants of doubles
    assert value(c.to_expr(), {q2: 0.4}) == pytest.approx(math.cos(0.4), rel=1e-15)


def test_shared_subtrees_are_converted_once():
    # x_{k+1} = x_k cos q1 + x_k sin q2: a tree of 2^24 leaves, a DAG of ~70 nodes
    x = a
    for _ in range(24):
        x = x * sp.cos(q1) + x * sp.sin(q2)
    space = space_for([x], (q1, q2))
    memo: dict = {}
    p = from_expr(x, space, memo)
    assert len(memo) < 6 * 24
    assert p == from_expr(a * (sp.cos(q1) + sp.sin(q2)) ** 24, space)


@pytest.mark.parametrize(
    "expr, culprit",
    [
        (q1 * sp.cos(q1), "outside sin/cos"),
        (sp.cos(q1 / 2), "non-integer multiple"),
        (sp.cos(a), "integer combination of the angles"),
        (sp.Symbol("z") * sp.cos(q1), "unknown symbol z"),
        (1 / a, "power -1 of a non-constant"),
        (sp.tan(q1), "unsupported function tan"),
    ],
)
def test_non_polynomial_input_names_the_culprit(expr, culprit):
    with pytest.raises(ValueError, match=culprit):
        from_expr(expr, S)


def test_numeric_constants_fold_to_exact_values():
    assert from_expr(sp.sqrt(4) * sp.cos(q1) + 2**-2, S) == S.term([1, 0], "cos", 2) + sp.Rational(1, 4)
    assert from_expr(sp.sin(q1 + sp.pi) + sp.sin(q1), S).is_zero()
    assert np.isclose(value(from_expr(sp.sqrt(2) * a, S).to_expr(), POINT), math.sqrt(2) * 0.8, rtol=1e-15)


def test_named_intermediates_fold_through_a_seeded_memo():
    w1, w2 = sp.symbols("w1 w2")
    definitions = [(w1, a * sp.cos(q1)), (w2, w1 * sp.sin(q2) + w1)]
    memo: dict = {}
    for name, expr in definitions:
        memo[name] = from_expr(expr, S, memo)
    direct = from_expr(a * sp.cos(q1) * sp.sin(q2) * (b + 1) + a * b * sp.cos(q1), S)
    assert from_expr(w2 * b + w1 * sp.sin(q2), S, memo) == direct


def test_items_give_ring_coefficients_and_rebuild_the_polynomial():
    p = from_expr(sp.Rational(3, 4) * a**2 * sp.cos(q1 - q2) - b * sp.sin(2 * q2) + 5, S)
    rebuilt = S.zero
    for k, kind, coeff in p.items():
        assert coeff.ring == S.ring
        rebuilt = rebuilt + S.term(k, kind, 1) * S.const(coeff)
    assert rebuilt == p
    assert [(k, kind) for k, kind, _ in p.items()] == [((0, 0), "cos"), ((0, 2), "sin"), ((1, -1), "cos")]
