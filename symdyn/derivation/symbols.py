"""The joint symbols every derivation and emitter shares: q1…qn, qd1…, qdd1….

One place so that Lagrange, Newton–Euler, the program and the emitters all
speak of the same sympy Symbols.
"""

from __future__ import annotations

import functools

import sympy as sp

from ..model.placement import exact, exact_cos_sin_of

__all__ = ["joint_symbols", "exact", "exact_cos_sin_of"]


@functools.lru_cache(maxsize=None)
def joint_symbols(n: int) -> tuple[tuple[sp.Symbol, ...], tuple[sp.Symbol, ...], tuple[sp.Symbol, ...]]:
    """(q, qd, qdd): three tuples of n real Symbols named q1, qd1, qdd1, … (none for a lone body)"""
    if n < 0:
        raise ValueError(f"the number of joints must be ≥ 0, got n = {n}")
    make = lambda stem: tuple(sp.Symbol(f"{stem}{i + 1}", real=True) for i in range(n))  # noqa: E731
    return make("q"), make("qd"), make("qdd")
