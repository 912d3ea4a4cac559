"""Lagrange's energy method on named intermediates: the route for arms whose
expanded trigonometric polynomials are too large (7 joints and up).

Still the energy method, independent of the Newton–Euler recursion: link
poses and Jacobians give M = Σ_i m_i J_viᵀJ_vi + J_ωiᵀ I_i J_ωi (+ G²·Jm on
the diagonal), the potential energy V = −Σ_i m_i g·c_i gives G = ∂V/∂q, and
the Christoffel symbols Γ_kij = ½(∂M_ki/∂q_j + ∂M_kj/∂q_i − ∂M_ij/∂q_k)
give C.  Every intermediate is named on a `Tape` and the derivatives ∂/∂q_l
are taken on that DAG by the chain rule (one derivative name per name that
depends on q_l), so nothing is expanded: the Panda's M, C and G take seconds
where its trigonometric polynomials take minutes.
"""

from __future__ import annotations

import time

import sympy as sp

from .dynamics import Dynamics, friction_expr, rotor_inertia
from .kinematics import along_z, ancestors, link_frames
from ..model import Robot
from . import floating
from .newton_euler import base_inertia, gravity_in_base, link_inertias
from .symbols import joint_symbols
from .tape import AXES, Tape

__all__ = ["derive"]


class _Derivatives:
    """∂/∂q_l of named expressions on a tape, by the chain rule through the names."""

    def __init__(self, tape: Tape, q: tuple):
        self.tape, self.q = tape, q
        self.deps: dict = {}
        self.memo: dict = {}

    def depends(self, expr) -> set:
        """The joints an expression depends on (through its names, cos/sin q and q)."""
        out: set = set()
        for s in sp.sympify(expr).free_symbols:
            if s in self.tape.defs:
                if s not in self.deps:
                    self.deps[s] = self.depends(self.tape.defs[s])
                out |= self.deps[s]
            elif s in self.q:
                out.add(self.q.index(s))
        return out

    def of(self, expr, l: int) -> sp.Expr:
        """∂expr/∂q_l, written in names (each name's derivative named once); one
        walk of the expression (sums and products by the rules, names by the chain rule)."""
        expr = sp.sympify(expr)
        if expr.is_Number:
            return sp.S.Zero
        if expr.is_Symbol:
            if expr in self.tape.defs:
                return self.name_of(expr, l) if l in self.depends(expr) else sp.S.Zero
            return sp.S.One if expr == self.q[l] else sp.S.Zero
        if expr.is_Add:
            return sp.Add(*(self.of(a, l) for a in expr.args))
        if expr.is_Mul:
            args = expr.args
            terms = []
            for i, a in enumerate(args):
                da = self.of(a, l)
                if da != 0:
                    terms.append(sp.Mul(*args[:i], da, *args[i + 1 :]))
            return sp.Add(*terms)
        if expr.is_Pow and expr.exp.is_Number:
            db = self.of(expr.base, l)
            return expr.exp * expr.base ** (expr.exp - 1) * db if db != 0 else sp.S.Zero
        if isinstance(expr, (sp.cos, sp.sin)) and expr.args[0] == self.q[l]:
            return -sp.sin(self.q[l]) if isinstance(expr, sp.cos) else sp.cos(self.q[l])
        if isinstance(expr, (sp.cos, sp.sin)) and expr.args[0] in self.q:
            return sp.S.Zero
        raise ValueError(f"cannot differentiate {expr} on the tape")

    def name_of(self, s: sp.Symbol, l: int) -> sp.Expr:
        if (s, l) not in self.memo:
            self.memo[s, l] = self.tape.name(self.of(self.tape.defs[s], l), f"d{s}_q{l + 1}")
        return self.memo[s, l]


def _mat(tape: Tape, A, B, label: str) -> sp.Matrix:
    """A·B, entries named."""
    return sp.Matrix(
        3, 3, lambda i, j: tape.name(sum(A[i, k] * B[k, j] for k in range(3)), f"{label}_{AXES[i]}{AXES[j]}")
    )


def _columns(tape: Tape, k: int, Rt, o, units: list, joints: list, axes, origins, frames) -> list:
    """Link k's Jacobian columns (v at its origin, ω), in its own frame: the base's velocities
    `units` ((linear, angular) in the base frame) and then its ancestors `joints`."""
    cols = []
    for c, (lin, ang) in enumerate(units):  # v = lin + ang × o in the base frame
        w = Rt * sp.Matrix(ang)
        v = Rt * (sp.Matrix(lin) + sp.Matrix(ang).cross(o))
        cols.append(
            (
                sp.Matrix([tape.name(x, f"v{k}_b{c + 1}{AXES[a]}") for a, x in enumerate(v)]),
                sp.Matrix([tape.name(x, f"w{k}_b{c + 1}{AXES[a]}") for a, x in enumerate(w)]),
            )
        )
    for j in joints:
        revolute = frames[j].S[2] == 1
        zj = Rt * axes[j]  # joint j's axis in link k's frame
        w = [tape.name(x, f"w{k}_{j + 1}{AXES[a]}") for a, x in enumerate(zj)] if revolute else [0, 0, 0]
        v = sp.Matrix(w).cross(Rt * (o - origins[j])) if revolute else zj
        cols.append((sp.Matrix([tape.name(x, f"v{k}_{j + 1}{AXES[a]}") for a, x in enumerate(v)]), sp.Matrix(w)))
    return cols


def _kinetic(M, index: list, cols: list, inertia) -> None:
    """Add one body's ½ m v_c² + ½ ωᵀ I_c ω to M's lower triangle: with Jacobian columns at
    its origin, m va·vb + va·(ωb × h) + vb·(ωa × h) + ωaᵀ Io ωb (h = m·r, Io about the origin)."""
    m, h, Io = inertia.m, sp.Matrix(inertia.h), inertia.Io
    for x, a in enumerate(index):
        va, wa = cols[x]
        Iw = Io * wa
        for y, b in enumerate(index[: x + 1]):
            vb, wb = cols[y]
            M[a][b] += m * va.dot(vb) + va.dot(wb.cross(h)) + vb.dot(wa.cross(h)) + Iw.dot(wb)


def _base_gravity(kind: str, gb, mass, X) -> list:
    """The base rows of G: V = m·g0·p + gb·X (X = Σ m_i c_i in the base frame) differentiated along
    each base velocity's left-invariant field, p → p + ε R·lin, R → R (1 + ε [ang×])."""
    eps = sp.Symbol("epsilon")
    out = []
    for lin, ang in floating.columns(kind):
        moved = sp.Matrix(X) + eps * sp.Matrix(ang).cross(sp.Matrix(X))
        V = mass * eps * gb.dot(sp.Matrix(lin)) + gb.dot(moved)
        out.append(sp.diff(V, eps))
    return out


def _bracket_part(kind: str, M, k: int, i: int, j: int, nb: int) -> sp.Expr:
    """Koszul's bracket terms of Γ_k,ij = ⟨∇_{X_i} X_j, X_k⟩ for left-invariant base fields:
    ½ (M([X_i, X_j], X_k) − M([X_j, X_k], X_i) + M([X_k, X_i], X_j)), brackets only between
    base velocities ([e_a, e_b] = ad(e_a)·e_b, `floating.bracket`)."""
    if kind is None:
        return sp.S.Zero

    def term(a, b, c):
        if a >= nb or b >= nb:
            return sp.S.Zero
        unit = [1 if r == a else 0 for r in range(nb)]
        ab = floating.bracket(kind, unit)[:, b]
        return sum((ab[r] * M[r][c] for r in range(nb) if ab[r] != 0), sp.S.Zero)

    return (term(i, j, k) - term(j, k, i) + term(k, i, j)) / 2


def derive(robot: Robot) -> Dynamics:
    """The Lagrange `Dynamics` of `robot`, M, C, G and τ written in named intermediates.

    A floating base (Hamel's form of Lagrange's equations in the base's body-frame velocities,
    Pinocchio's free-flyer v): T = ½ vᵀ M v with the base's columns in every body's Jacobian;
    G from V along each base velocity's left-invariant field; C's Christoffel symbols by Koszul's
    formula, whose brackets of base velocities do not vanish (Ṁ − 2C skew)."""
    t0 = time.perf_counter()
    n = robot.n
    q, qd, qdd = joint_symbols(n)
    kind = robot.base_joint
    units = floating.columns(kind) if kind else []
    nb = len(units)
    frames = link_frames(along_z(robot), q)  # every joint axis along its link's z
    inertias = link_inertias(along_z(robot))  # about the link origin, first moments h = m·r
    tape = Tape()
    axes, origins, rotations = [], [], []
    for i, f in enumerate(frames):
        k = i + 1
        R, o = (sp.eye(3), sp.zeros(3, 1)) if f.parent < 0 else (rotations[f.parent], origins[f.parent])
        o = sp.Matrix([tape.name(x, f"o{k}_{AXES[a]}") for a, x in enumerate(o + R * f.p)])
        R = _mat(tape, R, f.R, f"R{k}")
        axes.append(R[:, 2])
        origins.append(o)
        rotations.append(R)
    # kinetic energy, body by body; v = (base velocities, joint rates), a tree's other branches
    # do not move a link
    nv = nb + n
    M = [[sp.S.Zero] * nv for _ in range(nv)]
    if kind:
        body = base_inertia(robot)
        _kinetic(M, list(range(nb)), [(sp.Matrix(lin), sp.Matrix(ang)) for lin, ang in units], body)
    for i in range(n):
        path = sorted(ancestors(robot.parents, i))
        cols = _columns(tape, i + 1, rotations[i].T, origins[i], units, path, axes, origins, frames)
        _kinetic(M, list(range(nb)) + [nb + j for j in path], cols, inertias[i])
    Ia = [0] * nb + rotor_inertia(robot)
    for a in range(nv):
        for b in range(a + 1):
            M[a][b] = tape.name(M[a][b] + (Ia[a] if a == b else 0), f"M{a + 1}{b + 1}")
            M[b][a] = M[a][b]
    t1 = time.perf_counter()
    # potential energy V = Σ_i m_i g0·c_i over the links' centres of mass c_i in frame {0}
    g0 = sp.Matrix(gravity_in_base(robot))  # the base's upward acceleration, in frame {0}
    V = sum(
        (inertias[i].m * g0.dot(origins[i]) + g0.dot(rotations[i] * sp.Matrix(inertias[i].h)) for i in range(n)),
        sp.S.Zero,
    )
    d = _Derivatives(tape, q)
    G = []
    if kind:  # V = m·g0·p + gb·X: the base's position p, gravity turned into its frame, X = Σ m_i c_i there
        qb, vb, ab = floating.base_symbols(kind)
        gb = sp.Matrix(tape.vector(list(floating.base_rotation(kind, qb).T * g0), "gb"))
        X = sum(
            (inertias[i].m * origins[i] + rotations[i] * sp.Matrix(inertias[i].h) for i in range(n)), sp.zeros(3, 1)
        )
        X = sp.Matrix(tape.vector(list(X + sp.Matrix(body.h)), "X"))
        mass = sum((inertia.m for inertia in inertias), body.m)
        G = [tape.name(x, f"G{c + 1}") for c, x in enumerate(_base_gravity(kind, gb, mass, X))]
        V = gb.dot(X)
    G += [tape.name(d.of(V, l), f"G{nb + l + 1}") for l in range(n)]
    t2 = time.perf_counter()
    dM = {(a, b, l): d.of(M[a][b], l) for a in range(nv) for b in range(a + 1) for l in range(n)}
    # X_l M_ab: the joints' fields are ∂/∂q_l; M does not change along the base's
    dm = lambda a, b, l: sp.S.Zero if l < nb else dM[max(a, b), min(a, b), l - nb]  # noqa: E731
    gamma = {}
    for k in range(nv):
        for i in range(nv):
            for j in range(i, nv):
                g = (dm(k, i, j) + dm(k, j, i) - dm(i, j, k)) / 2
                gamma[k, i, j] = tape.name(g + _bracket_part(kind, M, k, i, j, nb), f"Gam{k + 1}_{i + 1}{j + 1}")
                gamma[k, j, i] = tape.name(g + _bracket_part(kind, M, k, j, i, nb), f"Gam{k + 1}_{j + 1}{i + 1}")
    v, dv = (tuple(vb) + qd, tuple(ab) + qdd) if kind else (qd, qdd)
    C = sp.ImmutableMatrix(nv, nv, lambda k, j: sum((gamma[k, i, j] * v[i] for i in range(nv)), sp.S.Zero))
    t3 = time.perf_counter()
    F = friction_expr(robot, qd)
    if kind:
        F = sp.ImmutableMatrix([0] * nb + list(F))
    Mm = sp.ImmutableMatrix(M)
    Cqd = sp.ImmutableMatrix(C * sp.Matrix(v))
    Gm = sp.ImmutableMatrix(G)
    named = {"M": Mm, "C": C, "Cqd": Cqd, "G": Gm, "F": F, "tau": Mm * sp.Matrix(dv) + Cqd + Gm + F}
    stats = {
        "time_M": t1 - t0,
        "time_G": t2 - t1,
        "time_Gamma_C": t3 - t2,
        "form": "named",
        "names": len(tape.defs),
        "time_total": time.perf_counter() - t0,
    }
    return Dynamics(
        robot=robot,
        method="lagrange",
        q=tuple(qb) + q if kind else q,
        qd=v,
        qdd=dv,
        F=F,
        definitions=tuple(tape.used_by(list(named["tau"]) + list(C) + list(Mm))),
        named=named,
        stats=stats,
    )
