"""Newton–Euler on a floating base (issue 35): the base joint's rows and columns first.

The derivation's τ, M, G and C·v at random states equal the numeric reference
(itself checked against Pinocchio's free-flyer and planar models); exact identities
at rational points: τ = M v̇ + C·v + G, M symmetric, the base block's diagonal the
robot's total mass; any non-zero quaternion names its rotation.  Terms are evaluated
through the derivation's named definitions: the expanded trees of a floating base run
to 10⁶ operations.
"""

from __future__ import annotations

import dataclasses
import math
import random
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

import symdyn.reference as ref
from symdyn.derivation.entry import derive
from symdyn.derivation.exact import compile_exact, rational_angle
from symdyn.model.random_robots import random_tree_robot
from tests.conftest import tiered

BASES = ("free", "planar")
TERMS = ("tau", "M", "G", "Cqd")


def _robot(seed: int, base: str, n: int = 4):
    robot = random_tree_robot(seed, n=n, base_joint=base)
    return dataclasses.replace(robot, gravity=(0.3, -1.2, 9.81)).nofriction(all=True)  # gravity along every base axis


def _angles(dyn) -> list:
    """The coordinates that enter through cos and sin: the joints' and a planar base's yaw."""
    return [s for s in dyn.q if not s.name.startswith("base_") or s.name == "base_yaw"]


_COMPILED: dict = {}


def _evaluate(dyn, q: dict, trig: dict, v, a) -> dict:
    """τ, M, G, C·v at one state: q {symbol: value}, trig {angle symbol: (cos, sin)}."""
    angles = _angles(dyn)
    if id(dyn) not in _COMPILED:
        inputs = [*dyn.q, *(f(s) for s in angles for f in (sp.cos, sp.sin)), *dyn.qd, *dyn.qdd]
        _COMPILED[id(dyn)] = (dyn, compile_exact(dyn.definitions, [e for t in TERMS for e in dyn.named[t]], inputs))
    flat = _COMPILED[id(dyn)][1](*(q[s] for s in dyn.q), *(x for s in angles for x in trig[s]), *v, *a)
    out, k = {}, 0
    for t in TERMS:
        out[t], k = flat[k : k + len(dyn.named[t])], k + len(dyn.named[t])
    return out


@pytest.mark.parametrize("base", BASES)
@pytest.mark.parametrize("seed", tiered(range(3), 1))
def test_floating_newton_euler_equals_the_reference(seed, base):
    robot = _robot(seed, base)
    dyn = derive(robot, cache=False)
    assert (len(dyn.q), len(dyn.qd), dyn.named["M"].shape) == (robot.nq, robot.nv, (robot.nv, robot.nv))
    rng = np.random.default_rng(seed)
    for _ in range(10):
        q = robot.integrate(robot.neutral(), rng.normal(size=robot.nv) * 2)
        v, a = rng.normal(size=robot.nv), rng.normal(size=robot.nv)
        values = dict(zip(dyn.q, map(float, q)))
        got = _evaluate(dyn, values, {s: (math.cos(values[s]), math.sin(values[s])) for s in _angles(dyn)}, v, a)
        expected = {
            "tau": ref.rne(robot, q, v, a),
            "M": ref.inertia(robot, q),
            "G": ref.gravload(robot, q),
            "Cqd": ref.rne(robot.nofriction(all=True), q, v, 0 * v, gravity=(0, 0, 0)),
        }
        for term, want in expected.items():
            have = np.array(got[term], dtype=float).reshape(want.shape)
            assert np.abs(have - want).max() < 1e-10 * (1 + np.abs(want).max()), term


@pytest.mark.parametrize("base", tiered(["planar", "free"], 1))  # the free base: make test-all
def test_floating_identities_hold_exactly(base):
    robot = _robot(5, base, n=3).nofriction(all=True)
    dyn = derive(robot, cache=False)
    rng = random.Random(0)
    q = {s: Fraction(rng.randint(-9, 9), rng.randint(1, 7)) for s in dyn.q}
    if base == "free":  # a quaternion far from unit norm: only its direction counts
        q[dyn.q[6]] = Fraction(3)
    trig = {s: rational_angle(rng) for s in _angles(dyn)}
    v, a = ([Fraction(rng.randint(-9, 9), rng.randint(1, 7)) for _ in dyn.qd] for _ in range(2))
    terms = _evaluate(dyn, q, trig, v, a)
    nv = robot.nv
    M = [terms["M"][r * nv : (r + 1) * nv] for r in range(nv)]
    assert all(M[r][c] == M[c][r] for r in range(nv) for c in range(nv))
    for r in range(nv):
        assert terms["tau"][r] == sum(M[r][c] * a[c] for c in range(nv)) + terms["Cqd"][r] + terms["G"][r]
    total = sum(Fraction(str(link.m)) for link in robot.links) + Fraction(str(robot.base_body.m))
    assert M[0][0] == total and M[1][1] == total


@pytest.mark.parametrize("base, seed, n", tiered([("planar", 0, 3), ("free", 1, 2)], 1))
def test_lagrange_on_the_floating_base_is_newton_euler_exactly(base, seed, n):
    """Hamel's equations (Lagrange in the base's body-frame velocities, `lagrange_dag`) against
    the customized recursion: τ, M, G, C·v equal at a rational point, the quaternion far from
    unit norm; Lagrange's C (Koszul's formula with the base velocities' brackets) equals
    the spatial reference's at random states."""
    robot = _robot(seed, base, n=n)
    ne, lag = derive(robot, cache=False), derive(robot, "lagrange", cache=False)
    assert (lag.q, lag.qd, lag.qdd) == (ne.q, ne.qd, ne.qdd)
    rng = random.Random(seed)
    q = {s: Fraction(rng.randint(-9, 9), rng.randint(1, 7)) for s in ne.q}
    trig = {s: rational_angle(rng) for s in _angles(ne)}
    v, a = ([Fraction(rng.randint(-9, 9), rng.randint(1, 7)) for _ in ne.qd] for _ in range(2))
    assert _evaluate(lag, q, trig, v, a) == _evaluate(ne, q, trig, v, a)
    angles = _angles(lag)
    inputs = [*lag.q, *(f(s) for s in angles for f in (sp.cos, sp.sin)), *lag.qd]
    C = compile_exact(lag.definitions, list(lag.named["C"]), inputs)
    state = np.random.default_rng(seed)
    for _ in range(3):
        x = robot.integrate(robot.neutral(), state.normal(size=robot.nv) * 2)
        w = state.normal(size=robot.nv)
        values = dict(zip(lag.q, map(float, x)))
        got = C(*x, *(f(values[s]) for s in angles for f in (math.cos, math.sin)), *w)
        want = ref.coriolis(robot, x, w)
        assert np.abs(np.array(got, dtype=float).reshape(want.shape) - want).max() < 1e-12 * (1 + np.abs(want).max())


def test_floating_christoffel_matrix_is_the_references():
    """Dynamics.C of a floating base: ½ ∂(C v)/∂v and the base velocities' brackets, which the
    symmetric part alone misses (C·v is the same either way, Ṁ − 2C skew only with them).  A
    planar base here (expanded, a free base's C takes seconds); the free base's generated C:
    tests/test_floating_codegen.py."""
    robot = _robot(1, "planar", n=2)
    dyn = derive(robot, cache=False)
    C = sp.lambdify([dyn.q, dyn.qd], dyn.C)
    half = sp.lambdify([dyn.q, dyn.qd], dyn.Cqd.jacobian(dyn.qd) / 2)
    rng = np.random.default_rng(0)
    for _ in range(3):
        q = robot.integrate(robot.neutral(), rng.normal(size=robot.nv))
        v = rng.normal(size=robot.nv)
        want = ref.coriolis(robot, q, v)
        assert np.abs(np.array(C(q, v), dtype=float) - want).max() < 1e-12 * (1 + np.abs(want).max())
        assert np.abs(np.array(half(q, v), dtype=float) - want).max() > 1e-3 * np.abs(want).max()


def test_named_constants_refuse_a_floating_base_by_name():
    """Its constants are laid out per link; a floating base's body comes first (refused, not misread)."""
    from symdyn.presentation.constants import constant_form

    robot = _robot(1, "free", n=2)
    with pytest.raises(NotImplementedError, match="named constants reads robots on a fixed base"):
        constant_form(derive(robot, cache=False))
