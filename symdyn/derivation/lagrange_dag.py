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
from .newton_euler import gravity_in_base, link_inertias
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


def derive(robot: Robot) -> Dynamics:
    """The Lagrange `Dynamics` of `robot`, M, C, G and τ written in named intermediates."""
    t0 = time.perf_counter()
    n = robot.n
    q, qd, qdd = joint_symbols(n)
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
    # link i's kinetic energy: ½ m v_c² + ½ ωᵀ I_c ω = ½ (m v_o² + 2 v_o·(ω × R h) + ωᵀ R I_o Rᵀ ω)
    # with Jacobian columns at the link origin: v_o = Σ_j Jv_ij q̇_j, ω = Σ_j Jw_ij q̇_j
    M = [[sp.S.Zero] * n for _ in range(n)]
    for i in range(n):
        k = i + 1
        Rt = rotations[i].T
        m, h, Io = inertias[i].m, sp.Matrix(inertias[i].h), inertias[i].Io
        path = sorted(ancestors(robot.parents, i))  # a tree's other branches do not move link i
        cols = {}
        for j in path:
            revolute = frames[j].S[2] == 1
            zj = Rt * axes[j]  # joint j's axis in link i's frame
            w = [tape.name(x, f"w{k}_{j + 1}{AXES[a]}") for a, x in enumerate(zj)] if revolute else [0, 0, 0]
            if revolute:
                v = sp.Matrix(w).cross(Rt * (origins[i] - origins[j]))
            else:
                v = zj
            v = [tape.name(x, f"v{k}_{j + 1}{AXES[a]}") for a, x in enumerate(v)]
            cols[j] = (sp.Matrix(v), sp.Matrix(w))
        for x, a in enumerate(path):
            va, wa = cols[a]
            Iw = Io * wa
            for b in path[: x + 1]:
                vb, wb = cols[b]
                term = m * va.dot(vb) + va.dot(wb.cross(h)) + vb.dot(wa.cross(h)) + Iw.dot(wb)
                M[a][b] += term
    Ia = rotor_inertia(robot)
    for a in range(n):
        for b in range(a + 1):
            M[a][b] = tape.name(M[a][b] + (Ia[a] if a == b else 0), f"M{a + 1}{b + 1}")
            M[b][a] = M[a][b]
    t1 = time.perf_counter()
    g0 = sp.Matrix(gravity_in_base(robot))  # the base's upward acceleration, in frame {0}
    V = sum(
        (inertias[i].m * g0.dot(origins[i]) + g0.dot(rotations[i] * sp.Matrix(inertias[i].h)) for i in range(n)),
        sp.S.Zero,
    )
    d = _Derivatives(tape, q)
    G = [tape.name(d.of(V, l), f"G{l + 1}") for l in range(n)]
    t2 = time.perf_counter()
    dM = {(a, b, l): d.of(M[a][b], l) for a in range(n) for b in range(a + 1) for l in range(n)}
    dm = lambda a, b, l: dM[max(a, b), min(a, b), l]  # noqa: E731
    gamma = {}
    for k in range(n):
        for i in range(n):
            for j in range(i, n):
                g = (dm(k, i, j) + dm(k, j, i) - dm(i, j, k)) / 2
                gamma[k, i, j] = gamma[k, j, i] = tape.name(g, f"Gam{k + 1}_{i + 1}{j + 1}")
    C = sp.ImmutableMatrix(n, n, lambda k, j: sum((gamma[k, i, j] * qd[i] for i in range(n)), sp.S.Zero))
    t3 = time.perf_counter()
    F = friction_expr(robot, qd)
    Mm = sp.ImmutableMatrix(M)
    Cqd = sp.ImmutableMatrix(C * sp.Matrix(qd))
    Gm = sp.ImmutableMatrix(G)
    named = {"M": Mm, "C": C, "Cqd": Cqd, "G": Gm, "F": F, "tau": Mm * sp.Matrix(qdd) + Cqd + Gm + F}
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
        q=q,
        qd=qd,
        qdd=qdd,
        F=F,
        definitions=tuple(tape.used_by(list(named["tau"]) + list(C) + list(Mm))),
        named=named,
        stats=stats,
    )
