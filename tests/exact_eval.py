"""Exact evaluation of trig expressions at angles whose sine and cosine are rational."""

from fractions import Fraction
import random

import sympy as sp


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
