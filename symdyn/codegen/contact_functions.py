"""Contact dynamics, generated: the KKT solve of rigid contacts and the inelastic impact.

Between derive and program, above the joint space and the task space, which it combines: for a
robot's contact set (`Robot.with_contacts`) the constraint rows J (nc × nv) and their drift γ come
from the task-space derivation of the contact frames, world-aligned at each frame (Pinocchio's
LOCAL_WORLD_ALIGNED): a point contact holds its origin's classical acceleration (3 rows), a
surface contact its spatial acceleration (6 rows; the linear part is the classical one less
ω × v).  With M's unrolled LDLᵀ (`functions.ldlt_factor`, M = L D Lᵀ in the tree's elimination
order) and Z = L⁻¹Jᵀ — a forward substitution that keeps each contact's column on the joints
above its frame — A = J M⁻¹Jᵀ = Zᵀ D⁻¹ Z, and M⁻¹Jᵀλ = L⁻ᵀ(D⁻¹Z λ), one backward substitution:

    contact_fdyn(q, v, τ) → (a, λ):  λ = −A⁻¹(J M⁻¹(τ − b) + γ),  a = M⁻¹(τ − b) + M⁻¹Jᵀλ
    contact_impulse(q, v⁻) → (v⁺, Λ): Λ = −A⁻¹ J v⁻,  v⁺ = v⁻ + M⁻¹JᵀΛ  (restitution 0)

(the dense X = M⁻¹Jᵀ, nc backward substitutions, only where a program outputs it: `blocks`).

— Pinocchio's `constraintDynamics` and `impulseDynamics` (M a = τ − b + Jᵀλ, J a + γ = 0;
J v⁺ = 0).  One program each: M and the bias b = τ(q, v, 0) are the chosen ones (`choice`), and
the contact frames' intermediates are renamed k_… so that they meet no name of the dynamics'.
With Baumgarte gains (`Robot.with_contacts(…, kp=, kd=)`) the constraint is Pinocchio's corrected
one, J a + γ = −kd J v − kp e, e the frames' errors from an `anchor` input (`_anchor_errors`).
A contact set whose rows are dependent (A singular: two surfaces on one body) is refused by name
(`_independent`).  The derivatives (`derivatives_program`) differentiate the KKT residuals,
r1 = τ(q, v, a) − Jᵀf and r2 = J a + γ (for the impact M(v⁺ − v⁻) − JᵀΛ and J v⁺), and solve
the same KKT system for each column: ∂[a; f]/∂z = −K⁻¹ ∂r/∂z, K = [M −Jᵀ; J 0].
"""

from __future__ import annotations

import functools
import math

import numpy as np
import sympy as sp

from ..derivation.task_space import derive_task_space
from ..model import Robot
from ..model.frames import CONTACT_KINDS
from ..model.rotations import quaternion_entries
from ..derivation.program import Program
from .derivatives import Splice, jacobian, tangent_map
from .functions import FunctionSpec, _Namer, elimination_order, ldlt_factor, ldlt_inverse
from .tangents import LANES, plan

__all__ = [
    "CONTACT_NAMES",
    "ContactSpecs",
    "anchor_size",
    "contact_names",
    "contact_count",
    "contact_signatures",
    "derivatives_program",
    "PARTS",
    "TANGENT_PARTS",
    "INVERSE_FACTORS",
    "ALL_PARTS",
    "parts_program",
]

CONTACT_NAMES = ("contact_fdyn", "contact_impulse", "contact_fdyn_derivatives", "contact_impulse_derivatives")


def contact_names(robot: Robot) -> tuple[str, ...]:
    """The contact functions of `robot`: both when it has a contact set, none otherwise."""
    return CONTACT_NAMES if robot.contacts else ()


def contact_count(robot: Robot) -> int:
    """nc: the rows of the contact set (3 per point, 6 per surface)."""
    return sum(CONTACT_KINDS[kind] for _, kind in robot.contacts)


def _rows(robot: Robot) -> tuple[list, list, list, tuple, list]:
    """(J rows, γ, the definitions they use renamed k_…, (q, v) symbols, each frame's (p, R) in the
    world) of the contact set."""
    contact_robot = robot.with_frames([name for name, _ in robot.contacts])
    ts = derive_task_space(contact_robot)
    J, drift, world = (
        ts.outputs["frame_jacobian_aligned"],
        ts.outputs["frame_drift"],
        ts.outputs["frame_velocity_world"],
    )
    rows, gamma = [], []
    for k, (_, kind) in enumerate(robot.contacts):
        count = CONTACT_KINDS[kind]
        rows += [list(J.row(6 * k + i)) for i in range(count)]
        d = list(drift.row(k))
        if kind == "surface":  # the spatial acceleration: classical less ω × v (world axes)
            v, w = list(world.row(k))[:3], list(world.row(k))[3:]
            d[:3] = [d[i] - (w[(i + 1) % 3] * v[(i + 2) % 3] - w[(i + 2) % 3] * v[(i + 1) % 3]) for i in range(3)]
        gamma += d[:count]
    zero = ts.at_rest()
    rename = {s: sp.Symbol(f"k_{s.name}", real=True) for s, _ in ts.definitions}
    defs = [(rename[s], sp.sympify(e).xreplace(zero).xreplace(rename)) for s, e in ts.definitions]
    rows = [[sp.sympify(e).xreplace(rename) for e in row] for row in rows]
    gamma = [sp.sympify(e).xreplace(zero).xreplace(rename) for e in gamma]
    T = ts.outputs["frame_pose"].xreplace(rename)
    poses = [(T[4 * k : 4 * k + 3, 3], T[4 * k : 4 * k + 3, :3]) for k in range(len(robot.contacts))]
    return rows, gamma, defs, (ts.q, ts.v), poses


#: Terms kept of the series h(u) = θ²/(2u), u = 1 − cos θ, that the surface anchors' log₆ reads
#: θ from: its terms fall as (u/2)ᵐ, so 40 keep it exact to double precision for θ ≤ 90°.
LOG_TERMS = 40


@functools.cache
def log_series() -> tuple[tuple, tuple]:
    """The coefficients of h(u) = θ²/(2u) = Σ aₘ uᵐ (θ² = 4 arcsin²√(u/2) = Σₙ 2ⁿ⁺¹uⁿ/(n² C(2n, n)))
    and of k(u) = (1 − (1 − u/2) h(u))/u = Σ (aₘ₋₁/2 − aₘ) uᵐ⁻¹."""
    a = [sp.Rational(2 ** (m + 1), (m + 1) ** 2 * math.comb(2 * m + 2, m + 1)) for m in range(LOG_TERMS + 1)]
    return tuple(a[:LOG_TERMS]), tuple(a[m - 1] / 2 - a[m] for m in range(1, LOG_TERMS + 1))


def _horner(coefficients: tuple, u: sp.Expr) -> sp.Expr:
    out = sp.S.Zero
    for c in reversed(coefficients):
        out = out * u + c
    return out


def _log6(R: sp.Matrix, t: sp.Matrix, name) -> tuple[list, list]:
    """SE(3)'s logarithm (linear, angular) of the placement (R, t), as Pinocchio's `log6`, without a
    branch: with u = 1 − cos θ = (3 − tr R)/2 and h, k of `log_series`, θ/(2 sin θ) = ½√(h/(1 − u/2))
    and (1 − (θ/2)cot(θ/2))/θ² = k/(2h(1 + √((1 − u/2)h))) — smooth at θ = 0, where the
    closed forms are 0/0; exact for θ ≤ 90° (`LOG_TERMS`).  `name(stem, expr)` names a term."""
    h_terms, k_terms = log_series()
    u = name("u", (3 - R.trace()) / 2)
    h, k = name("h", _horner(h_terms, u)), name("k", _horner(k_terms, u))
    f = name("f", sp.sqrt(h / (1 - u / 2)) / 2)
    w = sp.Matrix(
        [name("w", (R[2, 1] - R[1, 2]) * f), name("w", (R[0, 2] - R[2, 0]) * f), name("w", (R[1, 0] - R[0, 1]) * f)]
    )
    g = name("g", k / (2 * h * (1 + sp.sqrt((1 - u / 2) * h))))
    t = sp.Matrix([name("t", e) for e in t])
    wt = sp.Matrix([name("wt", e) for e in w.cross(t)])
    return [name("lin", e) for e in t - wt / 2 + g * w.cross(wt)], list(w)


def anchor_size(robot: Robot) -> int:
    """The size of the `anchor` input of a contact set with kp > 0 (3 per point, 7 per surface), else 0."""
    if not robot.baumgarte[0]:
        return 0
    return sum(3 if kind == "point" else 7 for _, kind in robot.contacts)


def _anchor_errors(robot: Robot, poses: list) -> tuple[tuple, list, list]:
    """(the anchor's symbols, e, the definitions e uses): each contact frame's error from its anchor
    in world axes, as Pinocchio's corrector measures it — p − p_anchor for a point; for a surface
    −R·log₆(M⁻¹M_anchor), M = (R, p) the frame's placement and M_anchor = (x y z, quaternion) the
    anchor's.  The terms are named k_anchor…, so that derivatives take them one at a time."""
    anchor, errors, defs = [], [], []

    def name(stem: str, expr: sp.Expr) -> sp.Symbol:
        symbol = sp.Symbol(f"k_anchor_{stem}{len(defs) + 1}", real=True)
        defs.append((symbol, sp.sympify(expr)))
        return symbol

    for (_, kind), (p, R) in zip(robot.contacts, poses):
        a = [sp.Symbol(f"anchor{len(anchor) + i + 1}", real=True) for i in range(3 if kind == "point" else 7)]
        anchor += a
        if kind == "point":
            errors += [p[i] - a[i] for i in range(3)]
            continue
        x, y, z, w = a[3:]  # any non-zero quaternion, read by its direction as a base's is
        k = name("k", 2 / (x * x + y * y + z * z + w * w))
        target = sp.Matrix(3, 3, [name("R", e) for e in quaternion_entries(x, y, z, w, k)])
        relative = sp.Matrix(3, 3, [name("Rr", e) for e in R.T * target])
        linear, angular = _log6(relative, R.T * (sp.Matrix(a[:3]) - p), name)
        errors += [-e for e in R * sp.Matrix(linear)] + [-e for e in R * sp.Matrix(angular)]
    return tuple(anchor), errors, defs


def _forward(L: list, iD: list, order: list, rhs: list, name: _Namer, stem: str, col: int) -> tuple[list, list]:
    """(z, D⁻¹z) with L z = rhs taken in `order` (`ldlt_factor`'s), in elimination positions, named
    kkt_{stem}z{col}_{i} and kkt_{stem}y{col}_{i}: zero where no entry of rhs reaches (a tree's
    factor carries an entry only towards the root)."""
    z: list = []
    for i in range(len(iD)):
        z.append(name(f"kkt_{stem}z{col}_", rhs[order[i]] - sp.Add(*(L[i][k] * z[k] for k in range(i))), order[i]))
    return z, [name(f"kkt_{stem}y{col}_", z[i] * iD[i], order[i]) for i in range(len(iD))]


def _backward(L: list, order: list, y: list, name: _Namer, stem: str, col: int) -> list:
    """x = L⁻ᵀ y (y in elimination positions), back in the joints' order, named kkt_{stem}{col}_{i}."""
    n = len(y)
    x = [sp.S.Zero] * n
    for i in reversed(range(n)):
        x[i] = name(f"kkt_{stem}{col}_", y[i] - sp.Add(*(L[k][i] * x[k] for k in range(i + 1, n))), order[i])
    out = [sp.S.Zero] * n
    for i, k in enumerate(order):
        out[k] = x[i]
    return out


def _solve(L: list, iD: list, order: list, rhs: list, name: _Namer, stem: str, col: int) -> list:
    """x = M⁻¹ rhs by the factor (L, 1/D) of `ldlt_factor` taken in `order`, named kkt_{stem}{col}_{i}."""
    return _backward(L, order, _forward(L, iD, order, rhs, name, stem, col)[1], name, stem, col)


def _small_factor(A: sp.Matrix, name: _Namer) -> tuple[list, list, list]:
    """The unrolled LDLᵀ of the contact set's A (nc × nc), its names prefixed kkt_K (M's factor has
    the plain ones): (definitions, L, 1/D)."""
    defs, L, iD = ldlt_factor(A)
    rename = {s: sp.Symbol(f"kkt_K{s.name}", real=True) for s, _ in defs}
    defs = [(rename[s], e.xreplace(rename)) for s, e in defs]
    L = [[sp.sympify(x).xreplace(rename) for x in row] for row in L]
    return defs, L, [sp.sympify(x).xreplace(rename) for x in iD]


def _independent(robot: Robot, rows: list, definitions: list, q: tuple, tries: int = 2) -> None:
    """Refuse a contact set whose rows are dependent at every configuration tried (two surfaces on
    one body, three points on one link): its forces are not unique, and A = J M⁻¹Jᵀ is singular.
    The rows are evaluated at random configurations; the error names the first contact whose rows
    add nothing to those before it."""
    rng = np.random.default_rng(0)
    counts = [CONTACT_KINDS[kind] for _, kind in robot.contacts]
    culprits = []
    for _ in range(tries):
        values = {s: sp.Float(x) for s, x in zip(q, rng.uniform(-1.0, 1.0, len(q)))}
        for sym, expr in definitions:
            values[sym] = sp.sympify(expr).xreplace(values)
        J = np.array([[float(sp.sympify(e).xreplace(values)) for e in row] for row in rows])
        scale = max(1.0, np.abs(J).max())
        start, culprit = 0, None
        for k, count in enumerate(counts):
            block = J[: start + count]
            if np.linalg.matrix_rank(block, tol=1e-9 * scale) < start + count:
                culprit = k
                break
            start += count
        if culprit is None:
            return
        culprits.append(culprit)
    name, kind = robot.contacts[culprits[0]]
    before = ", ".join(f"{f!r} ({k})" for f, k in robot.contacts[: culprits[0]]) or "none"
    raise ValueError(
        f"contact set of {robot.name}: the rows of {name!r} ({kind}) depend on those before it ({before}) "
        "at every configuration tried — the constraint Jacobian J is rank-deficient, so the contact forces "
        "are not unique (two surfaces on one body, more rows than the joints that move the frame); drop "
        f"{name!r} or merge it with the contact it repeats"
    )


class ContactSpecs:
    """The contact set's specs, sharing one build of their pieces: the rows J and drift γ, M's
    LDLᵀ, X = M⁻¹Jᵀ, A = J X and A's LDLᵀ (see the module)."""

    def __init__(self, robot: Robot, M: FunctionSpec, bias: FunctionSpec, *, tree: bool) -> None:
        self.robot, self.M, self.bias = robot, M, bias
        self.rows, self.gamma, self.kdefs, (q, _), poses = _rows(robot)
        _independent(robot, self.rows, self.kdefs, tuple(q))
        self.anchor, self.errors, self.edefs = _anchor_errors(robot, poses) if robot.baumgarte[0] else ((), [], [])
        Mmat, self.b = M.outputs[0][1], list(bias.outputs[0][1])
        n, nc = Mmat.rows, len(self.rows)
        self.n, self.nc = n, nc
        self.q, self.v = M.inputs[0], bias.inputs[1]
        self.mdefs, self.L, self.iD = ldlt_factor(Mmat, elimination_order(Mmat) if tree else None)
        self.order = elimination_order(Mmat) if tree else list(range(n))
        name = _Namer(max(n, nc))
        self.Z = [_forward(self.L, self.iD, self.order, self.rows[c], name, "X", c + 1) for c in range(nc)]
        A = sp.Matrix(
            nc,
            nc,
            lambda i, j: (
                name("kkt_A", sp.Add(*(zi * yj for zi, yj in zip(self.Z[i][0], self.Z[j][1]))), i, j) if i >= j else 0
            ),
        )
        A = sp.Matrix(nc, nc, lambda i, j: A[max(i, j), min(i, j)])
        self.adefs, self.AL, self.AiD = _small_factor(A, name)
        self.base = list(M.definitions) + list(bias.definitions) + self.kdefs + self.mdefs
        self.named, self._name, self._X = name.defs, name, None
        self.params = [a for a in M.inputs + bias.inputs if a[0] == "p"][:1]

    def _constraint(self, a: list, v: tuple) -> list:
        """J a + γ, and with Baumgarte gains + kd J v + kp e: the rows of the constraint."""
        kp, kd = self.robot.baumgarte
        out = []
        for c, row in enumerate(self.rows):
            r = sp.Add(*(row[k] * a[k] for k in range(self.n))) + self.gamma[c]
            if kd:
                r += kd * sp.Add(*(row[k] * v[k] for k in range(self.n)))
            if kp:
                r += kp * self.errors[c]
            out.append(r)
        return out

    def fdyn_inputs(self) -> tuple:
        """contact_fdyn's inputs: (q, v, tau[, anchor]) and the parameters."""
        tau = ("tau", tuple(sp.Symbol(f"tau{i + 1}", real=True) for i in range(self.n)))
        anchor = (("anchor", self.anchor),) if self.anchor else ()
        return (self.q, ("v", self.v[1]), tau, *anchor, *self.params)

    def shared(self) -> frozenset:
        """The symbols every contact program defines alike (M's terms and factor, X, A's factor):
        a spliced program takes them from the one spliced before (`derivatives.Splice`)."""
        return frozenset(s for s, _ in (*self.base, *self.named, *self.adefs))

    def _definitions(self, local: _Namer, anchor: bool = False) -> tuple:
        defs = dict(self.base)
        defs.update(self.edefs if anchor else ())
        defs.update(self.named)
        defs.update(self.adefs)
        defs.update(local.defs)
        return tuple(defs.items())

    def _kkt(self, u: list, w: list, local: _Namer, col: int) -> tuple[list, list]:
        """(x, λ) of [M −Jᵀ; J 0] [x; λ] = [u; w]: λ = A⁻¹(w − J M⁻¹u), x = M⁻¹u + X λ."""
        n, nc = self.n, self.nc
        y = _solve(self.L, self.iD, self.order, u, local, f"u{col}_", 0) if any(e != 0 for e in u) else [0] * n
        rhs = [local(f"kkt_g{col}_", w[i] - sp.Add(*(self.rows[i][k] * y[k] for k in range(n))), i) for i in range(nc)]
        lam = _solve(self.AL, self.AiD, list(range(nc)), rhs, local, f"lam{col}_", 0)
        x = [local(f"kkt_x{col}_", y[k] + sp.Add(*(self.X[c][k] * lam[c] for c in range(nc))), k) for k in range(n)]
        return x, lam  # X once for every column (2n + n of them), not a backward substitution each

    @property
    def X(self) -> list:
        """M⁻¹Jᵀ by columns (nc × n): the backward halves of Z's solves, made when first asked for."""
        if self._X is None:
            self._X = [_backward(self.L, self.order, y, self._name, "X", c + 1) for c, (_, y) in enumerate(self.Z)]
        return self._X

    def _plus_forces(self, y: list, lam: list, local: _Namer, stem: str) -> list:
        """y + M⁻¹Jᵀλ = y + L⁻ᵀ(Σ λ_c D⁻¹z_c): one backward substitution of the forces' sum."""
        w = [
            local(f"kkt_{stem}w", sp.Add(*(lam[c] * self.Z[c][1][i] for c in range(self.nc))), self.order[i])
            for i in range(self.n)
        ]
        dx = _backward(self.L, self.order, w, local, f"{stem}d", 0)
        return [local(f"kkt_{stem}", y[k] + dx[k], k) for k in range(self.n)]

    def dynamics(self, kind: str) -> FunctionSpec:
        """contact_fdyn (kind "fdyn") or contact_impulse ("impulse")."""
        n, nc, rows, robot = self.n, self.nc, self.rows, self.robot
        local = _Namer(max(n, nc))
        v = self.v
        if kind == "fdyn":
            inputs = self.fdyn_inputs()
            tau = inputs[2][1]
            r = [local("kkt_r", tau[i] - self.b[i], i) for i in range(n)]
            y = _solve(self.L, self.iD, self.order, r, local, "u", 0)
            rhs = [local("kkt_g", e, i) for i, e in enumerate(self._constraint(y, v[1]))]
            start = y
        else:
            rhs = [local("kkt_g", sp.Add(*(rows[i][k] * v[1][k] for k in range(n))), i) for i in range(nc)]
            inputs, start = (self.q, ("v_before", v[1]), *self.params), list(v[1])
        lam = _solve(self.AL, self.AiD, list(range(nc)), rhs, local, "lam", 0)
        lam = [local("kkt_lam", -x, i) for i, x in enumerate(lam)]
        out = self._plus_forces(start, lam, local, "out")
        label = ("a", "force") if kind == "fdyn" else ("v_after", "impulse")
        doc = f"Contact dynamics of the set {_set(robot)}: " + (
            f"a ({n},) and the contact forces ({nc},), world axes at each frame, of M a = tau - b + J^T f, "
            "J a + gamma = 0 (Pinocchio's constraintDynamics)."
            if kind == "fdyn"
            else f"the velocity after an inelastic impact ({n},) and the impulses ({nc},): J v+ = 0 "
            "(impulseDynamics, restitution 0)."
        )
        return FunctionSpec(
            f"contact_{kind}",
            inputs,
            ((label[0], sp.ImmutableMatrix(out)), (label[1], sp.ImmutableMatrix(lam))),
            self._definitions(local, anchor=kind == "fdyn"),
            doc,
            f"contacts; M: {self.M.origin}, bias: {self.bias.origin}",
        )

    def _residuals(self, kind: str, tau: FunctionSpec, base_joint: str | None) -> tuple:
        """(inputs, definitions, [r1; r2], the directions wrt, the closed-form turn columns or None)
        of the KKT residuals: for "fdyn", r1 = τ(q, v, a) − Jᵀf, r2 = J a + γ at (q, v, a, f); for
        "impulse", r1 = M(q)(v⁺ − v⁻) − JᵀΛ, r2 = J v⁺ at (q, v⁻, v⁺, Λ)."""
        n, nc, rows = self.n, self.nc, self.rows
        q, v = self.q[1], self.v[1]
        second = tuple(sp.Symbol(f"{'qdd' if kind == 'fdyn' else 'vplus'}{i + 1}", real=True) for i in range(n))
        lam = tuple(sp.Symbol(f"lam{i + 1}", real=True) for i in range(nc))
        if kind == "fdyn":
            tq, tv, ta = (syms for _, syms in tau.inputs[:3])
            swap = {**dict(zip(tq, q)), **dict(zip(tv, v)), **dict(zip(ta, second))}
            defs = [(s, sp.sympify(e).xreplace(swap)) for s, e in tau.definitions]
            first = [sp.sympify(e).xreplace(swap) for e in tau.outputs[0][1]]
            r2 = self._constraint(list(second), v)
            names = ("v", "a", "force")
        else:
            Mmat = self.M.outputs[0][1]
            defs = list(self.M.definitions)
            first = [sp.Add(*(Mmat[i, j] * (second[j] - v[j]) for j in range(n))) for i in range(n)]
            r2 = [sp.Add(*(rows[c][k] * second[k] for k in range(n))) for c in range(nc)]
            names = ("v_before", "v_after", "impulse")
        r1 = [first[i] - sp.Add(*(rows[c][i] * lam[c] for c in range(nc))) for i in range(n)]
        edefs = list(self.edefs) if kind == "fdyn" else []
        invariant = self._invariant(base_joint)
        wrt = [s for s in list(q) + list(v) if s not in invariant]
        turn = None
        if q[3] in invariant:
            known = dict(defs)
            turn = self._turn(kind, q, lam, known)
            defs = list(known.items())
        anchor = (("anchor", self.anchor),) if kind == "fdyn" and self.anchor else ()
        inputs = (self.q, (names[0], v), (names[1], second), (names[2], lam), *anchor, *self.params)
        return inputs, defs + list(self.kdefs) + edefs, r1 + r2, wrt, turn

    def residual(self, kind: str, tau: FunctionSpec, base_joint: str | None) -> FunctionSpec:
        """The KKT residuals' Jacobians in the tangent space of q (`_residuals`), by (q, v) for
        "fdyn", by (q, v⁻) for "impulse".  Outputs dr1_dq, dr1_dv, dr2_dq, dr2_dv."""
        n, nc = self.n, self.nc
        q, v = self.q[1], self.v[1]
        inputs, defs, residuals, wrt, turn = self._residuals(kind, tau, base_joint)
        jdefs, cols = jacobian(defs, residuals, wrt, stem="Dk")
        at = {s: k for k, s in enumerate(wrt)}
        jac = [[row[at[s]] if s in at else sp.S.Zero for s in list(q) + list(v)] for row in cols]
        T = tangent_map(q, n, base_joint) if base_joint is not None else sp.eye(n)

        def block(r0: int, rs: int, c0: int, cs: int, tangent: bool) -> sp.ImmutableMatrix:
            if not tangent:
                return sp.ImmutableMatrix(rs, cs, lambda i, k: jac[r0 + i][c0 + k])
            return sp.ImmutableMatrix(
                rs,
                n,
                lambda i, j: (
                    turn[i][j - 3]
                    if turn is not None and 3 <= j < 6 and r0 == 0
                    else sp.Add(
                        *(jac[r0 + i][k] * T[k, j] for k in range(len(q)) if jac[r0 + i][k] != 0 and T[k, j] != 0)
                    )
                ),
            )

        outputs = (
            ("dr1_dq", block(0, n, 0, len(q), True)),
            ("dr1_dv", block(0, n, len(q), n, False)),
            ("dr2_dq", block(n, nc, 0, len(q), True)),
            ("dr2_dv", block(n, nc, len(q), n, False)),
        )
        return FunctionSpec(
            f"contact_{kind}_residual",
            inputs,
            outputs,
            tuple(dict([*defs, *jdefs]).items()),
            "",
            f"contacts; tau: {tau.origin}",
            tuple(o for o, _ in outputs),
        )

    def tangents(self, kind: str, tau: FunctionSpec, base_joint: str | None) -> tuple | None:
        """The residuals' Jacobians for vectors of directions (`tangents.plan`): (a spec whose outputs
        are the local partials the plan reads and the turn's columns (n × 3; zeros without a free
        base), the plan, {direction: column of R = [∂r/∂q ∂r/∂v]}); None where a direction is not
        one column of the tangent space (kp: the quaternion is differentiated, then mapped)."""
        n = self.n
        q, v = self.q[1], self.v[1]
        inputs, defs, residuals, wrt, turn = self._residuals(kind, tau, base_joint)
        T = tangent_map(q, n, base_joint) if base_joint is not None else sp.eye(n)
        columns = {x: n + k for k, x in enumerate(v)}
        for k, x in enumerate(q):
            if x in wrt:
                cols = [j for j in range(n) if T[k, j] != 0]
                if len(cols) != 1 or T[k, cols[0]] != 1:
                    return None
                columns[x] = cols[0]
        program = plan(defs, residuals, self._groups(wrt))
        turned = sp.ImmutableMatrix(n, 3, lambda i, k: turn[i][k] if turn is not None else 0)
        spec = FunctionSpec(
            f"contact_{kind}_partials",
            inputs,
            (("partials", sp.ImmutableMatrix(len(program.values), 1, program.values)), ("turn", turned)),
            tuple(dict(defs).items()),
            "",
            f"contacts; tau: {tau.origin}",
            ("partials", "turn"),
        )
        return spec, program, columns

    def _groups(self, wrt: list) -> list:
        """The directions in vectors: the base's, then each chain of the tree (a joint and the joints
        below it up to a branching, which start chains of their own) — its joints' coordinates, then
        their velocities; a chain moves no other branch — the chains of at most LANES directions
        packed together first fit (Talos' torso and head in one vector: its residuals' tangents
        12 028 → 10 758 vector multiply-adds)."""
        robot, n = self.robot, self.n
        q, v = self.q[1], self.v[1]
        joints = robot.n
        children: dict = {}
        for k in range(joints):
            children.setdefault(robot.parents[k], []).append(k)
        chains, stack = [], list(reversed(children.get(-1, [])))
        while stack:
            chain = [stack.pop()]
            while len(children.get(chain[-1], [])) == 1:
                chain.append(children[chain[-1]][0])
            chains.append(chain)
            stack += reversed(children.get(chain[-1], []))
        chosen = set(wrt)
        base = [x for x in list(q[: len(q) - joints]) + list(v[: n - joints]) if x in chosen]
        groups: list = [base] if base else []
        for chain in chains:
            group = [
                x for x in [q[len(q) - joints + k] for k in chain] + [v[n - joints + k] for k in chain] if x in chosen
            ]
            fit = next((g for g in groups if len(group) <= LANES and len(g) + len(group) <= LANES), None)
            if fit is None:
                groups.append(group)
            else:
                fit += group
        return groups

    def _invariant(self, base_joint: str | None) -> tuple:
        """The base's coordinates the residuals are not differentiated by, when only a rigid motion of
        the whole robot depends on them (Baumgarte's kp measures positions from an anchor: then they
        all count).  Its position: the dynamics, the rows J (world-aligned, lever arms differences of
        positions) and γ are unchanged by a translation in a uniform field, so their derivatives by
        it are exact zeros, not the round-off of differences the program computes.  A free base's
        quaternion: turning the base turns the world-aligned terms and gravity in the base frame,
        whose derivatives have a closed form (`_turn`) — the four directions of the quaternion
        through the whole program were the costliest (Solo 12: ~4 000 operations each of 38 000)."""
        if self.robot.baumgarte[0] or base_joint not in ("free", "planar"):
            return ()
        return tuple(self.q[1][: 7 if base_joint == "free" else 2])

    def _turn(self, kind: str, q: tuple, lam: tuple, defs: dict) -> list:
        """∂r1/∂δ (n × 3) for a turn δ of a free base in its own frame (q ⊕ δ: R → R exp(δ×)).  Gravity
        enters τ as the base's upward acceleration g_b = Rᵀg₀ (`newton_euler.gravity_in_base`),
        so ∂τ/∂δ_k = M[:, :3](g_b × e_k) (for fdyn; M(v⁺ − v⁻) of the impact does not turn); a
        world-aligned row block J_c = R_w J_c,b gives ∂(J_cᵀλ_c)/∂δ_k = J_cᵀ(λ_c × R_w e_k).  r2, a
        world-aligned vector, turns as ∂r2/∂δ_k = R_w e_k × r2 = 0 at the solution, where r2 = 0."""
        from ..derivation.floating import base_rotation
        from ..derivation.newton_euler import gravity_in_base
        from ..model.placement import exact

        n, R = self.n, base_rotation("free", q[:7])
        Rw = sp.Matrix([[exact(x) for x in row[:3]] for row in self.robot.base[:3]]) * R
        gb = R.T * sp.Matrix(gravity_in_base(self.robot))
        M = self.M.outputs[0][1]
        if kind == "fdyn":  # M's terms, τ's where τ has them (one derivation: the same), added to defs
            ours = dict(self.M.definitions)
            clash = {s for s, e in ours.items() if s in defs and sp.sympify(defs[s]) != sp.sympify(e)}
            rename = {s: sp.Symbol(f"turn_{s.name}", real=True) for s in clash}
            for s, e in ours.items():
                if s not in defs or s in clash:
                    defs[rename.get(s, s)] = sp.sympify(e).xreplace(rename)
            M = M.xreplace(rename)
        out = [[sp.S.Zero] * 3 for _ in range(n)]
        for k in range(3):
            axis = Rw[:, k]
            if kind == "fdyn":
                turned = gb.cross(sp.Matrix([1 if m == k else 0 for m in range(3)]))
                for i in range(n):
                    out[i][k] += sp.Add(*(M[i, m] * turned[m] for m in range(3) if turned[m] != 0))
            for c0 in range(0, self.nc, 3):
                force = sp.Matrix(lam[c0 : c0 + 3]).cross(axis)
                for i in range(n):
                    out[i][k] -= sp.Add(
                        *(self.rows[c0 + m][i] * force[m] for m in range(3) if self.rows[c0 + m][i] != 0)
                    )
        return out

    def blocks(self, rows: bool = False) -> FunctionSpec:
        """Xᵀ = J M⁻¹ (nc × n) and A⁻¹ (nc × nc, from A's factor): the KKT inverse's blocks besides
        M⁻¹ (`parts_program`); `rows`: the rows J in Xᵀ's place, for a target that multiplies
        them with M⁻¹ itself (the C's vectors)."""
        defs, inv = ldlt_inverse(self.AL, self.AiD)
        rename = {s: sp.Symbol(f"kkt_Ai{s.name}", real=True) for s, _ in defs}
        defs = [(rename[s], e.xreplace(rename)) for s, e in defs]
        local = _Namer(1)
        first = (
            ("J", sp.ImmutableMatrix(self.nc, self.n, lambda c, k: self.rows[c][k]))
            if rows
            else ("XT", sp.ImmutableMatrix(self.nc, self.n, lambda c, k: self.X[c][k]))
        )
        return FunctionSpec(
            "contact_blocks",
            (self.q, *self.params),
            (first, ("Ainv", inv.xreplace(rename))),
            self._definitions(local) + tuple(defs),
            "",
            "contacts",
            (first[0], "Ainv"),
        )

    def solve(self, columns: int, identity: bool) -> FunctionSpec:
        """[x; λ] = [M −Jᵀ; J 0]⁻¹ [u; w] for `columns` columns given as inputs u (n × columns) and
        w (nc × columns), then (`identity`) n more with u = I, w = 0 (the derivatives by τ)."""
        n, nc = self.n, self.nc
        u = sp.Matrix(n, columns, lambda i, k: sp.Symbol(f"u{i + 1}_{k + 1}", real=True))
        w = sp.Matrix(nc, columns, lambda i, k: sp.Symbol(f"w{i + 1}_{k + 1}", real=True))
        local = _Namer(max(n, nc, columns))
        xs, lams = [], []
        for k in range(columns + (n if identity else 0)):
            if k < columns:
                x, lam = self._kkt(list(u[:, k]), list(w[:, k]), local, k + 1)
            else:
                e = [sp.S.One if i == k - columns else sp.S.Zero for i in range(n)]
                x, lam = self._kkt(e, [sp.S.Zero] * nc, local, k + 1)
            xs.append(x)
            lams.append(lam)
        X = sp.ImmutableMatrix(n, len(xs), lambda i, k: xs[k][i])
        Lam = sp.ImmutableMatrix(nc, len(lams), lambda i, k: lams[k][i])
        return FunctionSpec(
            "contact_solve",
            (self.q, ("u", tuple(u)), ("w", tuple(w)), *self.params),
            (("x", X), ("lam", Lam)),
            self._definitions(local),
            "",
            "contacts",
            ("x", "lam"),
        )


def _set(robot: Robot) -> str:
    return ", ".join(f"{f} ({k})" for f, k in robot.contacts)


def _labels(kind: str) -> tuple:
    return (
        ("a", "force", "da_dq", "da_dv", "da_dtau", "dforce_dq", "dforce_dv", "dforce_dtau")
        if kind == "fdyn"
        else ("v_after", "impulse", "dv_after_dq", "dv_after_dv", "dimpulse_dq", "dimpulse_dv")
    )


def _doc(kind: str, robot: Robot, n: int, nc: int) -> str:
    return (
        f"Contact dynamics of the set {_set(robot)} and their derivatives: "
        + (
            f"a ({n},), force ({nc},), da_dq, da_dv, da_dtau ({n}, {n}), dforce_dq, dforce_dv, dforce_dtau ({nc}, {n}); "
            "Pinocchio's computeConstraintDynamicsDerivatives"
            if kind == "fdyn"
            else f"v_after ({n},), impulse ({nc},), dv_after_dq, dv_after_dv ({n}, {n}), dimpulse_dq, dimpulse_dv "
            f"({nc}, {n}); d/dv is by v_before"
        )
        + ", d/dq in the tangent space of q."
    )


def _spliced(kind: str, dynamics: Program, residual: Program, shared: frozenset, extra: set) -> tuple:
    """(splice, x, λ, [dr1_dq, dr1_dv, dr2_dq, dr2_dv]): the contact dynamics spliced, then the
    residuals' Jacobians at its solution."""
    inputs = {s.name for _, syms in dynamics.inputs for s in syms} | {a for a, _ in dynamics.inputs}
    labels = _labels(kind)
    splice = Splice(inputs | set(labels) | extra | {f"contact_{kind}_derivatives"})
    x, lam = splice.append(dynamics, {}, "c_", shared)
    x = [splice.name(e, f"c_{labels[0]}{i + 1}") for i, e in enumerate(x)]
    lam = [splice.name(e, f"c_{labels[1]}{i + 1}") for i, e in enumerate(lam)]
    q, v = dynamics.inputs[0][1], dynamics.inputs[1][1]
    rq, rv, rx, rl = (syms for _, syms in residual.inputs[:4])
    rename = {**dict(zip(rq, q)), **dict(zip(rv, v)), **dict(zip(rx, x)), **dict(zip(rl, lam))}
    return splice, x, lam, splice.append(residual, rename, "r_")


def derivatives_program(
    kind: str, dynamics: Program, residual: Program, solve: Program, shared: frozenset, robot: Robot
) -> Program:
    """contact_fdyn_derivatives or contact_impulse_derivatives from the finished programs of the
    contact dynamics, the residuals' Jacobians at its solution and the KKT solve of their columns,
    spliced (`derivatives.Splice`): ∂[x; λ]/∂z = −K⁻¹ ∂r/∂z with K = [M −Jᵀ; J 0], and for fdyn
    ∂[a; f]/∂τ = K⁻¹ [I; 0]."""
    labels = _labels(kind)
    splice, x, lam, (d1q, d1v, d2q, d2v) = _spliced(kind, dynamics, residual, shared, set())
    n, nc = len(x), len(lam)
    q = dynamics.inputs[0][1]
    u = [-e for row in (d1q.row_join(d1v)).tolist() for e in row]
    w = [-e for row in (d2q.row_join(d2v)).tolist() for e in row]
    u = [splice.name(e, f"c_u{k + 1}") for k, e in enumerate(u)]
    w = [splice.name(e, f"c_w{k + 1}") for k, e in enumerate(w)]
    su, sw = solve.inputs[1][1], solve.inputs[2][1]
    dx, dlam = splice.append(
        solve, {**dict(zip(solve.inputs[0][1], q)), **dict(zip(su, u)), **dict(zip(sw, w))}, "s_", shared
    )
    pieces = [dx[:, :n], dx[:, n : 2 * n]] + ([dx[:, 2 * n :]] if kind == "fdyn" else [])
    pieces += [dlam[:, :n], dlam[:, n : 2 * n]] + ([dlam[:, 2 * n :]] if kind == "fdyn" else [])
    outputs = ((labels[0], sp.ImmutableMatrix(x)), (labels[1], sp.ImmutableMatrix(lam)))
    outputs += tuple((label, sp.ImmutableMatrix(m)) for label, m in zip(labels[2:], pieces))
    return Program(
        f"contact_{kind}_derivatives",
        dynamics.inputs,
        splice.live([m for _, m in outputs]),
        outputs,
        _doc(kind, robot, n, nc),
        dynamics.origin,
        frozenset(o for o, _ in outputs[2:]),
    )


#: The outputs of a KKT-parts program (`parts_program`) after the dynamics' two.
PARTS = ("Minv", "XT", "Ainv", "R")
#: What replaces R where it is made in vectors (`ContactSpecs.tangents`): the partials and the turn.
TANGENT_PARTS = ("partials", "turn")
#: What replaces M⁻¹ where the C multiplies out its factors (`derivatives.minv_factors_spec`).
INVERSE_FACTORS = ("Linv", "DLinv")
#: Every output a KKT-parts program may have after the dynamics' two (J: `ContactSpecs.blocks(rows=True)`).
ALL_PARTS = PARTS + TANGENT_PARTS + INVERSE_FACTORS + ("J",)


def parts_program(
    kind: str, dynamics: Program, residual: Program, minv: Program, blocks: Program, shared: frozenset, robot: Robot
) -> Program:
    """What the derivatives need before their dense products, in one straight-line program: the
    dynamics' two outputs, M⁻¹, Xᵀ = J M⁻¹, A⁻¹ and R = [∂r1/∂q ∂r1/∂v; ∂r2/∂q ∂r2/∂v] ((n + nc) ×
    2n, its exact zeros the tree's).  Then K⁻¹ = [P Gᵀ; −G A⁻¹] with G = A⁻¹Xᵀ, P = M⁻¹ − X G,
    ∂[x; λ]/∂z = −K⁻¹R and for fdyn ∂[a; f]/∂τ = [P; −G]: products the C target runs as loops
    the compiler vectorizes (`emit.ckkt`), the leg columns' zeros skipped.  Given the partials'
    program of `ContactSpecs.tangents` as `residual`, R's place takes the local partials and the
    turn's columns (`TANGENT_PARTS`), from which the C makes R in vectors (`tangents.Plan`); given
    `derivatives.minv_factors_spec`'s program as `minv`, M⁻¹'s place takes its factors L⁻¹ and
    D⁻¹L⁻¹ (`INVERSE_FACTORS`), which the C multiplies out in vectors, and given the blocks with
    the rows J (`ContactSpecs.blocks(rows=True)`) the C makes Xᵀ = J M⁻¹ in vectors too."""
    labels = _labels(kind)
    vectors = residual.name.endswith("_partials")  # `ContactSpecs.tangents`: R made in vectors
    splice, x, lam, terms = _spliced(kind, dynamics, residual, shared, set(ALL_PARTS))
    q = dynamics.inputs[0][1]
    inverse = splice.append(minv, dict(zip(minv.inputs[0][1], q)), "m_", shared)
    kkt_blocks = splice.append(blocks, dict(zip(blocks.inputs[0][1], q)), "b_", shared)
    if vectors:
        last = tuple(zip(TANGENT_PARTS, terms))
    else:
        d1q, d1v, d2q, d2v = terms
        last = (("R", sp.ImmutableMatrix(d1q.row_join(d1v).col_join(d2q.row_join(d2v)))),)
    outputs = (
        (labels[0], sp.ImmutableMatrix(x)),
        (labels[1], sp.ImmutableMatrix(lam)),
        *zip([o for o, _ in minv.outputs], inverse),
        *zip([o for o, _ in blocks.outputs], kkt_blocks),
        *last,
    )
    return Program(
        f"contact_{kind}_derivatives",
        dynamics.inputs,
        splice.live([m for _, m in outputs]),
        outputs,
        _doc(kind, robot, len(x), len(lam)),
        dynamics.origin,
        frozenset(o for o, _ in outputs[2:]),
    )


def contact_signatures(robot: Robot) -> dict:
    """{function: (inputs ((name, size), …), outputs ((name, shape), …))} of the contact functions."""
    nq, nv, nc = robot.nq, robot.nv, contact_count(robot)
    square, tall = (nv, nv), (nc, nv)
    state = (("q", nq), ("v", nv), ("tau", nv)) + ((("anchor", anchor_size(robot)),) if robot.baumgarte[0] else ())
    return {
        "contact_fdyn": (state, (("a", (nv,)), ("force", (nc,)))),
        "contact_impulse": ((("q", nq), ("v_before", nv)), (("v_after", (nv,)), ("impulse", (nc,)))),
        "contact_fdyn_derivatives": (
            state,
            (("a", (nv,)), ("force", (nc,)), ("da_dq", square), ("da_dv", square), ("da_dtau", square))
            + (("dforce_dq", tall), ("dforce_dv", tall), ("dforce_dtau", tall)),
        ),
        "contact_impulse_derivatives": (
            (("q", nq), ("v_before", nv)),
            (("v_after", (nv,)), ("impulse", (nc,)), ("dv_after_dq", square), ("dv_after_dv", square))
            + (("dimpulse_dq", tall), ("dimpulse_dv", tall)),
        ),
    }
