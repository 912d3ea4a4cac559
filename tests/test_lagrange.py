"""The Lagrange route: M, C, G against the numeric reference, Eq. 9.3 exactly, physics identities."""

import dataclasses
import math

import numpy as np
import pytest
import sympy as sp

from conftest import random_states
from symdyn import models
from symdyn.derivation import lagrange
from symdyn.derivation.symbols import joint_symbols
from symdyn.model import Link, Robot, rotx, roty
from symdyn.numeric import reference as ref

NUMERIC = ["puma560", "puma560_mdh", "twolink", "rrp"]


_NUMPY = {sp.cos: np.cos, sp.sin: np.sin, sp.sign: np.sign, sp.Abs: np.abs}


def evaluate(matrix, symbols, values):
    """Evaluate a sympy matrix at N states: values (N, len(symbols)) -> (N, *shape).

    A direct walk of the expression trees with NumPy arrays (what lambdify
    does, without printing and compiling source, which takes seconds here)."""
    memo = {s: values[:, i] for i, s in enumerate(symbols)}

    def walk(e):
        if e in memo:
            return memo[e]
        if e.is_Number:
            v = float(e)
        elif e.is_Add:
            v = sum(walk(a) for a in e.args)
        elif e.is_Mul:
            v = math.prod(walk(a) for a in e.args)
        elif e.is_Pow:
            v = walk(e.base) ** float(e.exp)
        elif e.func in _NUMPY:
            v = _NUMPY[e.func](walk(e.args[0]))
        elif e.is_number:
            v = float(e)
        else:
            raise ValueError(f"cannot evaluate {e}")
        memo[e] = v
        return v

    cols = [np.broadcast_to(walk(x), values.shape[:1]) for x in matrix]
    return np.stack(cols, -1).reshape(values.shape[:1] + matrix.shape)


def assert_close(got, expected):
    scale = max(1.0, np.abs(expected).max())
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12 * scale)


@pytest.fixture(scope="module")
def derived():
    """name -> (robot, Dynamics), derived once per module."""
    cache = {}

    def get(name):
        if name not in cache:
            robot = models.load(name)
            cache[name] = robot, lagrange.derive(robot)
        return cache[name]

    return get


# --------------------------------------------------------------------------- against the reference


@pytest.mark.parametrize("name", NUMERIC)
def test_M_C_G_match_the_reference_at_random_states(name, derived):
    robot, D = derived(name)
    q, qd, _ = random_states(robot, 200, seed=11)
    x = np.hstack([q, qd])
    syms = D.q + D.qd
    assert_close(evaluate(D.M, syms, x), ref.inertia(robot, q))
    assert_close(evaluate(D.C, syms, x), ref.coriolis(robot, q, qd))
    assert_close(evaluate(D.G, syms, x)[..., 0], ref.gravload(robot, q))


@pytest.mark.parametrize("name", ["puma560", "rrp"])
def test_tau_with_friction_matches_rne(name, derived):
    robot, D = derived(name)
    q, qd, qdd = random_states(robot, 200, seed=12)
    tau = evaluate(D.tau, D.q + D.qd + D.qdd, np.hstack([q, qd, qdd]))[..., 0]
    assert_close(tau, ref.rne(robot, q, qd, qdd))


@pytest.mark.parametrize("name", ["rrp", "twolink"])
def test_christoffel_symbols_match_the_reference(name):
    robot = models.load(name)
    Gam = lagrange.christoffel(robot)
    q, _, _ = random_states(robot, 50, seed=13)
    got = evaluate(sp.ImmutableMatrix(np.array(Gam.tolist()).reshape(-1)), joint_symbols(robot.n)[0], q)
    assert_close(got.reshape(ref.christoffel(robot, q).shape), ref.christoffel(robot, q))


def _variant(name):
    rrp = models.load("rrp")
    if name == "tilted base, odd twist, prismatic offset":
        links = list(rrp.links)
        links[0] = dataclasses.replace(links[0], alpha=-1.1)  # not a multiple of π/2
        links[2] = dataclasses.replace(links[2], offset=0.07)
        T = np.array(rotx(0.4), dtype=float) @ np.array(roty(-2.0), dtype=float)
        return dataclasses.replace(rrp, links=tuple(links), base=T.tolist())
    if name == "hanging modified-DH rrp":
        return dataclasses.replace(rrp.to_modified(), base=rotx(math.pi))
    raise KeyError(name)


@pytest.mark.parametrize("name", ["tilted base, odd twist, prismatic offset", "hanging modified-DH rrp"])
def test_variants_match_the_reference(name):
    robot = _variant(name)
    M, C, G = lagrange.equations(robot)
    q, qd, _ = random_states(robot, 100, seed=14)
    syms = joint_symbols(robot.n)
    x = np.hstack([q, qd])
    assert_close(evaluate(M, syms[0] + syms[1], x), ref.inertia(robot, q))
    assert_close(evaluate(C, syms[0] + syms[1], x), ref.coriolis(robot, q, qd))
    assert_close(evaluate(G, syms[0] + syms[1], x)[..., 0], ref.gravload(robot, q))


# --------------------------------------------------------------------------- the two-link arm, exactly


@pytest.fixture(scope="module")
def twolink_sym():
    robot = models.load("twolink", symbolic=True)
    return robot, lagrange.derive(robot)


def test_twolink_matches_eq_9_3(twolink_sym):
    robot, D = twolink_sym
    a1, a2, c1, c2, m1, m2, g = sp.symbols("a1 a2 c1 c2 m1 m2 g", real=True)
    q1, q2 = D.q
    qd1, qd2 = D.qd
    M11 = m1 * (a1**2 + 2 * a1 * c1 + c1**2) + m2 * (a1**2 + (a2 + c2) ** 2 + (2 * a1 * a2 + 2 * a1 * c2) * sp.cos(q2))
    M12 = m2 * (a2 + c2) * (a2 + c2 + a1 * sp.cos(q2))
    G1 = g * ((a1 * m1 + a1 * m2 + c1 * m1) * sp.cos(q1) + (a2 * m2 + c2 * m2) * sp.cos(q1 + q2))
    G2 = g * (a2 * m2 + c2 * m2) * sp.cos(q1 + q2)
    velocity = -2 * a1 * m2 * (a2 + c2) * sp.sin(q2) * qd1 * qd2 - a1 * m2 * (a2 + c2) * sp.sin(q2) * qd2**2
    assert sp.expand(D.M[0, 0] - M11) == 0
    assert sp.expand(D.M[0, 1] - M12) == 0
    assert sp.expand(D.M[1, 0] - M12) == 0
    assert sp.expand(D.G[0] - G1) == 0
    assert sp.expand(D.G[1] - G2) == 0
    assert sp.expand(D.Cqd[0] - velocity) == 0
    at_rest = {qd1: 0, qd2: 0, g: 0, **{x: 0 for x in D.qdd}}
    assert sp.expand(D.tau[0] - D.tau[0].xreplace(at_rest) - velocity - (D.M * sp.Matrix(D.qdd))[0] - D.G[0]) == 0


def test_symbolic_twolink_agrees_with_the_numeric_one(twolink_sym, derived):
    _, D = twolink_sym
    robot, Dn = derived("twolink")
    values = {s: v for s, v in zip(sp.symbols("a1 a2 c1 c2 m1 m2 g", real=True), (1, 1, -0.5, -0.5, 1, 1, 9.81))}
    q, qd, _ = random_states(robot, 20, seed=15)
    syms = D.q + D.qd
    for sym, num in ((D.M, Dn.M), (D.C, Dn.C), (D.G, Dn.G)):
        assert_close(evaluate(sym.xreplace(values), syms, np.hstack([q, qd])), evaluate(num, syms, np.hstack([q, qd])))


# --------------------------------------------------------------------------- physics, exactly


@pytest.mark.parametrize("name", ["puma560", "rrp", "twolink_sym"])
def test_M_symmetric_and_Mdot_minus_2C_skew_symmetric_exactly(name):
    robot = models.load("twolink", symbolic=True) if name == "twolink_sym" else models.load(name)
    T = lagrange.trig_dynamics(robot)
    Md = T.Mdot()
    n = robot.n
    for j in range(n):
        for k in range(n):
            assert T.M[j][k] == T.M[k][j]
            N_jk = Md[j][k] - 2 * T.C[j][k]
            N_kj = Md[k][j] - 2 * T.C[k][j]
            assert (N_jk + N_kj).is_zero(), (j, k)


def test_gravity_is_the_gradient_of_the_potential_and_tau_at_rest_is_G(derived):
    robot, D = derived("rrp")
    T = lagrange.trig_dynamics(robot)
    at_rest = {x: 0 for x in D.qd + D.qdd}
    assert sp.expand(D.tau.xreplace(at_rest) - D.G) == sp.zeros(robot.n, 1)
    q, _, _ = random_states(robot, 20, seed=16)
    V = evaluate(sp.ImmutableMatrix([T.V.to_expr()]), D.q, q)[:, 0, 0]
    assert_close(V, ref.energy(robot, q, np.zeros_like(q))[1])


def test_derive_fills_a_lagrange_dynamics(derived):
    robot, D = derived("rrp")
    assert D.method == "lagrange" and D.robot is robot
    assert (D.M.shape, D.C.shape, D.G.shape, D.F.shape, D.tau.shape) == ((3, 3), (3, 3), (3, 1), (3, 1), (3, 1))
    assert D.q == joint_symbols(3)[0]


# --------------------------------------------------------------------------- bad input


def test_symbolic_twist_is_refused_with_a_clear_message():
    al = sp.Symbol("alpha1", real=True)
    robot = Robot("bad", (Link(a=1, alpha=al, m=1, r=(0, 0, 0)),))
    with pytest.raises(ValueError, match="alpha of link 1 = alpha1 is symbolic"):
        lagrange.trig_dynamics(robot)
