"""The regressor and base parameters of floating-base trees (issue 35); derive(regroup=True) on them.

π is the base body's ten parameters (XX0 … M0) then each link's fourteen; Y has nv rows, the
base joint's first.  Checked exactly, through the named definitions (the expanded trees of a
floating base run to 10⁶ operations), at rational points: Y·π = τ; the base parameters have as
many independent columns as the symbolic regressor's rank at fresh points and Y·β = Y·π; the
regrouped derivation's τ, M, G, C·v equal the plain one's.  On a free base the rank analysis
keeps all ten of the body's parameters and regroups nothing beyond Khalil's rules; on a planar
base only ZZ0, MX0, MY0, M0 of the body are moved.
"""

from __future__ import annotations

import dataclasses
import random
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp
from sympy.polys.domains import GF, QQ
from sympy.polys.matrices import DomainMatrix

import symdyn.reference as ref
from symdyn.derivation.entry import derive
from symdyn.derivation.exact import compile_exact, rational_angle
from symdyn.derivation.regressor import (
    BODY,
    FRICTION,
    INERTIAL,
    base_parameters,
    parameter_symbols,
    parameter_values,
    regressor,
    regrouped_base_body,
    regrouped_inertias,
)
from symdyn import models
from symdyn.model import Link
from symdyn.model.random_robots import random_tree_robot
from tests.conftest import tiered

PER = len(INERTIAL) + len(FRICTION)
TERMS = ("tau", "M", "G", "Cqd")


def _robot(seed: int, base: str, n: int = 4):
    """A random tree on `base`, gravity along every axis, no friction (its sgn q̇ stays out of the
    exact evaluation; its columns are q̇ⱼ, sgn q̇ⱼ, sgn² q̇ⱼ as on a fixed base)."""
    robot = random_tree_robot(seed, n=n, base_joint=base)
    return dataclasses.replace(robot, gravity=(0.3, -1.2, 9.81)).nofriction(all=True)


def _case(base: str, seed, n: int):
    """A random tree (`_robot`), or seed "puma": the Puma 560 (modified DH, friction kept) on `base`
    carrying a body off its axes: a chain whose first axis is the planar base's yaw axis."""
    if seed != "puma":
        return _robot(seed, base, n=n)
    body = Link(m=2.0, r=(0.1, 0.0, -0.05), I=((0.1, 0.01, 0), (0.01, 0.2, 0), (0, 0, 0.3)))
    arm = models.load("puma560").to_modified()
    return dataclasses.replace(arm, base_joint=base, base_body=body, poses={}, gravity=(0.3, -1.2, 9.81))


def _inertial(robot) -> list[int]:
    """π's inertial slots: the base body's ten, then XX … IA of every link."""
    body = len(BODY)
    return list(range(body)) + [body + j * PER + i for j in range(robot.n) for i in range(len(INERTIAL))]


def _angles(q) -> list:
    """The coordinates that enter through cos and sin: the joints' and a planar base's yaw."""
    return [s for s in q if not s.name.startswith("base_") or s.name == "base_yaw"]


def _small_angle(rng: random.Random) -> tuple[Fraction, Fraction]:
    """cos and sin of a random angle with small rational values (short digits: fast exact ranks)."""
    t = Fraction(rng.randint(-5, 5), rng.randint(1, 4))
    return (1 - t * t) / (1 + t * t), 2 * t / (1 + t * t)


def _point(q, qd, rng: random.Random, small: bool = False) -> tuple:
    """Rational values of q (a quaternion of any norm), cos and sin of the angles, v and v̇
    (`small`: short numbers, for the exact ranks)."""
    den = 3 if small else 7
    values = {s: Fraction(rng.randint(-9, 9), rng.randint(1, den)) for s in q}
    if "base_qw" in {s.name for s in q}:
        values[q[6]] = Fraction(rng.randint(1, 9), rng.randint(1, den))  # never the zero quaternion
    trig = {s: (_small_angle if small else rational_angle)(rng) for s in _angles(q)}
    v, a = ([Fraction(rng.randint(-30, 30), rng.randint(1, den)) for _ in qd] for _ in range(2))
    return values, trig, v, a


def _evaluator(definitions, outputs, q, qd, qdd):
    """Exact evaluation of `outputs` at a `_point`."""
    angles = _angles(q)
    inputs = [*q, *(f(s) for s in angles for f in (sp.cos, sp.sin)), *qd, *qdd]
    run = compile_exact(definitions, outputs, inputs)
    return lambda values, trig, v, a: run(*(values[s] for s in q), *(x for s in angles for x in trig[s]), *v, *a)


def _exact_Y(robot, points: int, seed: int) -> DomainMatrix:
    """The symbolic regressor's inertial columns at rational points (rows: nv per point), over ℚ."""
    reg = regressor(robot)
    cols = _inertial(robot)
    nv = robot.nv
    run = _evaluator(
        reg.tape.defs.items(), [reg.columns[k][i] for k in cols for i in range(nv)], reg.q, reg.qd, reg.qdd
    )
    rng, rows = random.Random(seed), []
    for _ in range(points):
        flat = run(*_point(reg.q, reg.qd, rng, small=True))
        rows += [
            [QQ(flat[c * nv + i].numerator, flat[c * nv + i].denominator) for c in range(len(cols))] for i in range(nv)
        ]
    return DomainMatrix(rows, (len(rows), len(cols)), QQ)


# --------------------------------------------------------------------------- the regressor


@pytest.mark.parametrize("base", tiered(["planar", "free"], 1))
def test_regressor_times_standard_parameters_is_tau(base):
    """Y·π = τ of the Newton–Euler derivation exactly (base rows included), and of the numeric
    reference at float states; π has the body's ten parameters first."""
    robot = _robot(4, base, n=3)
    reg = regressor(robot)
    assert reg.params == parameter_symbols(robot.n, True) and str(reg.params[9]) == "M0"
    assert len(reg.columns) == len(BODY) + PER * robot.n and {len(c) for c in reg.columns} == {robot.nv}
    pi = [sp.Rational(x) for x in parameter_values(robot)]
    Ypi = [sp.Add(*(p * col[i] for p, col in zip(pi, reg.columns) if p != 0)) for i in range(robot.nv)]
    dyn = derive(robot, cache=False)
    assert (dyn.q, dyn.qd, dyn.qdd) == (reg.q, reg.qd, reg.qdd)
    defs = list(dyn.definitions) + list(reg.tape.defs.items())
    run = _evaluator(defs, Ypi + list(dyn.named["tau"]), reg.q, reg.qd, reg.qdd)
    rng = random.Random(1)
    for _ in range(3):
        flat = run(*_point(reg.q, reg.qd, rng))
        assert flat[: robot.nv] == flat[robot.nv :]
    # against the reference at a float state: the same inputs, doubles
    rng_np = np.random.default_rng(0)
    q = robot.integrate(robot.neutral(), rng_np.normal(size=robot.nv))
    v, a = rng_np.normal(size=robot.nv), rng_np.normal(size=robot.nv)
    values = dict(zip(reg.q, map(float, q)))
    trig = {s: (np.cos(values[s]), np.sin(values[s])) for s in _angles(reg.q)}
    cols = _inertial(robot)  # the friction columns (sgn q̇) have π = 0 here
    outputs = [reg.columns[k][i] for k in cols for i in range(robot.nv)]
    Y = np.array(_evaluator(reg.tape.defs.items(), outputs, reg.q, reg.qd, reg.qdd)(values, trig, v, a), dtype=float)
    Y = Y.reshape(len(cols), robot.nv)
    want = ref.rne(robot, q, v, a)
    assert np.abs(Y.T @ np.array([pi[k] for k in cols], dtype=float) - want).max() < 1e-10 * (1 + np.abs(want).max())


# --------------------------------------------------------------------------- base parameters


def _revolute(robot) -> list[bool]:
    from symdyn.derivation.base_parameters.sampled import frames

    return [f.revolute for f in frames(robot)]


@pytest.mark.parametrize(
    ("base", "seed", "n", "count"),
    [
        ("free", 8, 3, 34),
        ("planar", 11, 3, 25),
        pytest.param("free", 3, 4, 39, marks=pytest.mark.slow),
        pytest.param("free", "puma", 6, 58, marks=pytest.mark.slow),
        pytest.param("planar", 3, 4, 32, marks=pytest.mark.slow),
        pytest.param("planar", "puma", 6, 47, marks=pytest.mark.slow),
        pytest.param("free", 6, 5, 50, marks=pytest.mark.slow),
        pytest.param("planar", 6, 5, 43, marks=pytest.mark.slow),
    ],
)
def test_base_parameters_of_floating_trees_are_exact(base, seed, n, count):
    """The rules hand what a joint on the base cannot move to the base body, the rank analysis does
    the rest: as many independent columns as the symbolic regressor's rank at fresh rational points
    (a quaternion of any norm), and Y·β_regrouped = Y·π exactly.  A free base's body keeps all ten
    parameters and nothing regroups beyond the rules (8 per revolute link, 5 per prismatic one); a
    planar base's body keeps ZZ0, MX0, MY0, M0, and the links on it may lose more than the rules
    take (the Puma's first axis is the yaw axis: `count` inertial base parameters, 10 + 6·8 on a
    free base)."""
    robot = _case(base, seed, n)
    bp = base_parameters(robot)
    cols = _inertial(robot)
    Y = _exact_Y(robot, 40 // robot.nv + 3, seed=100 + (7 if seed == "puma" else seed))
    kept = [c for c, k in enumerate(cols) if k in bp.independent]
    assert len(kept) == count
    Yb = Y.extract(list(range(Y.shape[0])), kept)
    # rank(Y) ≤ |kept|: every column is the regrouping's combination of the kept ones, Y = Y_b·P over ℚ
    P = [[0] * len(cols) for _ in kept]
    position = {bp.params[k]: c for c, k in enumerate(cols)}
    for r, (k, expr) in enumerate((k, e) for k, e in zip(bp.independent, bp.expressions) if k in set(cols)):
        for symbol, coefficient in expr.as_coefficients_dict().items():
            P[r][position[symbol]] = QQ(int(coefficient.p), int(coefficient.q))
    assert (Yb * DomainMatrix(P, (len(kept), len(cols)), QQ).convert_to(QQ)).to_Matrix() == Y.to_Matrix()
    # rank(Y) ≥ |kept|: Y_b has full column rank modulo a prime (a non-zero minor mod p is non-zero over ℚ)
    prime = 2**61 - 1
    field = GF(prime)
    modular = [[field(int(x.numerator) * pow(int(x.denominator), -1, prime)) for x in row] for row in Yb.to_list()]
    assert DomainMatrix(modular, Yb.shape, field).rank() == len(kept)
    values = parameter_values(robot)
    pi = sp.Matrix([values[k] for k in cols]).to_DM().convert_to(Y.domain)
    beta = sp.Matrix([bp.regrouped[k] for k in cols]).to_DM().convert_to(Y.domain)
    assert (Y * pi).to_Matrix() == (Y * beta).to_Matrix()
    body = [str(bp.params[k]) for k in bp.independent if k < len(BODY)]
    if base == "free":
        assert body == [f"{name}0" for name in BODY]
        assert len(kept) == len(BODY) + sum(8 if r else 5 for r in _revolute(robot))
    else:
        assert body == ["ZZ0", "MX0", "MY0", "M0"]
    # the friction parameters stand as they are, after the body's and in each link's slots
    friction = [k for k in bp.independent if k >= len(BODY) and (k - len(BODY)) % PER >= len(INERTIAL)]
    assert len(friction) == len(FRICTION) * robot.n


@pytest.mark.parametrize(("base", "seed"), tiered([("planar", 2), ("free", 2), ("planar", "puma")], 1))
def test_regrouped_derivation_equals_the_plain_one_exactly(base, seed):
    """derive(regroup=True) on a floating base: the base body's regrouped parameters with the
    links', the same τ, M, G, C·v at rational points (base rows included), no more operations."""
    robot = _case(base, seed, 4).nofriction(all=True)
    plain, grouped = derive(robot, cache=False), derive(robot, regroup=True, cache=False)
    assert grouped.stats["regrouped"] and (grouped.q, grouped.qd) == (plain.q, plain.qd)
    rng = random.Random(5)
    runs = [
        _evaluator(dyn.definitions, [e for t in TERMS for e in dyn.named[t]], dyn.q, dyn.qd, dyn.qdd)
        for dyn in (plain, grouped)
    ]
    for _ in range(3):
        point = _point(plain.q, plain.qd, rng)
        assert runs[0](*point) == runs[1](*point)
    assert len(grouped.definitions) <= len(plain.definitions)


def test_regrouped_base_body_needs_a_floating_base_and_its_own_base_parameters():
    fixed = random_tree_robot(3, n=3)
    with pytest.raises(ValueError, match="fixed base"):
        regrouped_base_body(fixed, base_parameters(fixed))
    floating = _robot(3, "free", n=3)
    with pytest.raises(ValueError, match="do not fit"):
        regrouped_inertias(floating, base_parameters(fixed))
    assert len(regrouped_inertias(floating, base_parameters(floating))) == floating.n


# --------------------------------------------------------------------------- identification


def test_a_fixed_base_tree_is_identified_from_noise_free_data():
    """symdyn.identify on a tree (fixed base, two branches): noise-free data simulated by the
    reference from a perturbed tree give its base parameters and torques back to rounding."""
    from symdyn.identify import fit, simulate
    from symdyn.identify.estimate import regressor_rows
    from symdyn.identify.parameters import base_map
    from symdyn.identify.simulate import fourier

    robot = random_tree_robot(13, n=4)
    assert not robot.is_chain and robot.parents.count(0) == 2
    traj = fourier(robot, period=5, harmonics=5, rate=40, seed=1, rest=0.5)
    data = simulate(robot, traj, perturb=0.2, seed=3)
    res = fit(robot, data, consistent=False, target="numpy")
    true = base_map(res.prior).values(data.truth)
    Y = regressor_rows(res.prior, data.q, data.qd, data.qdd, target="numpy").reshape(-1, len(true))
    size = np.linalg.norm(data.tau) / np.linalg.norm(Y, axis=0)  # what a parameter needs to show in τ
    assert (np.abs(res.base.values - true) / np.maximum(np.abs(true), size)).max() < 1e-8
    assert np.abs(res.predict(data.q, data.qd, data.qdd) - data.tau).max() < 1e-8 * np.abs(data.tau).max()
