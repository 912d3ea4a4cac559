"""Exact evaluation at rational points: every cos qᵢ, sin qᵢ, q̇ᵢ, q̈ᵢ a rational number.

The exact rungs of the correctness ladder (Lagrange ≡ Newton–Euler, the fuzz's
exact stage, the base parameters against the symbolic regressor) evaluate
named definitions with Python Fractions at points whose sines and cosines are
rational: ((1 − t²)/(1 + t²), 2t/(1 + t²)).
"""

from __future__ import annotations

import random
from fractions import Fraction
from typing import Callable

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from .symbols import joint_symbols
from .tape import Tape

__all__ = ["rational_angle", "random_rational_point", "compile_exact"]


def rational_angle(rng: random.Random) -> tuple[Fraction, Fraction]:
    """cos and sin of a random angle, both rational: ((1−t²)/(1+t²), 2t/(1+t²))."""
    t = Fraction(rng.randint(-40, 40), rng.randint(1, 40))
    return (1 - t * t) / (1 + t * t), 2 * t / (1 + t * t)


def random_rational_point(n: int, rng: random.Random, symbols=()) -> dict:
    """A substitution making every cos(qᵢ), sin(qᵢ), q̇ᵢ, q̈ᵢ and extra symbol an exact rational."""
    q, qd, qdd = joint_symbols(n)
    point = {}
    for i in range(n):
        c, s = rational_angle(rng)
        point[sp.cos(q[i])] = sp.Rational(c.numerator, c.denominator)
        point[sp.sin(q[i])] = sp.Rational(s.numerator, s.denominator)
        point[q[i]] = sp.Rational(rng.randint(-30, 30), 10)  # prismatic joints: q itself
        point[qd[i]] = sp.Rational(rng.randint(-30, 30), 7)
        point[qdd[i]] = sp.Rational(rng.randint(-30, 30), 11)
    for sym in symbols:
        point[sym] = sp.Rational(rng.randint(1, 30), 13)
    return point


class _FractionPrinter(PythonCodePrinter):
    """Python source in which every rational constant is a Fraction."""

    def _print_Rational(self, expr):
        return f"F({expr.p}, {expr.q})"

    def _print_Integer(self, expr):
        return f"F({expr.p})"


def compile_exact(definitions, outputs, inputs) -> Callable:
    """A function of Fractions (one per input symbol or trig atom, e.g. cos(q1))
    that evaluates named definitions [(Symbol, expr)] exactly and returns the outputs."""
    tape = Tape()
    tape.defs.update(definitions)
    dummies = [sp.Dummy(f"in{k}") for k in range(len(inputs))]
    rename = dict(zip(inputs, dummies))
    defs = [(s, e.xreplace(rename)) for s, e in tape.used_by(outputs)]
    outs = [sp.sympify(o).xreplace(rename) for o in outputs]
    return sp.lambdify(
        dummies,
        outs,
        modules=[{"F": Fraction}],
        printer=_FractionPrinter,
        cse=lambda exprs: (defs, exprs),
        docstring_limit=0,
    )
