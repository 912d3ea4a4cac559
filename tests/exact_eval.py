"""Exact evaluation of trig expressions at angles whose sine and cosine are rational."""

from fractions import Fraction
from typing import Callable
import random

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from symdyn.derivation.symbols import joint_symbols
from symdyn.derivation.tape import Tape


def rational_angles(n, rng):
    """n angles as (cos, sin) Fractions from t = p/q: ((1−t²)/(1+t²), 2t/(1+t²))."""
    out = []
    for _ in range(n):
        t = Fraction(rng.randint(-30, 30), rng.randint(1, 30))
        out.append(((1 - t * t) / (1 + t * t), 2 * t / (1 + t * t)))
    return out


def _power(z, k):
    """(c + i s)^k for integer k, exactly."""
    c, s = z
    if k < 0:
        c, s, k = c, -s, -k  # |z| = 1: the inverse is the conjugate
    rc, rs = Fraction(1), Fraction(0)
    for _ in range(k):
        rc, rs = rc * c - rs * s, rc * s + rs * c
    return rc, rs


def exact_value(expr, q, angles, values):
    """expr with every sin/cos of an integer combination of q replaced exactly,
    and other symbols from `values` (Fractions); returns a sympy Rational."""
    repl = {}
    for atom in expr.atoms(sp.sin, sp.cos):
        coeffs = sp.Poly(atom.args[0], *q).as_dict()
        c, s = Fraction(1), Fraction(0)
        for monom, k in coeffs.items():
            if sum(monom) == 0:
                raise ValueError(f"constant phase in {atom}")
            i = monom.index(1)
            pc, ps = _power(angles[i], int(k))
            c, s = c * pc - s * ps, c * ps + s * pc
        v = c if isinstance(atom, sp.cos) else s
        repl[atom] = sp.Rational(v.numerator, v.denominator)
    for sym, v in values.items():
        repl[sym] = sp.Rational(v.numerator, v.denominator)
    return sp.sympify(expr).xreplace(repl)


def random_point(robot, rng):
    """Rational angles and rational rates for an exact comparison."""
    from symdyn.derivation.symbols import joint_symbols

    q, qd, qdd = joint_symbols(robot.n)
    values = {}
    for s in list(qd) + list(qdd):
        values[s] = Fraction(rng.randint(-20, 20), rng.randint(1, 9))
    return rational_angles(robot.n, rng), values


__all__ = ["exact_value", "random_point", "rational_angles", "random"]


# The regressor at rational points (the independent check of the base parameters)


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
