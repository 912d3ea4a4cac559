"""Simplification: trig folding, parameter collection, significance pruning, op counts.

The simplify stage of model → derive → simplify → program → emit.  Folding
rewrites an expression as an exact trigonometric polynomial (products of
sines and cosines become sines and cosines of sums of angles, S² + C² = 1)
through `symdyn.trigpoly` — never sympy's `simplify`, which takes minutes on
the Puma.  Collection groups the result by the inertial parameters (the
dynamics are linear in them), then by trig functions.  Pruning is Corke's
significance analysis: terms that never matter over the joint-limit box go.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from . import trigpoly
from .dynamics import Dynamics
from .program import make_program


def fold(expr: sp.Expr, dyn: Dynamics) -> sp.Expr:
    """expr as an exact trig polynomial in the joint angles (cos(q2 + q3), …)."""
    if dyn.robot.links and any(not link.is_revolute for link in dyn.robot.links):
        angles = [q for q, link in zip(dyn.q, dyn.robot.links) if link.is_revolute]
    else:
        angles = list(dyn.q)
    expr = sp.sympify(expr)
    if expr.has(sp.sign):  # friction: sign(qd) is a coefficient, not an angle
        signs = sorted(expr.atoms(sp.sign), key=str)
        names = {s: sp.Symbol(f"_sgn{k}") for k, s in enumerate(signs)}
        back = {v: k for k, v in names.items()}
        return trigpoly.fold(expr.xreplace(names), angles).xreplace(back)
    return trigpoly.fold(expr, angles)


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


def tidy(expr: sp.Expr, dyn: Dynamics) -> sp.Expr:
    """Folded and collected: by the joint rates (q̈, q̇ products), then by the
    inertial parameters and gravity, then by trig functions."""
    expr = fold(expr, dyn)
    rates = list(dyn.qdd) + [a * b for i, a in enumerate(dyn.qd) for b in dyn.qd[i:]] + list(dyn.qd)
    gravity = [s for v in dyn.robot.gravity for s in getattr(v, "free_symbols", ())]
    params = gravity + inertial_symbols(dyn)
    expanded = sp.expand(expr)
    by_rate = sp.collect(expanded, rates, evaluate=False)
    parts = []
    for rate in sorted(by_rate, key=lambda r: (r == 1, sp.default_sort_key(r))):
        coeff = by_rate[rate]
        if params:
            by_param = sp.collect(coeff, params, evaluate=False)
            coeff = sp.Add(*(k * _trig_collect(v) for k, v in by_param.items()))
        else:
            coeff = _trig_collect(coeff)
        parts.append(coeff * rate)
    return sp.Add(*parts)


def _trig_collect(expr: sp.Expr) -> sp.Expr:
    trig = sorted(expr.atoms(sp.sin, sp.cos), key=sp.default_sort_key)
    if not trig:
        return sp.factor(expr) if len(expr.free_symbols) <= 8 else expr
    groups = sp.collect(sp.expand(expr), trig, evaluate=False)
    return sp.Add(*((sp.factor(v) if v.free_symbols else v) * k for k, v in groups.items()))


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
    from .program import OpCounter, lower

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
