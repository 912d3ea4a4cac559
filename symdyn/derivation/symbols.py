"""The joint symbols every derivation and emitter shares: q1…qn, qd1…, qdd1….

One place so that Lagrange, Newton–Euler, the program and the emitters all
speak of the same sympy Symbols.
"""

from __future__ import annotations

import functools
import math
from fractions import Fraction

import sympy as sp

from ..model import exact_cos_sin


@functools.lru_cache(maxsize=None)
def joint_symbols(n: int) -> tuple[tuple[sp.Symbol, ...], tuple[sp.Symbol, ...], tuple[sp.Symbol, ...]]:
    """(q, qd, qdd): three tuples of n real Symbols named q1, qd1, qdd1, …"""
    if n < 1:
        raise ValueError(f"a robot needs at least one joint, got n = {n}")
    make = lambda stem: tuple(sp.Symbol(f"{stem}{i + 1}", real=True) for i in range(n))  # noqa: E731
    return make("q"), make("qd"), make("qdd")


def exact(x) -> sp.Expr:
    """A model parameter as an exact sympy number: floats become the rational
    of their shortest decimal (0.4318 → 2159/5000), so derivations are exact."""
    if isinstance(x, sp.Basic):
        return x
    if isinstance(x, bool):
        raise ValueError("a parameter cannot be a bool")
    if isinstance(x, int):
        return sp.Integer(x)
    return sp.Rational(repr(float(x)))


def exact_cos_sin_of(angle) -> tuple[sp.Expr, sp.Expr]:
    """cos and sin of a constant angle as exact numbers that lie exactly on the
    unit circle: multiples of π/2 give 0 and ±1, a sympy angle gives cos and
    sin of it, any other float gives ((1 − t²)/(1 + t²), 2t/(1 + t²)) with t
    the exact rational of the double tan(angle/2) — within an ulp of the
    double's cosine and sine, and cos² + sin² = 1 exactly, so the rotations of
    a derivation are exactly orthogonal and derivations that rely on it in
    different ways (composite links, base parameters, Lagrange) agree exactly.
    """
    c, s = exact_cos_sin(angle)
    if not isinstance(c, float):
        return exact(c), exact(s)
    t = sp.Rational(Fraction(math.tan(float(angle) / 2)))
    return (1 - t * t) / (1 + t * t), 2 * t / (1 + t * t)
