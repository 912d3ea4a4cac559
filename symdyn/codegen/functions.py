"""Which functions a model's generated code has, and from which expressions.

Between derive and program.  Every derivation offers each term (τ, M, C,
C·q̇, G, F and the bias C·q̇ + G + F = τ(q, q̇, 0)) as a `FunctionSpec`: named
inputs, output expressions, and the intermediates it already named.  When
several derivations are at hand, `choice.programs` takes for each function
the one whose program has the fewest operations.  Forward dynamics is the
chosen M and bias followed by an unrolled LDLᵀ solve, in one program; the
regressor Y (τ = Y·π) is one more spec; the derivatives are in `derivatives`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from ..derivation.dynamics import Dynamics
from ..derivation.program import Program, make_program

__all__ = [
    "SingularMass",
    "FunctionSpec",
    "candidates",
    "fdyn_spec",
    "regressor_spec",
    "elimination_order",
    "ldlt_factor",
    "ldlt_solve",
    "ldlt_inverse",
    "NAMES",
]

NAMES = ("tau", "M", "C", "Cqd", "G", "F", "fdyn")


class SingularMass(ValueError):
    """M(q) is singular for every q (a joint that moves no mass and has no rotor): what solves
    with M (forward dynamics, M⁻¹, contacts) cannot be generated."""


_DOCS = {
    "tau": "Inverse dynamics tau = M(q) qdd + C(q, qd) qd + F(qd) + G(q), ({n},).",
    "M": "Joint-space inertia M(q), ({n}, {n}) row-major, rotor inertia G^2 Jm on the diagonal.",
    "C": "Christoffel Coriolis/centripetal matrix C(q, qd), ({n}, {n}) row-major.",
    "Cqd": "Coriolis/centripetal torques C(q, qd) qd, ({n},).",
    "G": "Gravity load G(q), ({n},): the joint torques that hold the arm still.",
    "F": "Joint friction F(qd) = G^2 B qd + |G| Tc(sign qd), ({n},).",
    "bias": "Bias torques C(q, qd) qd + G(q) + F(qd) = tau(q, qd, 0), ({n},).",
    "fdyn": "Forward dynamics qdd = M(q)^-1 (tau - C(q, qd) qd - F(qd) - G(q)), ({n},), by an unrolled LDL^T of M.",
    "Y": "Joint-torque regressor Y(q, qd, qdd), ({n}, {p}): tau = Y pi with the standard "
    "parameters pi of symdyn.derivation.regressor.parameter_symbols.",
}


@dataclass(frozen=True)
class FunctionSpec:
    """One function to generate: inputs [(argname, symbols)], outputs
    [(outname, Matrix)], definitions [(Symbol, expr)] named by the derivation,
    and `origin`, the derivation it comes from."""

    name: str
    inputs: tuple
    outputs: tuple
    definitions: tuple = ()
    doc: str = ""
    origin: str = ""
    matrices: tuple = ()
    shapes: tuple = ()

    def program(self) -> Program:
        return make_program(
            self.name, self.inputs, self.outputs, self.definitions, self.doc, self.origin, self.matrices, self.shapes
        )

    def fields(self) -> dict:
        """The function's arguments of `make_programs` (all but the definitions)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "definitions"}


def _label(*indices: int, n: int) -> str:
    return ("_" if n > 9 else "").join(str(i + 1) for i in indices)


class _Namer:
    """Definitions of an unrolled factorisation: each non-atomic value gets a
    name stem + its 1-based indices; atoms (exact zeros, ones) stay as they are."""

    def __init__(self, n: int) -> None:
        self.n, self.defs = n, []

    def __call__(self, stem: str, expr, *idx: int):
        expr = sp.sympify(expr)
        if expr.is_Atom:
            return expr
        sym = sp.Symbol(f"{stem}{_label(*idx, n=self.n)}", real=True)
        self.defs.append((sym, expr))
        return sym


def elimination_order(M: sp.Matrix) -> list[int]:
    """An order for the unrolled LDLᵀ of a tree's M: 0…n−1, or n−1…0 (the leaves first,
    as Featherstone's LTDL factorisation) when M's exact zeros make that fill in strictly
    fewer entries of L.  A tree's joints come after the joints they hang from, so leaves
    first fills in nothing and the zeros between branches stay zeros in L, where 0…n−1
    fills in the blocks of the branches above a shared joint.  (Chains keep 0…n−1: their
    generated code is what it was.)"""
    n = M.rows
    pattern = {(i, j) for i in range(n) for j in range(i) if M[i, j] != 0}

    def filled(order: list[int]) -> int:
        where = {k: position for position, k in enumerate(order)}
        edges = {(max(where[i], where[j]), min(where[i], where[j])) for i, j in pattern}
        for k in range(n):  # eliminating k joins every pair of its later neighbours
            later = sorted(i for i, j in edges if j == k)
            edges |= {(b, a) for x, a in enumerate(later) for b in later[x + 1 :]}
        return len(edges)

    forward, backward = list(range(n)), list(range(n - 1, -1, -1))
    return backward if filled(backward) < filled(forward) else forward


def ldlt_factor(M: sp.Matrix, order: Sequence[int] | None = None) -> tuple[list, list, list]:
    """The unrolled LDLᵀ of symmetric positive-definite M: (definitions named
    M21, W21 (= L21·D1), D1, iD1 = 1/D1, L21, …; L as rows of values, 1/D).
    Exact zeros of M propagate, so a sparse M costs less; n divisions.  `order`
    (default 0…n−1, see `elimination_order`): the rows taken in that order, i.e. the
    factor of PMPᵀ, its L and 1/D indexed by position in `order`, its names by M's indices."""
    n = M.rows
    order = list(range(n)) if order is None else list(order)
    name = _Namer(n)
    Ms = [
        [name("M", M[order[i], order[j]], order[i], order[j]) if i >= j else None for j in range(n)] for i in range(n)
    ]
    L = [[sp.S.Zero] * n for _ in range(n)]
    W = [[sp.S.Zero] * n for _ in range(n)]
    iD = [sp.S.Zero] * n
    for j in range(n):
        D = name("D", Ms[j][j] - sp.Add(*(W[j][k] * L[j][k] for k in range(j))), order[j])
        if D == 0:
            joint = order[j] + 1
            raise SingularMass(
                f"M(q) is singular for every q: pivot {joint} of its LDLᵀ is exactly 0 (joint "
                f"{joint} moves no mass and has no rotor inertia); forward dynamics is undefined. "
                "Give a link beyond that joint mass and inertia, or the joint a rotor (Jm and G)"
            )
        iD[j] = name("iD", 1 / D, order[j])
        for i in range(j + 1, n):
            W[i][j] = name("W", Ms[i][j] - sp.Add(*(W[i][k] * L[j][k] for k in range(j))), order[i], order[j])
            L[i][j] = name("L", W[i][j] * iD[j], order[i], order[j])
    return name.defs, L, iD


def ldlt_solve(M: sp.Matrix, r: Sequence, result: str = "x", order: Sequence[int] | None = None) -> tuple[list, list]:
    """x = M⁻¹ r for symmetric positive-definite M by an unrolled LDLᵀ (rows taken in
    `order`, default 0…n−1: see `elimination_order`).

    Returns (definitions, x): the factor's definitions (`ldlt_factor`), z1
    (= L⁻¹r), y1 (= z/D) and the solution {result}1, …; ~n³/6 mul.
    """
    n = M.rows
    order = list(range(n)) if order is None else list(order)
    defs, L, iD = ldlt_factor(M, order)
    name = _Namer(n)
    z: list = []
    for i in range(n):
        z.append(name("z", r[order[i]] - sp.Add(*(L[i][k] * z[k] for k in range(i))), order[i]))
    y = [name("y", z[i] * iD[i], order[i]) for i in range(n)]
    x = [sp.S.Zero] * n
    for i in reversed(range(n)):
        x[i] = name(result, y[i] - sp.Add(*(L[k][i] * x[k] for k in range(i + 1, n))), order[i])
    solution = [sp.S.Zero] * n
    for i, k in enumerate(order):
        solution[k] = x[i]
    return defs + name.defs, solution


def ldlt_inverse(L: list, iD: list, order: Sequence[int] | None = None) -> tuple[list, sp.ImmutableMatrix]:
    """M⁻¹ = L⁻ᵀ D⁻¹ L⁻¹ from the factor of `ldlt_factor` (taken in `order`, the same as
    the factor's): (definitions named Li21 (L⁻¹, unit lower triangular), P21 (= L⁻¹/D),
    Minv21, …; the symmetric matrix, in M's indices).  ~n³/3 mul."""
    n = len(iD)
    order = list(range(n)) if order is None else list(order)
    name = _Namer(n)
    Li, P = _inverse_factor(L, iD, order, name)
    inv = [[sp.S.Zero] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            a, b = order[i], order[j]
            value = name("Minv", sp.Add(*(Li[k][i] * P[k][j] for k in range(i, n))), max(a, b), min(a, b))
            inv[a][b] = inv[b][a] = value
    return name.defs, sp.ImmutableMatrix(inv)


def _inverse_factor(L: list, iD: list, order: list, name: _Namer) -> tuple[list, list]:
    """(L⁻¹, D⁻¹L⁻¹) of the factor, in elimination positions, their entries named Li…, P…"""
    n = len(iD)
    Li = [[sp.S.One if i == j else sp.S.Zero for j in range(n)] for i in range(n)]
    for i in range(n):
        for j in range(i):
            Li[i][j] = name("Li", -sp.Add(*(L[i][k] * Li[k][j] for k in range(j, i))), order[i], order[j])
    P = [[name("P", iD[k] * Li[k][j], order[k], order[j]) for j in range(k + 1)] for k in range(n)]
    return Li, P


def ldlt_inverse_factors(L: list, iD: list, order: Sequence[int] | None = None) -> tuple[list, tuple]:
    """M⁻¹ = L⁻ᵀ D⁻¹ L⁻¹ left as its two factors (`ldlt_inverse`'s names): (definitions, (A, B)),
    n × n, A = (L⁻¹)ᵀ with its rows M's indices and its columns the elimination positions, B = D⁻¹L⁻¹
    with its rows the elimination positions and its columns M's indices, so that row a of M⁻¹ is
    Σₖ A[a, k]·B[k, :] — products a caller runs in vectors."""
    n = len(iD)
    order = list(range(n)) if order is None else list(order)
    name = _Namer(n)
    Li, P = _inverse_factor(L, iD, order, name)
    A = sp.zeros(n, n)
    B = sp.zeros(n, n)
    for k in range(n):
        for j in range(k + 1):
            A[order[j], k] = Li[k][j]
            B[k, order[j]] = P[k][j]
    return name.defs, (sp.ImmutableMatrix(A), sp.ImmutableMatrix(B))


def _params(dyn: Dynamics) -> list:
    return [("p", dyn.params)] if dyn.params else []


def _doc(term: str, dyn: Dynamics, **extra) -> str:
    """The function's docstring (sizes: v's, nv); a symbolic model's last argument p lists its
    parameters, a floating base's docstring says what q and v hold."""
    doc = _DOCS[term].format(n=len(dyn.qd), **extra)
    if dyn.robot.base_joint is not None:  # q and v differ: say which is which
        doc += (
            f" q: ({len(dyn.q)},), the {dyn.robot.base_joint} base's coordinates ({', '.join(s.name for s in dyn.q[: len(dyn.q) - dyn.n])}) "
            f"then the joints'; qd, qdd, tau: ({len(dyn.qd)},), the base's velocity in its own frame first."
        )
    return doc + (f" p = ({', '.join(map(str, dyn.params))})." if dyn.params else "")


def candidates(dyn: Dynamics, origin: str | None = None) -> dict[str, FunctionSpec]:
    """Each term of one derivation as a spec (tau, M, C, Cqd, G, F, bias),
    written in the derivation's named intermediates when it has them;
    `origin` names the derivation in the generated files (default dyn.method)."""
    origin = origin or dyn.method
    out = {}
    for term in ("tau", "M", "C", "Cqd", "G", "F"):
        if term == "C" and dyn.named and "C" not in dyn.named:
            continue  # a recursion without its Christoffel passes: C comes from ½ ∂(C q̇)/∂q̇ (choice.programs)
        named = dyn.named.get(term)
        expr, defs = (dyn.term(term), ()) if named is None else (named, tuple(dyn.definitions))
        out[term] = FunctionSpec(
            term,
            tuple(dyn.inputs(term)),
            ((term, expr),),
            defs,
            _doc(term, dyn),
            origin,
            (term,) if term in ("M", "C") else (),
        )
    zero = {a: sp.S.Zero for a in dyn.qdd}
    tau = out["tau"]
    out["bias"] = FunctionSpec(
        "bias",
        (("q", dyn.q), ("qd", dyn.qd), *_params(dyn)),
        (("bias", tau.outputs[0][1].xreplace(zero)),),
        tuple((s, sp.sympify(e).xreplace(zero)) for s, e in tau.definitions),
        _doc("bias", dyn),
        origin,
    )
    return out


def fdyn_spec(M: FunctionSpec, bias: FunctionSpec, *, tree: bool = False) -> FunctionSpec:
    """Forward dynamics from the specs of M and of the bias: r = τ − bias, then
    the LDLᵀ solve of M q̈ = r, all definitions of one program; `tree`: M is a tree's,
    factored in its `elimination_order` (no fill-in between branches)."""
    Mmat, b = M.outputs[0][1], bias.outputs[0][1]
    n = Mmat.rows
    q, qd = M.inputs[0], bias.inputs[1]
    tau = ("tau", tuple(sp.Symbol(f"tau{_label(i, n=n)}", real=True) for i in range(n)))
    rhs = [sp.Symbol(f"r{_label(i, n=n)}", real=True) for i in range(n)]
    ldl, qdd = ldlt_solve(Mmat, rhs, result="qdd", order=elimination_order(Mmat) if tree else None)
    defs = dict(M.definitions)
    defs.update(bias.definitions)
    defs.update((r, tau[1][i] - b[i]) for i, r in enumerate(rhs))
    defs.update(ldl)
    params = [a for a in M.inputs + bias.inputs if a[0] == "p"][:1]
    origin = M.origin if M.origin == bias.origin else f"M: {M.origin}, bias: {bias.origin}"
    doc = _DOCS["fdyn"].format(n=n) + (f" p = ({', '.join(map(str, params[0][1]))})." if params else "")
    return FunctionSpec(
        "fdyn", (q, qd, tau, *params), (("qdd", sp.ImmutableMatrix(qdd)),), tuple(defs.items()), doc, origin
    )


def regressor_spec(reg, dyn: Dynamics) -> FunctionSpec:
    """Y(q, q̇, q̈) (nv × 14n, a floating base's body columns first: nv × (10 + 14n)) of a
    `symdyn.derivation.regressor.Regressor`, in its named columns."""
    nv, cols = len(dyn.qd), reg.columns
    Y = sp.ImmutableMatrix(nv, len(cols), lambda i, k: cols[k][i])
    return FunctionSpec(
        "Y",
        (("q", dyn.q), ("qd", dyn.qd), ("qdd", dyn.qdd), *_params(dyn)),
        (("Y", Y),),
        tuple(reg.tape.defs.items()),
        _doc("Y", dyn, p=len(cols)),
        "regressor",
        ("Y",),
    )
