"""Derivatives of the dynamics as function specs: ∂τ/∂(q, q̇), ∂q̈/∂(q, q̇), M⁻¹.

Between derive and program, beside `functions`.  A Jacobian of a program's
named definitions is accumulated on its graph of local partial derivatives by
eliminating the intermediate vertices in the order that costs fewer products:
first to last (forward mode, each nonzero ∂s/∂x_k a named definition) or last to
first (reverse accumulation, each ∂out/∂s a named definition) — a straight-line
program again, which `make_program` CSEs like any other.  ∂τ/∂(q, q̇), 2n inputs
and n outputs, goes in reverse (the Panda: 4694 operations with τ, not 6357);
the Christoffel C, n inputs, forward.  Coulomb friction's sign(q̇) is held
constant: its derivative is taken as zero everywhere, also at q̇ = 0 where it
does not exist.  Forward dynamics: ∂q̈/∂x = −M⁻¹ ∂τ/∂x at (q, q̇, q̈), spliced
from the finished programs of fdyn, tau_derivatives and M⁻¹ = L⁻ᵀD⁻¹L⁻¹.
Matrices have row i = output i (Pinocchio's layout).
"""

from __future__ import annotations

from typing import Sequence

import sympy as sp

from ..derivation.engine import partials
from ..derivation.floating import bracket_term
from ..derivation.program import Program
from .functions import FunctionSpec, elimination_order, ldlt_factor, ldlt_inverse, ldlt_inverse_factors

__all__ = [
    "forward",
    "reverse",
    "jacobian",
    "tau_derivatives_spec",
    "fdyn_derivatives_program",
    "minv_spec",
    "minv_factors_spec",
    "christoffel_spec",
    "Splice",
]

_DOCS = {
    "tau_derivatives": "Inverse dynamics and its derivatives (tau, dtau_dq, dtau_dqd): ({n},), ({n}, {n}), "
    "({n}, {n}), row i = d tau_i; dtau/dqdd = M. Coulomb friction's derivative is taken "
    "as 0, also at qd = 0.",
    "fdyn_derivatives": "Forward dynamics and its derivatives (qdd, dqdd_dq, dqdd_dqd, Minv): ({n},) and "
    "({n}, {n}) x 3, row i = d qdd_i; dqdd/dtau = Minv. Coulomb friction's derivative "
    "is taken as 0, also at qd = 0.",
    "Minv": "Inverse joint-space inertia M(q)^-1, ({n}, {n}), from the unrolled LDL^T of M.",
}


def _reachable(definitions: dict, roots: Sequence) -> list:
    """The definitions the roots use, in their given (evaluation) order."""
    seen, stack = set(), [s for e in roots for s in sp.sympify(e).free_symbols if s in definitions]
    while stack:
        s = stack.pop()
        if s not in seen:
            seen.add(s)
            stack.extend(t for t in definitions[s].free_symbols if t in definitions and t not in seen)
    return [(s, e) for s, e in definitions.items() if s in seen]


def forward(definitions: Sequence, outputs: Sequence, wrt: Sequence, stem: str = "D") -> tuple[list, list]:
    """Forward-mode derivatives of a straight-line program.

    definitions: [(Symbol, expr)] in evaluation order; outputs: [expr]; wrt:
    the input symbols.  Returns (new definitions, rows): each nonzero ∂s/∂x of
    a definition s is named {stem}{x}_{s} (atoms stay inline), and rows[i][k]
    = ∂outputs[i]/∂wrt[k] in those names.
    """
    index = {x: k for k, x in enumerate(wrt)}
    tangent: dict = {x: {k: sp.S.One} for x, k in index.items()}
    new: list = []

    def derivative(expr) -> dict:
        out: dict = {}
        active = sorted((u for u in expr.free_symbols if tangent.get(u)), key=str)
        for u, pe in zip(active, partials(expr, active)):
            if pe == 0:
                continue
            for k, v in tangent[u].items():
                out[k] = out.get(k, sp.S.Zero) + pe * v
        return out

    defs = dict(definitions)
    for s, e in _reachable(defs, outputs):
        named = {}
        for k, v in sorted(derivative(sp.sympify(e)).items()):
            if v == 0:
                continue
            if v.is_Atom:
                named[k] = v
            else:
                sym = sp.Symbol(f"{stem}{wrt[k].name}_{s.name}", real=True)
                new.append((sym, v))
                named[k] = sym
        if named:
            tangent[s] = named
    rows = []
    for o in outputs:
        d = derivative(sp.sympify(o))
        rows.append([d.get(k, sp.S.Zero) for k in range(len(wrt))])
    return new, rows


def _graph(definitions: Sequence, outputs: Sequence, wrt: Sequence) -> tuple[list, dict]:
    """The active part of a program's graph: [(definition, expr)] that depend on wrt, in
    evaluation order, and {node: [active operands]} for them and for the outputs
    (as the nodes ("out", i))."""
    active, nodes = set(wrt), []
    for s, e in _reachable(dict(definitions), outputs):
        e = sp.sympify(e)
        if any(u in active for u in e.free_symbols):
            active.add(s)
            nodes.append((s, e))
    operands = {s: sorted((u for u in e.free_symbols if u in active), key=str) for s, e in nodes}
    for i, o in enumerate(outputs):
        operands[("out", i)] = sorted((u for u in sp.sympify(o).free_symbols if u in active), key=str)
    return nodes, operands


def _elimination_products(operands: dict, order: Sequence) -> int:
    """Products vertex elimination takes to reduce the graph to inputs → outputs when it
    removes the vertices in `order` (|predecessors| × |successors| each)."""
    pred = {s: set(us) for s, us in operands.items()}
    succ: dict = {}
    for s, us in pred.items():
        for u in us:
            succ.setdefault(u, set()).add(s)
    total = 0
    for v in order:
        P, S = pred.pop(v), succ.pop(v, set())
        total += len(P) * len(S)
        for u in P:
            succ[u].discard(v)
            succ[u].update(S)
        for t in S:
            pred[t].discard(v)
            pred[t].update(P)
    return total


def reverse(definitions: Sequence, outputs: Sequence, wrt: Sequence, stem: str = "d", graph=None) -> tuple[list, list]:
    """Reverse accumulation of a straight-line program's Jacobian: the intermediate
    vertices of its graph of local partials eliminated last to first, so each output's
    sensitivity to a definition s is summed once, named {stem}o{i}_{s}, and reused
    by every input s depends on.  Same arguments and result as `forward`; `graph`:
    the program's `_graph`, when the caller has it already."""
    nodes, operands = graph or _graph(definitions, outputs, wrt)
    taken = {str(s) for s, _ in definitions} | {x.name for x in wrt}
    new: list = []

    def name(expr, label: str):
        if expr.is_Atom or (expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1 and expr.args[1].is_Atom):
            return expr
        unique, k = label, 1
        while unique in taken:
            unique, k = f"{label}_{k}", k + 1
        taken.add(unique)
        sym = sp.Symbol(unique, real=True)
        new.append((sym, expr))
        return sym

    # sens[v][o]: ∂(output o)/∂v over the vertices eliminated so far
    sens: dict = {}
    for i, o in enumerate(outputs):
        for u, pe in zip(operands[("out", i)], partials(o, operands[("out", i)])):
            sens.setdefault(u, {})[i] = pe
    for s, e in reversed(nodes):
        out = {i: name(w, f"{stem}o{i + 1}_{s.name}") for i, w in sorted(sens.pop(s, {}).items()) if w != 0}
        for u, pe in zip(operands[s], partials(e, operands[s]) if out else ()):
            if pe == 0:
                continue
            pe = name(pe, f"{stem}{s.name}_{u.name}")
            acc = sens.setdefault(u, {})
            for i, w in out.items():
                acc[i] = acc.get(i, sp.S.Zero) + pe * w
    rows = [[sp.S.Zero] * len(wrt) for _ in outputs]
    for k, x in enumerate(wrt):
        for i, w in sens.get(x, {}).items():
            rows[i][k] = w
    return new, rows


def jacobian(definitions: Sequence, outputs: Sequence, wrt: Sequence, stem: str = "D") -> tuple[list, list]:
    """The Jacobian of a straight-line program by `forward` or `reverse`, whichever
    vertex elimination order takes fewer products on its graph (forward on ties)."""
    graph = _graph(definitions, outputs, wrt)
    order = [s for s, _ in graph[0]]
    if _elimination_products(graph[1], order[::-1]) < _elimination_products(graph[1], order):
        return reverse(definitions, outputs, wrt, stem="d" + stem, graph=graph)
    return forward(definitions, outputs, wrt, stem=stem)


def _params(spec) -> list:
    """The parameter input of a symbolic model's spec or program ([] for a numeric one)."""
    return [a for a in spec.inputs if a[0] == "p"][:1]


def _doc(name: str, n: int, params: list) -> str:
    return _DOCS[name].format(n=n) + (f" p = ({', '.join(map(str, params[0][1]))})." if params else "")


def _jacobians(tau: FunctionSpec) -> tuple[list, sp.ImmutableMatrix, sp.ImmutableMatrix]:
    """(derivative definitions, ∂τ/∂q, ∂τ/∂q̇) of a τ spec by `jacobian`: nv × nq and nv × nv
    (n × n each on a fixed base)."""
    q, qd = tau.inputs[0][1], tau.inputs[1][1]
    nq, nv = len(q), len(qd)
    defs, rows = jacobian(tau.definitions, list(tau.outputs[0][1]), list(q) + list(qd))
    dq = sp.ImmutableMatrix(nv, nq, lambda i, k: rows[i][k])
    dqd = sp.ImmutableMatrix(nv, nv, lambda i, k: rows[i][nq + k])
    return defs, dq, dqd


def tangent_map(q: Sequence, nv: int, base_joint: str | None) -> sp.ImmutableMatrix:
    """∂(q ⊕ δ)/∂δ at δ = 0 (nq × nv): how the coordinates q move with a velocity δ, i.e.
    q̇ = T(q)·v.  A free base (v in its own frame): ṗ = R(quat)·v_lin and the quaternion
    (x, y, z, w) turns at ½·quat ⊗ (ω, 0); a planar base: (ẋ, ẏ) = R₂(yaw)·v_xy, yaw's rate ω;
    the joints' q̇ = v.  Chain rule for derivatives in the tangent space, as Pinocchio takes them.

    Raises:
        ValueError: an unknown base joint.
    """
    from ..derivation.floating import base_rotation

    q = list(q)
    T = sp.zeros(len(q), nv)
    if base_joint == "free":
        R = base_rotation("free", q[:7])
        x, y, z, w = q[3:7]
        T[:3, :3] = R
        T[3:7, 3:6] = sp.Rational(1, 2) * sp.Matrix([[w, -z, y], [z, w, -x], [-y, x, w], [-x, -y, -z]])
    elif base_joint == "planar":
        c, s = sp.cos(q[2]), sp.sin(q[2])
        T[:3, :3] = sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    elif base_joint is not None:
        raise ValueError(f"unknown base joint {base_joint!r}: expected 'free', 'planar' or None")
    bq, bv = len(q) - nv + {"free": 6, "planar": 3}.get(base_joint, 0), {"free": 6, "planar": 3}.get(base_joint, 0)
    for j in range(nv - bv):
        T[bq + j, bv + j] = 1
    return sp.ImmutableMatrix(T)


def tau_derivatives_spec(tau: FunctionSpec, base_joint: str | None = None) -> FunctionSpec:
    """(τ, ∂τ/∂q, ∂τ/∂q̇)(q, q̇, q̈) from the spec of τ, in one program.  A floating base
    (`base_joint` "free" or "planar"): ∂τ/∂q is nv × nv, in the tangent space — d/dε τ(q ⊕ εδ),
    Pinocchio's computeRNEADerivatives — the coordinates' Jacobian times `tangent_map`."""
    defs, dq, dqd = _jacobians(tau)
    n = dq.rows
    if base_joint is not None:
        T = tangent_map(tau.inputs[0][1], n, base_joint)
        dq = sp.ImmutableMatrix(
            n,
            n,
            lambda i, j: sp.Add(*(dq[i, k] * T[k, j] for k in range(T.rows) if dq[i, k] != 0 and T[k, j] != 0)),
        )
    doc = _doc("tau_derivatives", n, _params(tau))
    if base_joint is not None:
        doc += f" q: ({len(tau.inputs[0][1])},); dtau_dq in the tangent space (d tau(q + dq) with q + dq Pinocchio's integrate)."
    return FunctionSpec(
        "tau_derivatives",
        tau.inputs,
        (("tau", tau.outputs[0][1]), ("dtau_dq", dq), ("dtau_dqd", dqd)),
        tuple(tau.definitions) + tuple(defs),
        doc,
        tau.origin,
        ("dtau_dq", "dtau_dqd"),
    )


def christoffel_spec(cqd: FunctionSpec, M: FunctionSpec, base_joint: str | None = None) -> FunctionSpec:
    """The Christoffel C(q, q̇) as ½ ∂(C q̇)/∂q̇ from the spec of C·q̇: C·q̇ = q̇ᵀΓ_k q̇
    with Γ_k symmetric, so its q̇-Jacobian is 2 Σ_i Γ_kij q̇_i = 2 C exactly — one
    differentiated recursion instead of n(n+1)/2 unit-velocity ones (Panda: 3126
    operations, not 8939).  A floating base's Γ is not symmetric: its base columns add
    ½ M[:, base]·ad(v_base) from the spec of M (`floating.bracket_term`)."""
    qd = cqd.inputs[1][1]
    out = list(cqd.outputs[0][1])
    defs, rows = jacobian(cqd.definitions, out, list(qd), stem="DC")
    C = sp.Matrix(len(out), len(qd), lambda i, j: rows[i][j] / 2)
    shared = dict(cqd.definitions)
    if base_joint is not None:
        C += bracket_term(base_joint, M.outputs[0][1], qd)
        shared.update(M.definitions)
    return FunctionSpec(
        "C",
        cqd.inputs,
        (("C", sp.ImmutableMatrix(C)),),
        tuple(shared.items()) + tuple(defs),
        f"Christoffel Coriolis/centripetal matrix C(q, qd), ({len(qd)}, {len(qd)}) row-major, "
        "as d(C qd)/d qd / 2"
        + (" and the base velocities' brackets." if base_joint else ".")
        + cqd.doc.partition(".")[2],
        f"{cqd.origin}, C = d(C qd)/d qd / 2" + (" + M ad(v_base) / 2" if base_joint else ""),
        ("C",),
    )


def minv_factors_spec(M: FunctionSpec, *, tree: bool = False) -> FunctionSpec:
    """M(q)⁻¹ as its factors (L⁻¹)ᵀ and D⁻¹L⁻¹ (`functions.ldlt_inverse_factors`: outputs "Linv",
    "DLinv"), M's factor named as `minv_spec`'s: what the C target's contact derivatives multiply
    out in vectors."""
    order = elimination_order(M.outputs[0][1]) if tree else None
    factor, L, iD = ldlt_factor(M.outputs[0][1], order)
    inv_defs, (A, B) = ldlt_inverse_factors(L, iD, order)
    return FunctionSpec(
        "Minv_factors",
        M.inputs,
        (("Linv", A), ("DLinv", B)),
        tuple(M.definitions) + tuple(factor + inv_defs),
        "",
        M.origin,
        ("Linv", "DLinv"),
    )


def minv_spec(M: FunctionSpec, *, tree: bool = False) -> FunctionSpec:
    """M(q)⁻¹ from the spec of M: its LDLᵀ, then L⁻ᵀD⁻¹L⁻¹; `tree`: M is a tree's,
    factored in its `elimination_order` (no fill-in between branches)."""
    order = elimination_order(M.outputs[0][1]) if tree else None
    factor, L, iD = ldlt_factor(M.outputs[0][1], order)
    inv_defs, inv = ldlt_inverse(L, iD, order)
    return FunctionSpec(
        "Minv",
        M.inputs,
        (("Minv", inv),),
        tuple(M.definitions) + tuple(factor + inv_defs),
        _doc("Minv", inv.rows, _params(M)),
        M.origin,
        ("Minv",),
    )


class Splice:
    """Straight-line programs appended one after another into one: each assignment
    renamed into the inputs and earlier names, and one whose expression an earlier
    assignment already computes becomes that name (sin q1, M's entries, the
    velocity terms the programs share)."""

    def __init__(self, taken: set) -> None:
        self.assignments: list = []
        self.seen: dict = {}
        self.taken = set(taken)
        self.named: dict = {}  # {derivation's symbol: its spliced name}, for `shared`

    def name(self, expr, stem: str):
        """A symbol holding expr: an atom itself, an earlier name for the same
        expression, or a new assignment named `stem` (made unique)."""
        if expr.is_Atom:
            return expr
        if expr in self.seen:
            return self.seen[expr]
        name, k = stem, 1
        while name in self.taken:
            name, k = f"{stem}_{k}", k + 1
        self.taken.add(name)
        sym = sp.Symbol(name, real=True)
        self.assignments.append((sym, expr))
        self.seen[expr] = sym
        return sym

    def append(self, program: Program, rename: dict, prefix: str, shared: frozenset = frozenset()) -> list:
        """Splice `program` in, its input symbols mapped by `rename`; returns its
        outputs' matrices in the spliced names.  `shared`: a derivation's symbols that hold
        the same value in every program spliced (M's named terms and its LDLᵀ factor in fdyn
        and in Minv): one spliced before is taken as it is, however the programs' CSEs wrote it."""
        rename = dict(rename)
        for sym, expr in program.assignments:
            if sym in shared and sym in self.named:
                rename[sym] = self.named[sym]
                continue
            rename[sym] = self.name(
                expr.xreplace(rename), sym.name if sym.name not in self.taken else prefix + sym.name
            )
            if sym in shared:
                self.named[sym] = rename[sym]
        return [m.xreplace(rename) for _, m in program.outputs]

    def live(self, outputs) -> tuple:
        """The assignments the outputs (matrices) read, in order: a spliced program's
        outputs left unused (tau_derivatives' τ) leave dead assignments behind, which
        compilers warn about (-Wunused-variable) and every target would evaluate."""
        needed = set().union(*(m.free_symbols for m in outputs))
        kept = []
        for sym, expr in reversed(self.assignments):
            if sym in needed:
                needed |= expr.free_symbols
                kept.append((sym, expr))
        return tuple(reversed(kept))


def fdyn_derivatives_program(
    fdyn: Program, tau_derivatives: Program, minv: Program, shared: frozenset = frozenset()
) -> Program:
    """(q̈, ∂q̈/∂q, ∂q̈/∂q̇, M⁻¹)(q, q̇, τ) from the finished programs of fdyn,
    tau_derivatives and Minv: q̈ = fdyn(q, q̇, τ), then ∂q̈/∂x = −M⁻¹ ∂τ/∂x with ∂τ/∂x
    of tau_derivatives at (q, q̇, q̈) — spliced, not re-CSE'd: a 7-joint arm's
    joint CSE of the whole took ~2.7 s for ~3 % fewer operations.  τ, which
    tau_derivatives computes beside its Jacobians, is not an output: its
    assignments are dropped.  `shared`: the symbols of M's spec and of its LDLᵀ factor, which
    fdyn and Minv both compute (`Splice.append`)."""
    q, qd = fdyn.inputs[0][1], fdyn.inputs[1][1]  # then tau (and p, a symbolic model's parameters)
    inputs = {s.name for _, syms in fdyn.inputs for s in syms} | {a for a, _ in fdyn.inputs}
    splice = Splice(inputs | {"qdd", "dqdd_dq", "dqdd_dqd", "Minv", "fdyn_derivatives"})
    (qdd,) = splice.append(fdyn, {}, "f_", shared)
    qdd = [splice.name(e, f"f_qdd{i + 1}") for i, e in enumerate(qdd)]
    tq, tqd, tqdd = (syms for _, syms in tau_derivatives.inputs[:3])
    _, dq, dqd = splice.append(
        tau_derivatives, {**dict(zip(tq, q)), **dict(zip(tqd, qd)), **dict(zip(tqdd, qdd))}, "t_"
    )
    (inv,) = splice.append(minv, dict(zip(minv.inputs[0][1], q)), "m_", shared)
    n = len(qdd)

    def named(stem: str, mat) -> sp.ImmutableMatrix:
        return sp.ImmutableMatrix(n, n, lambda i, k: splice.name(mat[i, k], f"{stem}{i + 1}_{k + 1}"))

    inv, dq, dqd = named("Minv", inv), named("dtau_dq", dq), named("dtau_dqd", dqd)
    outputs = (("qdd", sp.ImmutableMatrix(qdd)), ("dqdd_dq", -(inv * dq)), ("dqdd_dqd", -(inv * dqd)), ("Minv", inv))
    return Program(
        "fdyn_derivatives",
        fdyn.inputs,
        splice.live([m for _, m in outputs]),
        outputs,
        _doc("fdyn_derivatives", n, _params(fdyn)),
        fdyn.origin,
        frozenset(("dqdd_dq", "dqdd_dqd", "Minv")),
    )
