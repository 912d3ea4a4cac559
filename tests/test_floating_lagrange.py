"""Lagrange ≡ Newton–Euler on floating bases, exactly, through the equivalent chain (issue 35).

A floating base is the same system as a chain of massless carriages carrying the base body:
a planar base is prismatic x, prismatic y and a revolute yaw; a free base prismatic x, y, z
and revolutes about z, y, x (yaw, pitch, roll: R = Rz·Ry·Rx).  Lagrange's equations of that
chain are derived in its coordinate rates q̇c; the floating base's Newton–Euler in the base
body's own velocities v (Pinocchio's free-flyer).  With q̇c = J·v, power is the same in both:
τ_v = Jᵀ·τ_chain at (q̇c, q̈c) = (J v, J v̇ + J̇ v), and M_v = Jᵀ·M_chain·J.  Both sides are
evaluated exactly at rational points (every cos and sin rational, the quaternion of the
chain's Euler angles rational through their half angles), so the two derivations agree to
the last digit or not at all.
"""

from __future__ import annotations

import dataclasses
import random
from fractions import Fraction

import pytest
import sympy as sp

from symdyn.derivation.entry import derive
from symdyn.derivation.exact import compile_exact
from symdyn.model.random_robots import random_tree_robot
from symdyn.model.robot import IDENTITY, Link

from exact_eval import exact_value
from tests.conftest import tiered

CARRIAGES = {
    "planar": (("prismatic", (1, 0, 0)), ("prismatic", (0, 1, 0)), ("revolute", (0, 0, 1))),
    "free": (
        *(("prismatic", axis) for axis in ((1, 0, 0), (0, 1, 0), (0, 0, 1))),
        *(("revolute", axis) for axis in ((0, 0, 1), (0, 1, 0), (1, 0, 0))),
    ),
}


def _pair(robot):
    """(the floating robot, its equivalent chain): the base body on the last carriage, the
    links that hung on the base hung on it."""
    links = tuple(dataclasses.replace(link, offset=0) for link in robot.links)  # exact: no constant phases
    robot = dataclasses.replace(robot, links=links, base=IDENTITY, gravity=(0.3, -1.2, 9.81)).nofriction(all=True)
    carriages = CARRIAGES[robot.base_joint]
    k = len(carriages)
    body = robot.base_body
    base = [Link(joint=j, axis=axis, m=0) for j, axis in carriages[:-1]]
    base.append(dataclasses.replace(body, joint=carriages[-1][0], axis=carriages[-1][1]))
    links = [dataclasses.replace(link, parent=p + k) for link, p in zip(robot.links, robot.parents)]
    chain = dataclasses.replace(
        robot, name=robot.name + "_chain", links=tuple(base + links), base_joint=None, base_body=None
    )
    return robot, chain


def _rational(rng: random.Random, a: int = 9) -> Fraction:
    return Fraction(rng.randint(-a, a), rng.randint(1, 7))


def _half_angle(rng: random.Random):
    """(cos α/2, sin α/2, cos α, sin α) of a random angle α, all rational."""
    u = Fraction(rng.randint(-20, 20), rng.randint(1, 20))
    c, s = (1 - u * u) / (1 + u * u), 2 * u / (1 + u * u)
    return c, s, c * c - s * s, 2 * s * c


def _evaluate(dyn, q: list, trig: dict, v: list, a: list) -> tuple[sp.Matrix, sp.Matrix]:
    """τ and M of a derivation, exactly: q, v (or q̇), v̇ (or q̈) Fractions, and every sine
    and cosine (of sums of angles too, as expanded Lagrange writes them) from `trig`,
    {angle symbol: (cos, sin)}."""
    named = "M" in dyn.named  # else expanded (up to six joints)
    outs = [*dyn.named["tau"], *dyn.named["M"]] if named else [*dyn.term("tau"), *dyn.term("M")]
    definitions = dyn.definitions if named else ()
    atoms = set()
    for e in [e for _, e in definitions] + outs:
        atoms |= sp.sympify(e).atoms(sp.sin, sp.cos)
    atoms = sorted(atoms, key=sp.default_sort_key)
    evaluate = compile_exact(definitions, outs, [*atoms, *dyn.q, *dyn.qd, *dyn.qdd])
    angles = list(trig)
    values = [Fraction(str(exact_value(x, angles, [trig[s] for s in angles], {}))) for x in atoms]
    flat = evaluate(*values, *q, *v, *a)
    nv = len(dyn.qd)
    return sp.Matrix(flat[:nv]), sp.Matrix(nv, nv, flat[nv:])


def _rotation(kind: str, trig: list) -> sp.Matrix:
    """R = Rz(ψ)·Ry(θ)·Rx(φ) (free) or Rz(ψ) (planar) from exact (cos, sin) pairs."""

    def rot(axis, c, s):
        R = sp.eye(3)
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
        return R

    if kind == "planar":
        return rot(2, *trig[0])
    return rot(2, *trig[0]) * rot(1, *trig[1]) * rot(0, *trig[2])


# the free bases (free-2-2 the slowest, 8 s): make test-all
@pytest.mark.parametrize(
    "base, seed, n", tiered([("planar", 1, 3), ("planar", 4, 2), ("free", 7, 1), ("free", 2, 2)], 2)
)
def test_lagrange_of_the_equivalent_chain_is_newton_euler_on_the_floating_base(base, seed, n):
    robot, chain = _pair(random_tree_robot(seed, n=n, base_joint=base))
    ne, lag = derive(robot, "newton-euler", cache=False), derive(chain, "lagrange", cache=False)
    k, nv = len(CARRIAGES[base]), robot.nv
    turns = 1 if base == "planar" else 3
    rng = random.Random(seed)
    # the chain's state: position, Euler angles (exact half angles), joints
    halves = [_half_angle(rng) for _ in range(turns)]
    trig_euler = [(h[2], h[3]) for h in halves]
    joint_trig = [((1 - t * t) / (1 + t * t), 2 * t / (1 + t * t)) for t in (_rational(rng) for _ in range(robot.n))]
    pos = [_rational(rng) for _ in range(k - turns)]
    joints = [_rational(rng) for _ in range(robot.n)]  # a prismatic joint's q itself
    qd_c, qdd_c = ([_rational(rng) for _ in range(nv)] for _ in range(2))
    # the chain's Lagrange τ and M
    q_c = pos + [0] * turns + joints
    trig_c = dict(zip(lag.q[k - turns :], trig_euler + joint_trig))
    tau_c, M_c = _evaluate(lag, q_c, trig_c, qd_c, qdd_c)
    # the map q̇c = J v and its rate, exact
    R = _rotation(base, trig_euler)
    if base == "planar":
        R = R[:2, :2]
        E, Edot = sp.eye(1), sp.zeros(1, 1)  # ω = ψ̇
    else:
        (cz, sz), (cy, sy), (cx, sx) = trig_euler
        rates = qd_c[3:6]  # ψ̇, θ̇, φ̇: ω_body = Rxᵀ Ryᵀ ez ψ̇ + Rxᵀ ey θ̇ + ex φ̇
        E = sp.Matrix([[-sy, 0, 1], [sx * cy, cx, 0], [cx * cy, -sx, 0]])
        dE_dtheta = sp.Matrix([[-cy, 0, 0], [-sx * sy, 0, 0], [-cx * sy, 0, 0]])
        dE_dphi = sp.Matrix([[0, 0, 0], [cx * cy, -sx, 0], [-sx * cy, -cx, 0]])
        Edot = dE_dtheta * rates[1] + dE_dphi * rates[2]
    lin, ang = slice(0, k - turns), slice(k - turns, k)
    p_dot, e_dot = sp.Matrix(qd_c[lin]), sp.Matrix(qd_c[ang])
    p_ddot, e_ddot = sp.Matrix(qdd_c[lin]), sp.Matrix(qdd_c[ang])
    omega = E * e_dot
    v_lin = R.T * p_dot
    if base == "planar":
        w = omega[0]
        v_lin_dot = R.T * p_ddot + sp.Matrix([w * v_lin[1], -w * v_lin[0]])  # −ω × v in the plane
    else:
        v_lin_dot = R.T * p_ddot - omega.cross(v_lin)
    omega_dot = E * e_ddot + Edot * e_dot
    v = [*v_lin, *omega, *qd_c[k:]]
    vdot = [*v_lin_dot, *omega_dot, *qdd_c[k:]]
    # the floating base's Newton–Euler at the same state
    if base == "planar":
        q_f, trig_f = pos + [0] + joints, dict(zip(ne.q[2:], [trig_euler[0], *joint_trig]))
    else:  # the quaternion of Rz(ψ)·Ry(θ)·Rx(φ), rational through the half angles
        (c1, s1, *_), (c2, s2, *_), (c3, s3, *_) = halves
        w = c1 * c2 * c3 + s1 * s2 * s3
        x = c1 * c2 * s3 - s1 * s2 * c3
        y = c1 * s2 * c3 + s1 * c2 * s3
        z = s1 * c2 * c3 - c1 * s2 * s3
        q_f, trig_f = pos + [x, y, z, w] + joints, dict(zip(ne.q[7:], joint_trig))
    tau_f, M_f = _evaluate(ne, q_f, trig_f, v, vdot)
    # τ_v = Jᵀ τ_chain, M_v = Jᵀ M_chain J with J = blockdiag(R, E⁻¹, 1)
    J = sp.zeros(nv, nv)
    m = k - turns
    J[:m, :m] = R
    J[m:k, m:k] = E.inv()
    J[k:, k:] = sp.eye(nv - k)
    assert tau_f == J.T * tau_c
    assert M_f == J.T * M_c * J
