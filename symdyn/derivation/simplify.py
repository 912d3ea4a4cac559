"""Simplification: trig folding, parameter collection, significance pruning, op counts.

The simplify stage of model → derive → simplify → program → emit.  Folding
rewrites an expression as an exact trigonometric polynomial (products of
sines and cosines become sines and cosines of sums of angles, S² + C² = 1)
through `symdyn.derivation.trigpoly` — never sympy's `simplify`, which takes minutes on
the Puma.  Collection groups the result by the inertial parameters (the
dynamics are linear in them), then by trig functions.  Pruning is Corke's
significance analysis: terms that never matter over the joint-limit box go.
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import sympy as sp

from ..model import exact_cos_sin
from . import trigpoly
from .program import OpCounter, lower, make_program

if TYPE_CHECKING:  # annotations only: Dynamics.op_count calls into this module
    from .dynamics import Dynamics


def fold(expr: sp.Expr, dyn: Dynamics) -> sp.Expr:
    """expr as an exact trig polynomial in the joint angles (cos(q2 + q3), …)."""
    angles = _angles(dyn)
    expr = sp.sympify(expr)
    if expr.has(sp.sign):  # friction: sign(qd) is a coefficient, not an angle
        signs = sorted(expr.atoms(sp.sign), key=str)
        names = {s: sp.Symbol(f"_sgn{k}") for k, s in enumerate(signs)}
        back = {v: k for k, v in names.items()}
        return trigpoly.fold(expr.xreplace(names), angles).xreplace(back)
    return trigpoly.fold(expr, angles)


def parallel_chains(robot) -> list[tuple[int, ...]]:
    """Runs of consecutive revolute joints with parallel axes (Puma: joints 2, 3),
    as 0-based indices: their angle sums are the natural angles of the arm."""
    mdh = robot.to_modified()
    chains, run = [], []
    for j, link in enumerate(mdh.links):
        if mdh.convention == "general":   # axes along z: parallel when the placement keeps z
            turned = link.origin[0][2] != 0 or link.origin[1][2] != 0
        else:
            turned = isinstance(link.alpha, sp.Basic) or exact_cos_sin(link.alpha)[1] != 0
        parallel = j > 0 and link.is_revolute and mdh.links[j - 1].is_revolute and not turned
        if parallel:
            run = run or [j - 1]
            run.append(j)
        else:
            if len(run) > 1:
                chains.append(tuple(run))
            run = []
    if len(run) > 1:
        chains.append(tuple(run))
    return chains


def _decompose(k: tuple, chains: list) -> list[tuple[tuple[int, ...], int]]:
    """k·q as a short sum of atoms (single angles and parallel-chain sums):
    [(joints, multiplicity)], fewest atoms first, then smallest multiplicities."""
    atoms: list = []
    rest = list(k)
    for chain in chains:
        runs = [chain[a:b] for a in range(len(chain)) for b in range(a + 2, len(chain) + 1)]
        values = sorted({0} | {k[i] for i in chain}, key=lambda v: (abs(v), v))
        best = None
        for ms in itertools.product(values, repeat=len(runs)):
            r = {i: k[i] for i in chain}
            for run, m in zip(runs, ms):
                for i in run:
                    r[i] -= m
            cost = (sum(1 for m in ms if m) + sum(1 for v in r.values() if v),
                    sum(map(abs, ms)) + sum(map(abs, r.values())))
            if best is None or cost < best[0]:
                best = (cost, ms, r)
        _, ms, r = best
        atoms += [(run, m) for run, m in zip(runs, ms) if m]
        for i in chain:
            rest[i] = r[i]
    return atoms + [((i,), m) for i, m in enumerate(rest) if m]


def book_form(expr: sp.Expr, dyn: Dynamics) -> sp.Expr:
    """expr as a polynomial in sines and cosines of natural angles (qᵢ and the
    sums of parallel joints, e.g. q2 + q3), with sin² reduced to 1 − cos²:
    the products a textbook prints (S23·C4·S5), exactly equal to expr."""
    angles = _angles(dyn)
    expr = sp.sympify(expr)
    signs = {s: sp.Symbol(f"_sgn{k}") for k, s in enumerate(sorted(expr.atoms(sp.sign), key=str))}
    space = trigpoly.space_for([expr.xreplace(signs)], angles)
    poly = trigpoly.from_expr(expr.xreplace(signs), space)
    chains = natural_chains(dyn)
    out = []
    for k, kind, coeff in poly.items():
        out.append(coeff.as_expr() * angle_products(tuple(k), kind, chains, tuple(angles)))
    back = {v: k for k, v in signs.items()}
    return sp.expand(sp.Add(*out)).xreplace(back)


def natural_chains(dyn: Dynamics) -> tuple:
    """The parallel chains of `dyn`'s robot as indices into its revolute angles."""
    angles = _angles(dyn)
    return tuple(tuple(angles.index(dyn.q[i]) for i in c) for c in parallel_chains(dyn.robot)
                 if all(dyn.q[i] in angles for i in c))


@functools.lru_cache(maxsize=4096)
def angle_products(k: tuple, kind: str, chains: tuple, angles: tuple) -> sp.Expr:
    """cos(k·θ) or sin(k·θ) as a polynomial in sines and cosines of natural
    angles (single angles and parallel-chain sums), sin² written 1 − cos²:
    the one frequency term of `book_form`, exactly."""
    atoms = _decompose(k, list(chains))
    if not atoms:
        return sp.S.One if kind == "cos" else sp.S.Zero
    phis = [sp.Dummy(f"phi{a}") for a in range(len(atoms))]
    arg = sp.Add(*(m * phi for (_, m), phi in zip(atoms, phis)))
    e = sp.expand(sp.expand_trig(sp.cos(arg) if kind == "cos" else sp.sin(arg)))
    S = [sp.sin(p) for p in phis]
    C = [sp.cos(p) for p in phis]
    poly = sp.Poly(e, *S, *C)
    n = len(phis)
    total = sp.S.Zero
    for monom, c in poly.terms():
        term = c
        for a in range(n):
            es, ec = monom[a], monom[n + a]
            term *= S[a] ** (es % 2) * (1 - C[a] ** 2) ** (es // 2) * C[a] ** ec
        total += term
    real = {phi: sp.Add(*(angles[i] for i in run)) for (run, _), phi in zip(atoms, phis)}
    return sp.expand(total).xreplace(real)


def _angles(dyn: Dynamics) -> list:
    return [q for q, link in zip(dyn.q, dyn.robot.links) if link.is_revolute]


def inertial_symbols(dyn: Dynamics) -> list:
    """Symbols of the robot's masses, inertias and motor parameters (what the
    dynamics are linear in, and what closed forms are collected by)."""
    syms: list = []
    for link in dyn.robot.links:
        for value in (link.m, *[x for row in link.I for x in row], link.Jm, link.B, *link.Tc):
            for s in sorted(getattr(value, "free_symbols", ()), key=str):
                if s not in syms:
                    syms.append(s)
    return syms


FORMS = ("book", "folded")


def tidy(expr: sp.Expr, dyn: Dynamics, form: str = "book") -> sp.Expr:
    """Simplified and collected: by the joint rates (q̈, q̇ products), then by
    the inertial parameters and gravity, then by trig functions.  form="book":
    products of sines and cosines of natural angles (`book_form`);
    "folded": sines and cosines of sums of angles (`fold`)."""
    if form not in FORMS:
        raise ValueError(f"unknown form {form!r}: expected one of {', '.join(FORMS)}")
    expr = book_form(expr, dyn) if form == "book" else fold(expr, dyn)
    rates = list(dyn.qdd) + [a * b for i, a in enumerate(dyn.qd) for b in dyn.qd[i:]] + list(dyn.qd)
    gravity = [s for v in dyn.robot.gravity for s in getattr(v, "free_symbols", ())]
    params = gravity + inertial_symbols(dyn)
    expanded = sp.expand(expr)
    by_rate = sp.collect(expanded, rates, evaluate=False)
    parts = []
    for rate in sorted(by_rate, key=lambda r: (r == 1, sp.default_sort_key(r))):
        coeff = by_rate[rate]
        symbolic = set(dyn.robot.free_symbols)
        if params:
            by_param = sp.collect(coeff, params, evaluate=False)
            coeff = sp.Add(*(k * _trig_collect(v, symbolic) for k, v in by_param.items()))
        else:
            coeff = _trig_collect(coeff, symbolic)
        parts.append(coeff * rate)
    return sp.Add(*parts)


def _trig_collect(expr: sp.Expr, symbolic: set) -> sp.Expr:
    """Group by products of trig functions; factor each coefficient that holds
    the robot's symbols (`group_parameters`).  Numeric coefficients are left
    alone: factoring a polynomial in a prismatic q with rational coefficients
    pulls out a tiny content and leaves giant integers (1.9e-67·(11276…·q3² …))."""
    trig = sorted(expr.atoms(sp.sin, sp.cos), key=sp.default_sort_key)
    if not trig:
        return group_parameters(expr, symbolic)
    groups: dict = {}
    for term in sp.Add.make_args(sp.expand(expr)):
        coeff, monomial = term.as_independent(*trig, as_Add=False)
        groups[monomial] = groups.get(monomial, 0) + coeff
    return sp.Add(*(group_parameters(v, symbolic) * k for k, v in groups.items()))


def group_parameters(expr: sp.Expr, symbolic: set, masses=()) -> sp.Expr:
    """A coefficient in the robot's symbols as a reader groups it: factored;
    a sum in which every term holds exactly one of `masses` (to the first
    power) collected by them, masses outside; elsewhere perfect squares
    completed (a1² + a2² + 2a2c2 + c2² → a1² + (a2 + c2)², the COM distance
    of Eq. 9.3).  Expressions without the robot's symbols, or with more than
    8 symbols, are returned as they are."""
    syms = sorted(expr.free_symbols & symbolic, key=str)
    if not syms or len(expr.free_symbols) > 8:
        return expr
    factored = sp.factor(expr)
    if factored.is_Mul:
        return sp.Mul(*(group_parameters(f, symbolic, masses) if f.is_Add else f for f in factored.args))
    if factored.is_Pow or not expr.is_polynomial(*syms):
        return factored
    expr = sp.expand(expr)
    present = [m for m in masses if m in expr.free_symbols]
    terms = sp.Add.make_args(expr)
    if present and all(sum(sp.degree(t, m) for m in present) == 1 and
                       all(sp.degree(t, m) <= 1 for m in present) for t in terms):
        by_mass = sp.collect(expr, present, evaluate=False)
        return sp.Add(*(m * group_parameters(c, symbolic) for m, c in by_mass.items()))
    return _complete_squares(expr, syms)


def _complete_squares(expr: sp.Expr, syms: list) -> sp.Expr:
    """Rewrite c·(x² + 2xy + y²) inside expr as c·(x + y)², pair by pair."""
    poly = sp.Poly(expr, *syms)
    squares = []
    for a, b in itertools.combinations(range(len(syms)), 2):
        x, y = syms[a], syms[b]
        c = poly.coeff_monomial(x**2)
        if c == 0 or poly.coeff_monomial(y**2) != c or poly.coeff_monomial(x * y) != 2 * c:
            continue
        poly = poly - sp.Poly(c * (x + y) ** 2, *syms)
        squares.append(c * (x + y) ** 2)
    rest = poly.as_expr()
    return sp.Add(*squares, sp.factor(rest) if rest.free_symbols else rest)


# --------------------------------------------------------------------------- pruning

@dataclass(frozen=True)
class PruneReport:
    """What significance pruning did to one term."""

    term: str
    tolerance: float
    dropped: int
    kept: int
    worst_error: float      # max |pruned − full| over the samples, relative to the element scale
    ops_before: dict
    ops_after: dict


def prune(dyn: Dynamics, term: str, tol: float, *, samples: int = 2000, seed: int = 0):
    """Drop terms of each element whose largest magnitude over the joint-limit
    box (|cos|, |sin| ≤ 1, |q̇|, |q̈| ≤ 1) is below tol × the element's scale
    (its largest sampled magnitude).  Returns (pruned matrix, PruneReport)."""
    if not (isinstance(tol, (int, float)) and 0 < tol < 1):
        raise ValueError(f"pruning tolerance must be a number in (0, 1), got {tol!r}")
    dyn.robot.require_numeric("significance pruning")
    mat = dyn.term(term)
    folded = [sp.expand(fold(e, dyn)) for e in mat]
    args = [s for _, syms in dyn.inputs(term) for s in syms]
    rng = np.random.default_rng(seed)
    lo, hi = dyn.robot.qlim.T
    values = {}
    for name, syms in dyn.inputs(term):
        box = rng.uniform(lo, hi, (samples, dyn.n)) if name == "q" else rng.uniform(-1, 1, (samples, dyn.n))
        values.update({s: box[:, i] for i, s in enumerate(syms)})
    sample = [values[s] for s in args]
    pruned, dropped, kept, worst = [], 0, 0, 0.0
    for e in folded:
        full = np.broadcast_to(sp.lambdify(args, e, "numpy")(*sample), (samples,))
        scale = float(np.max(np.abs(full))) if np.size(full) else 0.0
        keep = []
        for t in sp.Add.make_args(e):
            coeff, _ = t.as_independent(*args, as_Add=False)
            bound = abs(float(coeff)) if coeff.is_number else np.inf
            if scale > 0 and bound < tol * scale:
                dropped += 1
            else:
                keep.append(t)
        kept += len(keep)
        new = sp.Add(*keep)
        approx = np.broadcast_to(sp.lambdify(args, new, "numpy")(*sample), (samples,))
        if scale > 0:
            worst = max(worst, float(np.max(np.abs(approx - full))) / scale)
        pruned.append(new)
    result = sp.ImmutableMatrix(mat.rows, mat.cols, pruned)
    before = _count(term, dyn.inputs(term), folded)
    after = _count(term, dyn.inputs(term), pruned)
    return result, PruneReport(term, tol, dropped, kept, worst, before, after)


# --------------------------------------------------------------------------- op counts

def _count(name: str, inputs, exprs, definitions=()) -> dict:
    program = make_program(name, inputs, [(name, sp.Matrix(list(exprs)))], definitions)
    return program.op_count()


def _raw(dyn: Dynamics, term: str) -> dict:
    """Ops of the derivation as it stands: each named intermediate once, no CSE."""
    counter = OpCounter()
    named = dyn.named.get(term)
    if named is None:
        for e in dyn.term(term):
            lower(e, counter)
    else:
        defs = dict(dyn.definitions)
        seen: set = set()
        stack = [s for e in named for s in e.free_symbols if s in defs]
        while stack:
            s = stack.pop()
            if s in seen:
                continue
            seen.add(s)
            lower(defs[s], counter)
            stack.extend(t for t in defs[s].free_symbols if t in defs)
        for e in named:
            lower(e, counter)
    counts = dict(counter.counts)
    counts["total"] = sum(v for k, v in counts.items() if k != "neg")
    return counts


STAGES = ("raw", "cse", "folded", "pruned")


def op_counts(dyn: Dynamics, term: str, stages=STAGES, *, prune_tol: float = 1e-3) -> dict:
    """Operation counts of a term at each stage: raw (as derived), cse (one
    joint CSE), folded (trig-folded, then CSE), pruned (significance-pruned at
    prune_tol, then CSE; numeric robots only)."""
    out = {}
    for stage in stages:
        if stage == "raw":
            out[stage] = _raw(dyn, term)
        elif stage == "cse":
            named = dyn.named.get(term)
            if named is None:
                out[stage] = _count(term, dyn.inputs(term), dyn.term(term))
            else:
                out[stage] = _count(term, dyn.inputs(term), named, dyn.definitions)
        elif stage == "folded":
            out[stage] = _count(term, dyn.inputs(term), [fold(e, dyn) for e in dyn.term(term)])
        elif stage == "pruned":
            out[stage] = prune(dyn, term, prune_tol)[1].ops_after if not dyn.robot.is_symbolic else None
        else:
            raise ValueError(f"unknown stage {stage!r}: expected one of {', '.join(STAGES)}")
    return out
