"""Contact dynamics, generated: the KKT solve of rigid contacts and the inelastic impact.

Between derive and program, above the joint space and the task space, which it combines: for a
robot's contact set (`Robot.with_contacts`) the constraint rows J (nc × nv) and their drift γ come
from the task-space derivation of the contact frames, world-aligned at each frame (Pinocchio's
LOCAL_WORLD_ALIGNED): a point contact holds its origin's classical acceleration (3 rows), a
surface contact its spatial acceleration (6 rows; the linear part is the classical one less
ω × v).  With M's unrolled LDLᵀ (`functions.ldlt_factor`) and X = M⁻¹Jᵀ, A = J X:

    contact_fdyn(q, v, τ) → (a, λ):  λ = −A⁻¹(J M⁻¹(τ − b) + γ),  a = M⁻¹(τ − b) + X λ
    contact_impulse(q, v⁻) → (v⁺, Λ): Λ = −A⁻¹ J v⁻,  v⁺ = v⁻ + X Λ  (restitution 0)

— Pinocchio's `constraintDynamics` and `impulseDynamics` (M a = τ − b + Jᵀλ, J a + γ = 0;
J v⁺ = 0).  One program each: M and the bias b = τ(q, v, 0) are the chosen ones (`choice`), and
the contact frames' intermediates are renamed k_… so that they meet no name of the dynamics'.
A contact set whose rows are dependent (A singular: two surfaces on one body) is not detected
here: its pivot is zero and the outputs are not finite.
"""

from __future__ import annotations

import sympy as sp

from ..derivation.task_space import derive_task_space
from ..model import Robot
from ..model.frames import CONTACT_KINDS
from .functions import FunctionSpec, _Namer, elimination_order, ldlt_factor

__all__ = ["CONTACT_NAMES", "contact_names", "contact_specs", "contact_count", "contact_signatures"]

CONTACT_NAMES = ("contact_fdyn", "contact_impulse")


def contact_names(robot: Robot) -> tuple[str, ...]:
    """The contact functions of `robot`: both when it has a contact set, none otherwise."""
    return CONTACT_NAMES if robot.contacts else ()


def contact_count(robot: Robot) -> int:
    """nc: the rows of the contact set (3 per point, 6 per surface)."""
    return sum(CONTACT_KINDS[kind] for _, kind in robot.contacts)


def _rows(robot: Robot) -> tuple[list, list, list, tuple]:
    """(J rows, γ, the definitions they use renamed k_…, the velocity symbols) of the contact set."""
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
    return rows, gamma, defs, (ts.q, ts.v)


def _solve(L: list, iD: list, order: list, rhs: list, name: _Namer, stem: str, col: int) -> list:
    """x = M⁻¹ rhs by the factor (L, 1/D) of `ldlt_factor` taken in `order`, named kkt_{stem}{col}_{i}."""
    n = len(iD)
    z: list = []
    for i in range(n):
        z.append(name(f"kkt_{stem}z{col}_", rhs[order[i]] - sp.Add(*(L[i][k] * z[k] for k in range(i))), order[i]))
    y = [name(f"kkt_{stem}y{col}_", z[i] * iD[i], order[i]) for i in range(n)]
    x = [sp.S.Zero] * n
    for i in reversed(range(n)):
        x[i] = name(f"kkt_{stem}{col}_", y[i] - sp.Add(*(L[k][i] * x[k] for k in range(i + 1, n))), order[i])
    out = [sp.S.Zero] * n
    for i, k in enumerate(order):
        out[k] = x[i]
    return out


def _small_factor(A: sp.Matrix, name: _Namer) -> tuple[list, list, list]:
    """The unrolled LDLᵀ of the contact set's A (nc × nc), its names prefixed kkt_K (M's factor has
    the plain ones): (definitions, L, 1/D)."""
    defs, L, iD = ldlt_factor(A)
    rename = {s: sp.Symbol(f"kkt_K{s.name}", real=True) for s, _ in defs}
    defs = [(rename[s], e.xreplace(rename)) for s, e in defs]
    L = [[sp.sympify(x).xreplace(rename) for x in row] for row in L]
    return defs, L, [sp.sympify(x).xreplace(rename) for x in iD]


def contact_specs(robot: Robot, M: FunctionSpec, bias: FunctionSpec, *, tree: bool) -> dict[str, FunctionSpec]:
    """The specs of contact_fdyn and contact_impulse from the chosen M and bias (see the module)."""
    rows, gamma, kdefs, _ = _rows(robot)
    Mmat, b = M.outputs[0][1], list(bias.outputs[0][1])
    n, nc = Mmat.rows, len(rows)
    q, v = M.inputs[0], bias.inputs[1]
    mdefs, L, iD = ldlt_factor(Mmat, elimination_order(Mmat) if tree else None)
    order = elimination_order(Mmat) if tree else list(range(n))
    name = _Namer(max(n, nc))
    X = [_solve(L, iD, order, rows[c], name, "X", c + 1) for c in range(nc)]  # columns of M⁻¹Jᵀ
    A = sp.Matrix(
        nc, nc, lambda i, j: name("kkt_A", sp.Add(*(rows[i][k] * X[j][k] for k in range(n))), i, j) if i >= j else 0
    )
    A = sp.Matrix(nc, nc, lambda i, j: A[max(i, j), min(i, j)])
    adefs, AL, AiD = _small_factor(A, name)
    aorder = list(range(nc))
    base = list(M.definitions) + list(bias.definitions) + kdefs + mdefs

    def specs_of(kind: str) -> FunctionSpec:
        local = _Namer(max(n, nc))
        if kind == "fdyn":
            tau = tuple(sp.Symbol(f"tau{i + 1}", real=True) for i in range(n))
            r = [local("kkt_r", tau[i] - b[i], i) for i in range(n)]
            y = _solve(L, iD, order, r, local, "u", 0)
            rhs = [local("kkt_g", sp.Add(*(rows[i][k] * y[k] for k in range(n))) + gamma[i], i) for i in range(nc)]
            inputs, start = (q, ("v", v[1]), ("tau", tau)), y
        else:
            rhs = [local("kkt_g", sp.Add(*(rows[i][k] * v[1][k] for k in range(n))), i) for i in range(nc)]
            inputs, start = (q, ("v_before", v[1])), list(v[1])
        lam = _solve(AL, AiD, aorder, rhs, local, "lam", 0)
        lam = [local("kkt_lam", -x, i) for i, x in enumerate(lam)]
        out = [local("kkt_out", start[k] + sp.Add(*(X[c][k] * lam[c] for c in range(nc))), k) for k in range(n)]
        defs = dict(base)
        defs.update(name.defs)
        defs.update(adefs)
        defs.update(local.defs)
        label = ("a", "force") if kind == "fdyn" else ("v_after", "impulse")
        doc = f"Contact dynamics of the set {', '.join(f'{f} ({k})' for f, k in robot.contacts)}: " + (
            f"a ({n},) and the contact forces ({nc},), world axes at each frame, of M a = tau - b + J^T f, "
            "J a + gamma = 0 (Pinocchio's constraintDynamics)."
            if kind == "fdyn"
            else f"the velocity after an inelastic impact ({n},) and the impulses ({nc},): J v+ = 0 "
            "(impulseDynamics, restitution 0)."
        )
        params = [a for a in M.inputs + bias.inputs if a[0] == "p"][:1]
        return FunctionSpec(
            f"contact_{kind}",
            (*inputs, *params),
            ((label[0], sp.ImmutableMatrix(out)), (label[1], sp.ImmutableMatrix(lam))),
            tuple(defs.items()),
            doc,
            f"contacts; M: {M.origin}, bias: {bias.origin}",
        )

    return {"contact_fdyn": specs_of("fdyn"), "contact_impulse": specs_of("impulse")}


def contact_signatures(robot: Robot) -> dict:
    """{function: (inputs ((name, size), …), outputs ((name, shape), …))} of the contact functions."""
    nq, nv, nc = robot.nq, robot.nv, contact_count(robot)
    return {
        "contact_fdyn": ((("q", nq), ("v", nv), ("tau", nv)), (("a", (nv,)), ("force", (nc,)))),
        "contact_impulse": ((("q", nq), ("v_before", nv)), (("v_after", (nv,)), ("impulse", (nc,)))),
    }
