"""Symbolic derivations: both methods agree exactly, with the reference, and with Eq. 9.3."""

import random
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from symdyn import models
from symdyn.derivation import trigpoly
from symdyn.derivation.entry import derive
from symdyn.derivation.exact import compile_exact
from symdyn.numeric import reference as ref

from conftest import random_states, tiered
from exact_eval import exact_value, random_point

MODELS = ["twolink", "puma560", "rrp", "puma560_mdh"]


@pytest.fixture(scope="module", params=tiered(MODELS, 3))  # the Puma in modified DH: make test-all
def ne(request):
    return derive(models.load(request.param), "newton-euler")


def _numeric(dyn, term):
    """A float function of (q, qd, qdd), through the derivation's named DAG where it has one."""
    args = list(dyn.q) + list(dyn.qd) + list(dyn.qdd)
    if term in dyn.named:
        defs = list(dyn.definitions)
        return sp.lambdify(args, dyn.named[term], "numpy", cse=lambda e: (defs, e), docstring_limit=0)
    return sp.lambdify(args, dyn.term(term), "numpy", cse=True, docstring_limit=0)


def _batch(f, q, qd, qdd):
    return np.array([np.array(f(*a, *b, *c), dtype=float) for a, b, c in zip(q, qd, qdd)])


def test_newton_euler_agrees_with_reference_at_200_states(ne):
    robot = ne.robot
    q, qd, qdd = random_states(robot, 200, seed=3)
    for term, expected in (
        ("tau", ref.rne(robot, q, qd, qdd)),
        ("M", ref.inertia(robot, q)),
        ("C", ref.coriolis(robot, q, qd)),
        ("G", ref.gravload(robot, q)),
        ("F", ref.friction(robot, qd)),
    ):
        got = _batch(_numeric(ne, term), q, qd, qdd).reshape(expected.shape)
        scale = max(1.0, np.abs(expected).max())
        assert np.abs(got - expected).max() <= 1e-12 * scale, term


def test_lagrange_agrees_with_reference_at_200_states():
    robot = models.load("puma560")
    dyn = derive(robot, "lagrange")
    q, qd, qdd = random_states(robot, 200, seed=4)
    for term, expected in (
        ("tau", ref.rne(robot, q, qd, qdd)),
        ("M", ref.inertia(robot, q)),
        ("C", ref.coriolis(robot, q, qd)),
        ("G", ref.gravload(robot, q)),
    ):
        got = _batch(_numeric(dyn, term), q, qd, qdd).reshape(expected.shape)
        assert np.abs(got - expected).max() <= 1e-12 * max(1.0, np.abs(expected).max()), term


def _vanishes(expr, q):
    """expr == 0 as a polynomial in sin qᵢ, cos qᵢ modulo sin² + cos² = 1 (independent of trigpoly)."""
    S = sp.symbols(f"S1:{len(q) + 1}")
    C = sp.symbols(f"C1:{len(q) + 1}")
    e = sp.expand(sp.expand_trig(expr)).xreplace({**dict(zip(map(sp.sin, q), S)), **dict(zip(map(sp.cos, q), C))})
    if e == 0:
        return True
    return sp.reduced(e, [s**2 + c**2 - 1 for s, c in zip(S, C)], *S, *C)[1] == 0


def test_methods_agree_symbolically_for_the_symbolic_twolink():
    robot = models.load("twolink", symbolic=True)
    a, b = derive(robot, "lagrange", cache=False), derive(robot, "newton-euler", cache=False)
    for term in ("M", "C", "G", "F", "tau"):
        for x, y in zip(a.term(term), b.term(term)):
            assert _vanishes(x - y, a.q), term
            assert trigpoly.equal(x, y, a.q), term


# make test-all: the two methods' exact agreement is in the main suite on the symbolic two-link arm
# (test_methods_agree_symbolically_for_the_symbolic_twolink) and on random trees at exact rational
# points (tests/test_tree_derivations.py::test_lagrange_and_newton_euler_agree_exactly_on_random_trees)
@pytest.mark.slow
def test_methods_agree_exactly_at_20_rational_points_for_the_puma():
    robot = models.load("puma560")
    lag, ne = derive(robot, "lagrange"), derive(robot, "newton-euler")
    q, qd, qdd = ne.q, ne.qd, ne.qdd
    terms = ("M", "C", "G", "tau")
    # both sides compiled to exact Fraction arithmetic; trig atoms are inputs
    ne_out = [e for t in terms for e in (ne.named[t] - ne.F if t == "tau" else ne.named[t])]
    lag_out = [e for t in terms for e in (lag.term(t) - lag.F if t == "tau" else lag.term(t))]
    ne_atoms = [f(x) for x in q for f in (sp.cos, sp.sin)]
    lag_atoms = sorted(set().union(*(e.atoms(sp.sin, sp.cos) for e in lag_out)), key=sp.default_sort_key)
    rates = list(qd) + list(qdd)
    ne_eval = compile_exact(ne.definitions, ne_out, ne_atoms + rates)
    lag_eval = compile_exact((), lag_out, lag_atoms + rates)
    rng = random.Random(7)
    for _ in range(20):
        angles, values = random_point(robot, rng)
        rate_values = [values[s] for s in rates]
        atom_values = [Fraction(str(exact_value(a, q, angles, {}))) for a in lag_atoms]
        got_ne = ne_eval(*[v for cs in angles for v in cs], *rate_values)
        got_lag = lag_eval(*atom_values, *rate_values)
        assert all(isinstance(x, Fraction) or x == 0 for x in got_ne)
        assert list(got_ne) == list(got_lag)


def test_twolink_coefficients_are_those_of_eq_9_3():
    robot = models.load("twolink", symbolic=True)
    dyn = derive(robot, "newton-euler", cache=False)
    a1, a2, c1, c2, m1, m2, g = sp.symbols("a1 a2 c1 c2 m1 m2 g", real=True)
    q1, q2 = dyn.q
    qd1, qd2 = dyn.qd
    qdd1, qdd2 = dyn.qdd
    M11 = m1 * (a1**2 + 2 * a1 * c1 + c1**2) + m2 * (a1**2 + (a2 + c2) ** 2 + (2 * a1 * a2 + 2 * a1 * c2) * sp.cos(q2))
    M12 = m2 * (a2 + c2) * (a2 + c2 + a1 * sp.cos(q2))
    C1 = -2 * a1 * m2 * (a2 + c2) * sp.sin(q2)
    C2 = -a1 * m2 * (a2 + c2) * sp.sin(q2)
    grav = g * ((a1 * m1 + a1 * m2 + c1 * m1) * sp.cos(q1) + (a2 * m2 + c2 * m2) * sp.cos(q1 + q2))
    tau1 = sp.expand(dyn.tau[0])
    coeff = lambda e, x: sp.expand(e).coeff(x)  # noqa: E731
    assert trigpoly.equal(coeff(tau1, qdd1), M11, dyn.q)
    assert trigpoly.equal(coeff(tau1, qdd2), M12, dyn.q)
    assert trigpoly.equal(coeff(coeff(tau1, qd1), qd2), C1, dyn.q)
    assert trigpoly.equal(coeff(tau1, qd2**2), C2, dyn.q)
    rest = tau1.subs({qdd1: 0, qdd2: 0, qd1: 0, qd2: 0})
    assert trigpoly.equal(rest, grav, dyn.q)
    assert coeff(tau1, qd1**2) == 0


def test_mdot_minus_2c_is_skew_symmetric_exactly():
    dyn = derive(models.load("twolink", symbolic=True), "newton-euler", cache=False)
    Mdot = sp.Matrix(dyn.n, dyn.n, lambda i, j: sum(sp.diff(dyn.M[i, j], q) * v for q, v in zip(dyn.q, dyn.qd)))
    S = Mdot - 2 * sp.Matrix(dyn.C)
    for x in S + S.T:
        assert trigpoly.equal(x, 0, dyn.q)


def test_second_derivation_comes_from_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    robot = models.load("twolink")
    first = derive(robot)
    second = derive(robot)
    assert not first.stats["from_cache"] and second.stats["from_cache"]
    assert second.M == first.M and second.tau == first.tau
    assert list(tmp_path.iterdir())


def test_corrupt_cache_entry_is_detected_and_rebuilt(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    robot = models.load("twolink")
    good = derive(robot)
    (entry,) = tmp_path.iterdir()
    entry.write_bytes(b"not a pickle")
    again = derive(robot)
    assert not again.stats["from_cache"] and again.M == good.M
    assert "ignored" in capsys.readouterr().err
    assert derive(robot).stats["from_cache"]


def test_xdg_cache_home_is_respected(tmp_path, monkeypatch):
    monkeypatch.delenv("SYMDYN_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    derive(models.load("twolink"))
    assert any((tmp_path / "symdyn").iterdir())


def test_no_cache_bypasses_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    derive(models.load("twolink"), cache=False)
    assert not list(tmp_path.iterdir())


def test_unknown_method_is_an_error():
    with pytest.raises(ValueError, match="unknown method 'euler'"):
        derive(models.load("twolink"), "euler")


def test_op_counts_are_reported_per_stage():
    dyn = derive(models.load("puma560"))
    from symdyn.derivation.simplify import op_counts

    counts = op_counts(dyn, "G", stages=("cse",))["cse"]
    assert {"mul", "add"} <= set(counts) and counts["mul"] > 0
    from symdyn.derivation.simplify import op_counts

    stages = op_counts(dyn, "G", ("raw", "cse", "folded"))
    assert stages["folded"]["mul"] + stages["folded"]["add"] < stages["cse"]["mul"] + stages["cse"]["add"]
