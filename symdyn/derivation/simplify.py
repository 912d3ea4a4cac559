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
from .kinematics import along_z
from .program import OpCounter, lower, make_program

if TYPE_CHECKING:  # annotations only: the dynamics module imports nothing of this one
    from .dynamics import Dynamics


def _coefficients(exprs) -> dict:
    """{atom: a placeholder Symbol} for what a trig polynomial carries as a coefficient but cannot
    write in its ring: friction's sign(q̇), and a free base's 1/|quaternion|² (its rotation holds
    any non-zero quaternion)."""
    found: set = set()
    for e in exprs:
        e = sp.sympify(e)
        found |= e.atoms(sp.sign)
        found |= {p for p in e.atoms(sp.Pow) if p.exp.is_negative and p.base.is_Add and _is_quaternion(p.base)}
    return {a: sp.Symbol(f"_sgn{k}") for k, a in enumerate(sorted(found, key=str))}


def _is_quaternion(expr) -> bool:
    return all(s.name in ("base_qx", "base_qy", "base_qz", "base_qw") for s in expr.free_symbols)


def fold(expr: sp.Expr, dyn: Dynamics) -> sp.Expr:
    """expr as an exact trig polynomial in the joint angles (cos(q2 + q3), …)."""
    angles = _angles(dyn)
    expr = sp.sympify(expr)
    names = _coefficients([expr])  # friction's sign(qd), a quaternion's norm: coefficients, not angles
    back = {v: k for k, v in names.items()}
    return trigpoly.fold(expr.xreplace(names), angles).xreplace(back)


def parallel_chains(robot) -> list[tuple[int, ...]]:
    """Runs of revolute joints with parallel axes, each hanging on the one before (Puma:
    joints 2, 3), as 0-based indices: their angle sums are the natural angles of the arm.
    On a tree a run follows one branch: of a link's parallel children only the first
    continues its run (the runs stay disjoint)."""
    mdh = along_z(robot)
    runs: list[list[int]] = []
    run_of: dict[int, list[int]] = {}
    for j, (link, parent) in enumerate(zip(mdh.links, mdh.parents)):
        if mdh.convention == "general":  # axes along z: parallel when the placement keeps z
            turned = link.origin[0][2] != 0 or link.origin[1][2] != 0
        else:
            turned = isinstance(link.alpha, sp.Basic) or exact_cos_sin(link.alpha)[1] != 0
        if parent < 0 or not (link.is_revolute and mdh.links[parent].is_revolute) or turned:
            continue
        run = run_of.get(parent)
        if run is None:
            run = [parent]
            runs.append(run)
        elif run[-1] != parent:  # the parent's run went on along an earlier child
            continue
        run.append(j)
        run_of[parent] = run_of[j] = run
    return sorted(tuple(run) for run in runs)


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
            cost = (
                sum(1 for m in ms if m) + sum(1 for v in r.values() if v),
                sum(map(abs, ms)) + sum(map(abs, r.values())),
            )
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
    the products a textbook prints (S23·C4·S5), exactly equal to expr.

    Each frequency term of expr's trig polynomial is expanded by
    `angle_terms` in integer arithmetic and the coefficients of equal
    products are summed as polynomials before anything becomes sympy: a
    7-joint G has hundreds of frequency terms, and expanding each through
    sympy's expand_trig took most of a minute."""
    angles = tuple(_angles(dyn))
    expr = sp.sympify(expr)
    signs = _coefficients([expr])
    space = trigpoly.space_for([expr.xreplace(signs)], angles)
    terms = book_terms(trigpoly.from_expr(expr.xreplace(signs), space), natural_chains(dyn))
    out = [coeff.as_expr() * _product_expr(mono, angles) for mono, coeff in terms.items()]
    back = {v: k for k, v in signs.items()}
    return sp.expand(sp.Add(*out)).xreplace(back)


def term_polys(dyn: Dynamics, term: str, budget: int | None = None):
    """[TrigPoly per element, row-major]: a term as exact trig polynomials in
    the revolute angles, folded from the derivation's named intermediates
    where it has them (each definition once, in order: the Panda's
    33,585-term M in a third of a second, where expanding its sympy tree
    first takes seconds and its C minutes), else from the plain matrix.
    Friction's sign(q̇) is a coefficient (a ring generator).  None as soon as
    the folded definitions hold more than `budget` terms in all: the cost of
    folding grows with that sum, so this bounds the time a size check takes."""
    named = dyn.named.get(term)
    if named is None:
        exprs, used = list(dyn.term(term)), []
    else:
        exprs, used = list(named), used_definitions(dyn, named)
    signs = _coefficients(exprs + [d for _, d in used])
    exprs = [e.xreplace(signs) for e in exprs]
    used = [(sym, d.xreplace(signs)) for sym, d in used]
    angles = _angles(dyn)
    names = {sym for sym, _ in used}
    gens = trigpoly.space_for(exprs + [d for _, d in used], angles).gens
    space = trigpoly.TrigSpace(angles, [g for g in gens if g not in names])
    memo: dict = {}
    held = 0
    for sym, definition in used:
        memo[sym] = trigpoly.from_expr(definition, space, memo)
        held += memo[sym].nterms
        if budget is not None and held > budget:
            return None
    return [trigpoly.from_expr(e, space, memo) for e in exprs]


def used_definitions(dyn: Dynamics, exprs) -> list:
    """The derivation's definitions that `exprs` depend on, in derivation order."""
    defs = dict(dyn.definitions)
    needed: set = set()
    stack = [s for e in exprs for s in e.free_symbols if s in defs]
    while stack:
        s = stack.pop()
        if s not in needed:
            needed.add(s)
            stack.extend(t for t in defs[s].free_symbols if t in defs and t not in needed)
    return [(s, d) for s, d in dyn.definitions if s in needed]


def book_terms(poly: trigpoly.TrigPoly, chains: tuple) -> dict:
    """{product key of `angle_terms`: coefficient in poly.space.ring}: a trig
    polynomial as a polynomial in sines and cosines of natural angles (the
    content of `book_form`, before any sympy).  The sums run over plain
    (product key, coefficient monomial) → rational dicts: a ring element per
    product made the Panda's M take half a minute."""
    acc: dict = {}
    for k, kind, coeff in poly.items():
        monomials = list(coeff.items())
        for c, mono in angle_terms(tuple(k), kind, chains):
            for m, x in monomials:
                key = (mono, m)
                acc[key] = acc.get(key, 0) + c * x
    ring = poly.space.ring
    out: dict = {}
    for (mono, m), x in acc.items():
        if x:
            out.setdefault(mono, {})[m] = x
    return {mono: ring.from_dict(d) for mono, d in out.items()}


def closed_size(dyn: Dynamics, term: str, budget: int | None = None) -> int | None:
    """How many terms (coefficient monomial × sine or cosine of an angle sum)
    the term's elements hold as exact trig polynomials, M's upper triangle
    only; None when folding its intermediates exceeds `budget` terms
    (`term_polys`).  The check that decides, in seconds, whether a term is
    printed in closed form: a 7-joint arm's C has ~10⁵ terms."""
    polys = term_polys(dyn, term, budget)
    if polys is None:
        return None
    named = dyn.named.get(term)
    cols = (dyn.term(term) if named is None else named).cols
    return sum(p.nterms for index, p in enumerate(polys) if not (term == "M" and index % cols < index // cols))


def natural_chains(dyn: Dynamics) -> tuple:
    """The parallel chains of `dyn`'s robot as indices into its revolute angles."""
    angles, joints = _angles(dyn), _joint_coordinates(dyn)
    return tuple(
        tuple(angles.index(joints[i]) for i in c)
        for c in parallel_chains(dyn.robot)
        if all(joints[i] in angles for i in c)
    )


def angle_products(k: tuple, kind: str, chains: tuple, angles: tuple) -> sp.Expr:
    """cos(k·θ) or sin(k·θ) as a polynomial in sines and cosines of natural
    angles (single angles and parallel-chain sums), sin² written 1 − cos²:
    the one frequency term of `book_form`, exactly, as sympy."""
    return sp.Add(*(c * _product_expr(mono, angles) for c, mono in angle_terms(k, kind, chains)))


def _product_expr(mono: tuple, angles: tuple) -> sp.Expr:
    """Π sin(φ)^es·cos(φ)^ec over a product key ((run, es, ec), …) of `angle_terms`,
    φ the sum of the run's angles."""
    factors = []
    for run, es, ec in mono:
        phi = sp.Add(*(angles[i] for i in run))
        factors += [sp.sin(phi) ** es, sp.cos(phi) ** ec]
    return sp.Mul(*factors)


@functools.lru_cache(maxsize=1 << 14)
def angle_terms(k: tuple, kind: str, chains: tuple) -> tuple:
    """cos(k·θ) or sin(k·θ) as ((integer coefficient, product key), …): k·θ
    written as a short sum Σ m·φ of natural angles (`_decompose`), expanded by
    the angle-sum formulas, every power of sin φ above one reduced by
    sin² = 1 − cos², which makes the expansion unique.  A product key is
    ((run of angle indices, exponent of sin, exponent of cos), …) over the
    natural angles that occur, in `_decompose`'s order."""
    cos_acc: dict = {(): 1}
    sin_acc: dict = {}
    for run, m in _decompose(k, list(chains)):
        cm, sm = _multiple_angle(m)
        cos_acc, sin_acc = (
            _combine((cos_acc, cm, 1), (sin_acc, sm, -1), run),
            _combine((sin_acc, cm, 1), (cos_acc, sm, 1), run),
        )
    return tuple((c, mono) for mono, c in (cos_acc if kind == "cos" else sin_acc).items() if c)


def _combine(first: tuple, second: tuple, run: tuple) -> dict:
    """a·b ± c·d for the angle-sum formulas, where a, c are expansions over
    earlier natural angles and b, d over the natural angle `run` alone
    ({(es, ec): coeff}): the keys are concatenated, the angles being distinct."""
    out: dict = {}
    for left, right, sign in (first, second):
        for mono, x in left.items():
            for (es, ec), y in right.items():
                key = mono + ((run, es, ec),)
                out[key] = out.get(key, 0) + sign * x * y
    return {key: v for key, v in out.items() if v}


@functools.lru_cache(maxsize=64)
def _multiple_angle(m: int) -> tuple[dict, dict]:
    """cos(mφ) and sin(mφ) as {(exponent of sin φ ∈ {0, 1}, exponent of cos φ): integer}
    (m of either sign), from cos((j+1)φ) = cos jφ·C − sin jφ·S, sin((j+1)φ) =
    sin jφ·C + cos jφ·S and S² = 1 − C²."""
    cos_j, sin_j = {(0, 0): 1}, {}
    for _ in range(abs(m)):
        nxt_cos: dict = {}
        nxt_sin: dict = {}
        for (es, ec), x in cos_j.items():
            _add(nxt_cos, es, ec + 1, x)  # cos jφ · C
            _add_times_sin(nxt_sin, es, ec, x)  # cos jφ · S
        for (es, ec), x in sin_j.items():
            _add_times_sin(nxt_cos, es, ec, -x)  # − sin jφ · S
            _add(nxt_sin, es, ec + 1, x)  # sin jφ · C
        cos_j = {key: v for key, v in nxt_cos.items() if v}
        sin_j = {key: v for key, v in nxt_sin.items() if v}
    if m < 0:
        sin_j = {key: -v for key, v in sin_j.items()}
    return cos_j, sin_j


def _add(acc: dict, es: int, ec: int, x: int) -> None:
    acc[(es, ec)] = acc.get((es, ec), 0) + x


def _add_times_sin(acc: dict, es: int, ec: int, x: int) -> None:
    """acc += x·S^es·C^ec·S, with S² = 1 − C²."""
    if es == 0:
        _add(acc, 1, ec, x)
    else:
        _add(acc, 0, ec, x)
        _add(acc, 0, ec + 2, -x)


def _joint_coordinates(dyn: Dynamics) -> tuple:
    """The joints' coordinates (after a floating base's)."""
    return dyn.q[len(dyn.q) - dyn.robot.n :]


def _angles(dyn: Dynamics) -> list:
    """The coordinates that enter through sines and cosines: a planar base's yaw (a free base's
    quaternion enters as a rational function), then the revolute joints'."""
    yaw = [s for s in dyn.q[: len(dyn.q) - dyn.robot.n] if s.name == "base_yaw"]
    return yaw + [q for q, link in zip(_joint_coordinates(dyn), dyn.robot.links) if link.is_revolute]


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
    present = expanded.free_symbols  # collect substitutes for every product of rates: skip absent ones
    by_rate = sp.collect(expanded, [r for r in rates if r.free_symbols <= present], evaluate=False)
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
    if present and all(
        sum(sp.degree(t, m) for m in present) == 1 and all(sp.degree(t, m) <= 1 for m in present) for t in terms
    ):
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
    worst_error: float  # max |pruned − full| over the samples, relative to the element scale
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
