"""Lagrange (energy) derivation of M, C, G in exact trigonometric-polynomial arithmetic.

The derive stage, route 1 of 2 (Newton–Euler is the independent check):
kinetic energy ½ q̇ᵀM q̇ with M = Σ_i m_i J_viᵀJ_vi + J_ωiᵀ I_i J_ωi (+ G²·Jm on
the diagonal), potential energy V = Σ_i m_i a_up·p_ci, G = ∂V/∂q, and C from
the Christoffel symbols of M.  Every quantity is a `symdyn.derivation.trigpoly.TrigPoly`
(products are sums of angles, derivatives exact); sympy appears only at the
end.  The Jacobians are taken in each link's own frame {i}, where the axis
and origin of joint j depend on q_{j+1}…q_i only, so no term in q_1…q_j is
ever formed and cancelled.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field

import sympy as sp
from sympy.polys.domains import QQ

from .dynamics import Dynamics, friction_expr, rotor_inertia
from ..model import Robot
from .symbols import exact, joint_symbols
from .trigpoly import TrigPoly, TrigSpace, constant_cos_sin, lincomb, summation, to_qq

__all__ = ["space", "TrigDynamics", "trig_dynamics", "christoffel", "equations", "derive"]


# --------------------------------------------------------------------------- constants


def _angle_constant(x, what: str) -> sp.Expr:
    """A constant angle for printing: k·π/m when a float is one (m ≤ 12), else exact."""
    if isinstance(x, sp.Basic):
        if x.free_symbols:
            raise ValueError(
                f"{what} = {x} is symbolic: the Lagrange route needs constant angles "
                f"(substitute a value with robot.subs)"
            )
        return x
    for m in range(1, 13):
        k = round(x * m / math.pi)
        if abs(x - k * math.pi / m) < 1e-12:
            return sp.pi * k / m
    return exact(x)


def _twist(x, what: str) -> tuple:
    """cos, sin of a constant angle in QQ (exact for multiples of π/2)."""
    if isinstance(x, sp.Basic) and x.free_symbols:
        raise ValueError(
            f"{what} = {x} is symbolic: the Lagrange route needs constant angles (substitute a value with robot.subs)"
        )
    return constant_cos_sin(x)


def space(robot: Robot) -> TrigSpace:
    """The trig space of a robot: angles q_i (+ offset_i) of the revolute joints; generators
    the robot's symbols (by name), the prismatic q_i, then qd1…qdn, qdd1…qddn."""
    q, qd, qdd = joint_symbols(robot.n)
    angles, offsets, prismatic = [], [], []
    for i, link in enumerate(robot.links):
        if link.is_revolute:
            angles.append(q[i])
            offsets.append(_angle_constant(link.offset, f"offset of joint {i + 1}"))
        else:
            prismatic.append(q[i])
    params = sorted(robot.free_symbols, key=str)
    clash = set(params) & set(q + qd + qdd)
    if clash:
        raise ValueError(f"robot parameters {sorted(map(str, clash))} clash with the joint symbols")
    return TrigSpace(angles, params + prismatic + list(qd) + list(qdd), offsets)


# --------------------------------------------------------------------------- vectors and frames


def _dot(u, v, S: TrigSpace) -> TrigPoly:
    """u·v of two 3-vectors of TrigPolys (zero entries skipped)."""
    return summation([a * b for a, b in zip(u, v) if a and b], S)


def _cross(u, v, S: TrigSpace) -> list:
    def d(a, b, c, e):
        x = u[a] * v[b] if u[a] and v[b] else S.zero
        y = u[c] * v[e] if u[c] and v[e] else S.zero
        return x - y

    return [d(1, 2, 2, 1), d(2, 0, 0, 2), d(0, 1, 1, 0)]


def _rot_vec(R, v, S: TrigSpace) -> list:
    """R·v for a constant rotation R (3×3 QQ) and a 3-vector of TrigPolys."""
    return [lincomb(zip(row, v), S) for row in R]


def _rot_t(R) -> list:
    return [[R[j][i] for j in range(3)] for i in range(3)]


def _rot_mul(A, B) -> list:
    return [[sum((A[i][k] * B[k][j] for k in range(3)), QQ(0)) for j in range(3)] for i in range(3)]


def _rx(alpha, what: str) -> list:
    c, s = _twist(alpha, what)
    o, z = QQ(1), QQ(0)
    return [[o, z, z], [z, c, -s], [z, s, c]]


@dataclass(frozen=True)
class _Link:
    """One link, ^{i-1}T_i = pre · Rz(θ)Tz(d) · post, with constant rotations in QQ
    and translations, mass, COM and inertia as (constant) TrigPolys."""

    pre_R: list
    pre_p: list
    post_R: list
    post_p: list
    cos: TrigPoly  # cos θ, sin θ (an angle, or constants for a prismatic joint)
    sin: TrigPoly
    d: TrigPoly  # a constant, or q_i + offset for a prismatic joint
    revolute: bool
    m: TrigPoly
    r: list
    I: list
    parent: int = -1  # the link it hangs on (-1: the base)


def _links(robot: Robot, S: TrigSpace) -> list[_Link]:
    q = joint_symbols(robot.n)[0]
    const = S.const
    eye = [[QQ(int(a == b)) for b in range(3)] for a in range(3)]
    if robot.convention == "general":
        robot = robot.to_modified()  # every axis along its link's z, exact placements
    out, a_idx = [], 0
    for i, (link, parent) in enumerate(zip(robot.links, robot.parents)):
        Rx = _rx(link.alpha, f"alpha of link {i + 1}")
        zero3 = [S.zero] * 3
        ax = [const(link.a), S.zero, S.zero]
        if robot.convention == "general":  # origin · Rz(q) or origin · Tz(q)
            T = link.origin
            pre_R, pre_p = [[to_qq(x) for x in row[:3]] for row in T[:3]], [const(row[3]) for row in T[:3]]
            post_R, post_p = eye, zero3
        elif robot.convention == "standard":
            pre_R, pre_p, post_R, post_p = eye, zero3, Rx, ax
        else:
            pre_R, pre_p, post_R, post_p = Rx, ax, eye, zero3
        if link.is_revolute:
            c, s = S.cos(a_idx), S.sin(a_idx)
            a_idx += 1
            d = const(link.d)
        else:
            ct, st = _twist(link.theta, f"theta of prismatic joint {i + 1}")
            c, s = const(ct), const(st)
            d = S.gen(q[i]) + const(link.offset)
        out.append(
            _Link(
                pre_R,
                pre_p,
                post_R,
                post_p,
                c,
                s,
                d,
                link.is_revolute,
                const(link.m),
                [const(x) for x in link.r],
                _symmetric(link.I, const),
                parent,
            )
        )
    return out


def _symmetric(I, const) -> list:
    """The inertia's upper triangle, mirrored: symmetric to rounding is read as exactly symmetric."""
    return [[const(I[min(a, b)][max(a, b)]) for b in range(3)] for a in range(3)]


def _back(links: list[_Link], j: int, S: TrigSpace) -> tuple:
    """K_j = pre_j⁻¹ · post_p⁻¹ (p: the link j hangs on) as (rotation in QQ, translation TrigPolys)."""
    parent = links[links[j].parent]
    Rpre_t, Rpost_t = _rot_t(links[j].pre_R), _rot_t(parent.post_R)
    post_inv_p = [-x for x in _rot_vec(Rpost_t, parent.post_p, S)]
    p = [x - y for x, y in zip(_rot_vec(Rpre_t, post_inv_p, S), _rot_vec(Rpre_t, links[j].pre_p, S))]
    return _rot_mul(Rpre_t, Rpost_t), p


# --------------------------------------------------------------------------- M and V


def _body_jacobians(links: list[_Link], backs: list, i: int, S: TrigSpace) -> dict:
    """{j: (v_j, ω_j)} for link i and the links it hangs from: COM-velocity and
    angular-velocity columns of link i in frame {i}, where the axis and origin of
    joint j depend on the joints between j and i only (a tree's other branches never enter).

    X_j = ^iT_(joint frame j) runs backwards: X_i = post_i⁻¹,
    X_p = X_j · Tz(−d_j) · Rz(−θ_j) · pre_j⁻¹ · post_p⁻¹ with p the parent of j.
    """
    L = links
    Rt = _rot_t(L[i].post_R)
    R = [[S.const(x) for x in row] for row in Rt]
    p = [-x for x in _rot_vec(Rt, L[i].post_p, S)]
    r = L[i].r
    cols = {}
    j = i
    while True:
        z = [R[a][2] for a in range(3)]
        if L[j].revolute:
            cols[j] = (_cross(z, [r[a] - p[a] for a in range(3)], S), z)
        else:
            cols[j] = (z, None)
        if L[j].parent < 0:
            break
        p = [p[a] - L[j].d * R[a][2] for a in range(3)]
        c, s = L[j].cos, L[j].sin
        R = [[c * R[a][0] - s * R[a][1], s * R[a][0] + c * R[a][1], R[a][2]] for a in range(3)]
        KR, Kp = backs[j]
        p = [p[a] + _dot(R[a], Kp, S) for a in range(3)]
        R = [[lincomb(((KR[k][b], R[a][k]) for k in range(3)), S) for b in range(3)] for a in range(3)]
        j = L[j].parent
    return cols


def _inertia(robot: Robot, links: list[_Link], S: TrigSpace) -> list:
    """M (n×n nested lists of TrigPoly), Σ_i m_i J_viᵀJ_vi + J_ωiᵀ I_i J_ωi + G²·Jm on the diagonal;
    on a tree, the entries of joints on different branches are sums of nothing (exactly 0)."""
    n = robot.n
    backs = [None if links[j].parent < 0 else _back(links, j, S) for j in range(n)]
    acc = [[[] for _ in range(n)] for _ in range(n)]
    for i in range(n):
        L = links[i]
        if not L.m and not any(x for row in L.I for x in row):
            continue
        cols = _body_jacobians(links, backs, i, S)
        path = sorted(cols)
        Iw = {j: None if w is None else [_dot(row, w, S) for row in L.I] for j, (_, w) in cols.items()}
        for x, j in enumerate(path):
            vj, wj = cols[j]
            for k in path[x:]:
                vk = cols[k][0]
                if L.m:
                    acc[j][k].append(L.m * _dot(vj, vk, S))
                if wj is not None and Iw[k] is not None:
                    acc[j][k].append(_dot(wj, Iw[k], S))
    M = [[None] * n for _ in range(n)]
    for j, rotor in enumerate(rotor_inertia(robot)):
        acc[j][j].append(S.const(rotor))
        for k in range(j, n):
            M[j][k] = M[k][j] = summation(acc[j][k], S)
    return M


def _potential(robot: Robot, links: list[_Link], S: TrigSpace) -> TrigPoly:
    """V = Σ m_i a·p_ci, a = R_baseᵀ·gravity (the base's upward acceleration in frame {0}).

    Forward recursion on b_i = ^0R_iᵀ a and h_i = a·^0p_i (only dot products with a are formed),
    each link's from its parent's.
    """
    base_R = [[S.const(robot.base[a][b]) for b in range(3)] for a in range(3)]
    g = [S.const(x) for x in robot.gravity]
    b0 = [_dot([base_R[k][a] for k in range(3)], g, S) for a in range(3)]
    state, terms = [], []
    for L in links:
        b, h = (b0, S.zero) if L.parent < 0 else state[L.parent]
        u = _rot_vec(_rot_t(L.pre_R), b, S)
        w = [L.cos * u[0] + L.sin * u[1], L.cos * u[1] - L.sin * u[0], u[2]]
        h = h + _dot(b, L.pre_p, S) + _dot(w, L.post_p, S) + L.d * u[2]
        b = _rot_vec(_rot_t(L.post_R), w, S)
        state.append((b, h))
        if L.m:
            terms.append(L.m * (h + _dot(b, L.r, S)))
    return summation(terms, S)


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class TrigDynamics:
    """M, Γ, C, G and τ (without friction) of one robot as trig polynomials.

    M[j][k]; Gamma[k][i][j] = ½(∂M_kj/∂q_i + ∂M_ki/∂q_j − ∂M_ij/∂q_k);
    C[k][j] = Σ_i Γ_kij q̇_i; G[k] = ∂V/∂q_k; tau[k] = Σ_j M_kj q̈_j + C_kj q̇_j + G_k.
    """

    space: TrigSpace
    q: tuple
    qd: tuple
    qdd: tuple
    M: tuple
    Gamma: tuple
    C: tuple
    G: tuple
    V: TrigPoly
    tau: tuple
    stats: dict = field(default_factory=dict, compare=False)

    def Mdot(self) -> tuple:
        """Ṁ = Σ_i ∂M/∂q_i q̇_i."""
        S, n = self.space, len(self.q)
        qd = [S.gen(x) for x in self.qd]
        return tuple(
            tuple(summation([self.M[j][k].diff(self.q[i]) * qd[i] for i in range(n)], S) for k in range(n))
            for j in range(n)
        )


def _christoffel(M: list, q: tuple, S: TrigSpace) -> list:
    n = len(q)
    dM = [[[M[a][b].diff(q[i]) for b in range(n)] for a in range(n)] for i in range(n)]  # dM[i][a][b]
    half = S.const(sp.Rational(1, 2))
    Gam = [[[None] * n for _ in range(n)] for _ in range(n)]
    for k in range(n):
        for i in range(n):
            for j in range(i, n):
                g = half * summation([dM[i][k][j], dM[j][k][i], -dM[k][i][j]], S)
                Gam[k][i][j] = Gam[k][j][i] = g
    return Gam


@functools.lru_cache(maxsize=16)
def trig_dynamics(robot: Robot) -> TrigDynamics:
    """M, Γ, C, G, τ of `robot` as exact trig polynomials by the energy method (cached per robot)."""
    t0 = time.perf_counter()
    S = space(robot)
    q, qd, qdd = joint_symbols(robot.n)
    n = robot.n
    links = _links(robot, S)
    M = _inertia(robot, links, S)
    t1 = time.perf_counter()
    V = _potential(robot, links, S)
    G = [V.diff(x) for x in q]
    t2 = time.perf_counter()
    Gam = _christoffel(M, q, S)
    qd_ = [S.gen(x) for x in qd]
    qdd_ = [S.gen(x) for x in qdd]
    C = [[summation([Gam[k][i][j] * qd_[i] for i in range(n)], S) for j in range(n)] for k in range(n)]
    t3 = time.perf_counter()
    tau = [
        summation([M[k][j] * qdd_[j] for j in range(n)] + [C[k][j] * qd_[j] for j in range(n)] + [G[k]], S)
        for k in range(n)
    ]
    t4 = time.perf_counter()
    stats = {
        "time_M": t1 - t0,
        "time_G": t2 - t1,
        "time_Gamma_C": t3 - t2,
        "time_tau": t4 - t3,
        "terms_M": sum(x.nterms for row in M for x in row),
        "terms_G": sum(x.nterms for x in G),
        "terms_Gamma": sum(x.nterms for a in Gam for b in a for x in b),
    }
    tup = lambda rows: tuple(tuple(r) for r in rows)  # noqa: E731
    return TrigDynamics(S, q, qd, qdd, tup(M), tuple(tup(a) for a in Gam), tup(C), tuple(G), V, tuple(tau), stats)


def christoffel(robot: Robot) -> sp.ImmutableDenseNDimArray:
    """Christoffel symbols Γ[k, i, j] (n×n×n sympy array), indexed as `reference.christoffel`."""
    T = trig_dynamics(robot)
    n = robot.n
    return sp.ImmutableDenseNDimArray(
        [[[T.Gamma[k][i][j].to_expr() for j in range(n)] for i in range(n)] for k in range(n)], (n, n, n)
    )


def _matrix(rows) -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix([[x.to_expr() for x in row] for row in rows])


def equations(robot: Robot) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix, sp.ImmutableMatrix]:
    """(M n×n, C n×n Christoffel matrix, G n×1) in the symbols of `joint_symbols(n)`."""
    T = trig_dynamics(robot)
    n = robot.n
    Mu = [[T.M[j][k].to_expr() if k >= j else None for k in range(n)] for j in range(n)]
    M = sp.ImmutableMatrix(n, n, lambda j, k: Mu[min(j, k)][max(j, k)])
    return M, _matrix(T.C), sp.ImmutableMatrix([g.to_expr() for g in T.G])


def derive(robot: Robot) -> Dynamics:
    """The Lagrange `Dynamics`: M, C, G, F and τ = M q̈ + C q̇ + F + G."""
    t0 = time.perf_counter()
    T = trig_dynamics(robot)
    M, C, G = equations(robot)
    F = friction_expr(robot, T.qd)
    tau = sp.ImmutableMatrix([t.to_expr() + f for t, f in zip(T.tau, F)])
    definitions, C_named = _christoffel_program(T, robot.n)
    stats = dict(T.stats, time_total=time.perf_counter() - t0)
    # τ and C·q̇ through the named Christoffel symbols: the expanded τ of a generic
    # 7-joint arm is a ~10⁵-operation tree that code generation cannot afford to CSE
    Cqd = sp.ImmutableMatrix(C_named * sp.Matrix(T.qd))
    named = {"C": C_named, "Cqd": Cqd, "tau": sp.ImmutableMatrix(M * sp.Matrix(T.qdd) + Cqd + G + F)}
    return Dynamics(
        robot=robot,
        method="lagrange",
        q=T.q,
        qd=T.qd,
        qdd=T.qdd,
        F=F,
        definitions=definitions,
        named=named,
        stats=stats,
        expanded={"M": M, "C": C, "G": G, "tau": tau},
    )


def _christoffel_program(T: "TrigDynamics", n: int) -> tuple[tuple, sp.ImmutableMatrix]:
    """C written in named Christoffel symbols, C_kj = Σ_i Γ_kij q̇_i, each Γ_kij
    (= Γ_kji) named once: a third fewer operations than C's entries expanded."""
    definitions, names = [], {}
    for k in range(n):
        for i in range(n):
            for j in range(i, n):
                g = T.Gamma[k][i][j]
                if g.is_zero():
                    continue
                sym = sp.Symbol(f"Gamma{k + 1}_{i + 1}{j + 1}", real=True)
                definitions.append((sym, g.to_expr()))
                names[k, i, j] = names[k, j, i] = sym
    C = sp.ImmutableMatrix(
        n, n, lambda k, j: sp.Add(*(names[k, i, j] * T.qd[i] for i in range(n) if (k, i, j) in names))
    )
    return tuple(definitions), C
