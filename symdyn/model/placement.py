"""Exact constant rotations for general joints: `placement(xyz, rpy)`, joint axes.

A general joint (URDF's `<origin xyz rpy>` and `<axis>`) is placed by a
constant transform.  Derivations compare exactly, so constant rotations are
built from exact numbers that are exactly orthogonal: multiples of π/2 give
0 and ±1, any other angle the rational point of the unit circle nearest its
double (`exact_cos_sin_of`), and an axis along ±x, ±y or ±z is exact.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any, Sequence

import numpy as np
import sympy as sp

__all__ = [
    "is_symbolic",
    "walk",
    "rotx",
    "roty",
    "rotz",
    "transl",
    "exact_cos_sin",
    "exact",
    "exact_cos_sin_of",
    "rpy_rotation",
    "placement",
    "axis_rotation",
    "exact_rotation",
    "rational_rotation",
    "compose",
    "joint_motion",
    "link_number",
]


def exact_cos_sin(angle: float | sp.Expr) -> tuple:
    """cos and sin of a constant angle, exact for multiples of π/2.

    The double nearest k·π/2 (within 4 ulp: math.pi/2, -math.pi, 3*math.pi/2 …)
    gives exact integers (cos(π/2) is 0, never 6.1e-17); a sympy expression
    gives sympy's cos/sin; any other float gives floats — a number near k·π/2
    is taken as written (`symdyn.model.snapping` is the rule that snaps what
    files write, and reports it).  Derivations and the reference use this one
    function.

    Returns:
        (cos, sin): ints at multiples of π/2, sympy expressions for a symbolic
        angle, else floats.

    Raises:
        TypeError: an angle that is not a number, a numeric string or a sympy
            expression (Python's `float()`).
        ValueError: a NaN or infinite angle, or a non-numeric string.
    """
    if isinstance(angle, sp.Basic) and not angle.is_Number:
        return sp.cos(angle), sp.sin(angle)
    value = float(angle)
    if not math.isfinite(value):
        raise ValueError(f"the angle must be a finite number, got {angle!r}")
    quarter = value / (math.pi / 2)
    k = round(quarter)
    if abs(quarter - k) <= 4 * 2.0**-52 * max(1, abs(k)):
        return ((1, 0), (0, 1), (-1, 0), (0, -1))[k % 4]
    return math.cos(value), math.sin(value)


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


def _mul(A, B) -> list:
    return [[sum((A[i][k] * B[k][j] for k in range(3)), sp.S.Zero) for j in range(3)] for i in range(3)]


def _axis_rot(axis: str, angle) -> list:
    c, s = exact_cos_sin_of(angle)
    o, z = sp.S.One, sp.S.Zero
    return {
        "x": [[o, z, z], [z, c, -s], [z, s, c]],
        "y": [[c, z, s], [z, o, z], [-s, z, c]],
        "z": [[c, -s, z], [s, c, z], [z, z, o]],
    }[axis]


def rpy_rotation(rpy: Sequence) -> list:
    """URDF's fixed-axis roll, pitch, yaw: Rz(yaw)·Ry(pitch)·Rx(roll), exact."""
    roll, pitch, yaw = rpy
    return _mul(_mul(_axis_rot("z", yaw), _axis_rot("y", pitch)), _axis_rot("x", roll))


def _three_finite(name: str, values: Sequence) -> list:
    """`values` as a list of exactly three entries, each a finite number (a numeric
    string included) or a symbolic sympy expression; else an error naming `name`."""
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__"):
        raise TypeError(f"placement: {name} must be a sequence of three numbers, got {values!r}")
    entries = list(values)
    if len(entries) != 3:
        raise ValueError(f"placement: {name} must have exactly three entries, got {len(entries)}: {values!r}")
    for i, x in enumerate(entries):
        if isinstance(x, sp.Basic) and not x.is_Number:
            continue  # symbolic: kept as it is
        if isinstance(x, (bool, np.bool_)):
            raise ValueError(f"placement: {name}[{i}] must be a number, got the bool {x!r}")
        try:
            value = float(x)
        except (TypeError, ValueError) as e:
            raise type(e)(f"placement: {name}[{i}] must be a number or sympy expression, got {x!r}") from None
        if not math.isfinite(value):
            raise ValueError(f"placement: {name}[{i}] must be finite, got {x!r}")
    return entries


def placement(xyz: Sequence = (0, 0, 0), rpy: Sequence = (0, 0, 0)) -> tuple:
    """The 4×4 transform of URDF's `<origin xyz rpy>`, with exact entries.

    Raises:
        ValueError: xyz or rpy that is not exactly three entries; an entry that is
            a bool, a non-numeric string, NaN or infinite.
        TypeError: xyz or rpy that is not a sequence, or an entry that is not a
            number or sympy expression.
    """
    R = rpy_rotation(_three_finite("rpy", rpy))
    p = [exact(x) for x in _three_finite("xyz", xyz)]
    return tuple(tuple(R[i]) + (p[i],) for i in range(3)) + ((0, 0, 0, 1),)


def axis_rotation(axis: Sequence) -> list:
    """An exact rotation R with R·z along `axis` (a unit 3-vector).

    ±x, ±y, ±z give signed permutations; any other axis Rz(φ)·Ry(θ) with φ, θ
    its spherical angles, so R·z is within an ulp of the axis and exactly unit.
    """
    a = np.array([float(x) for x in axis])
    for k, name in enumerate("xyz"):
        for sign in (1, -1):
            if np.array_equal(a, sign * np.eye(3)[k]):
                if name == "z":
                    return _axis_rot("x", 0 if sign > 0 else math.pi)
                if name == "x":
                    return _axis_rot("y", sign * math.pi / 2)
                return _axis_rot("x", -sign * math.pi / 2)
    phi, theta = math.atan2(a[1], a[0]), math.acos(max(-1.0, min(1.0, a[2])))
    return _mul(_axis_rot("z", phi), _axis_rot("y", theta))


def rational_rotation(R) -> list:
    """The exactly orthogonal rational rotation nearest a float one (within ~1e-16):
    its unit quaternion scaled by 2⁵² and rounded to integers (w, x, y, z) gives
    entries over the one denominator w² + x² + y² + z² — one rotation's worth of
    digits, where a product of generic exact rotations has several."""
    M = np.array([[float(x) for x in row] for row in R])
    # Shepperd: the largest component from the diagonal, the others from off-diagonal sums
    t = (M[0, 0] + M[1, 1] + M[2, 2], M[0, 0], M[1, 1], M[2, 2])
    k = int(np.argmax(t))
    if k == 0:
        w = math.sqrt(1 + t[0]) / 2
        q = (w, (M[2, 1] - M[1, 2]) / (4 * w), (M[0, 2] - M[2, 0]) / (4 * w), (M[1, 0] - M[0, 1]) / (4 * w))
    elif k == 1:
        x = math.sqrt(1 + 2 * M[0, 0] - t[0]) / 2
        q = ((M[2, 1] - M[1, 2]) / (4 * x), x, (M[0, 1] + M[1, 0]) / (4 * x), (M[0, 2] + M[2, 0]) / (4 * x))
    elif k == 2:
        y = math.sqrt(1 + 2 * M[1, 1] - t[0]) / 2
        q = ((M[0, 2] - M[2, 0]) / (4 * y), (M[0, 1] + M[1, 0]) / (4 * y), y, (M[1, 2] + M[2, 1]) / (4 * y))
    else:
        z = math.sqrt(1 + 2 * M[2, 2] - t[0]) / 2
        q = ((M[1, 0] - M[0, 1]) / (4 * z), (M[0, 2] + M[2, 0]) / (4 * z), (M[1, 2] + M[2, 1]) / (4 * z), z)
    W, X, Y, Z = (int(round(v * 2**52)) for v in q)
    N = sp.Integer(W * W + X * X + Y * Y + Z * Z)
    return [
        [(W * W + X * X - Y * Y - Z * Z) / N, 2 * (X * Y - W * Z) / N, 2 * (X * Z + W * Y) / N],
        [2 * (X * Y + W * Z) / N, (W * W - X * X + Y * Y - Z * Z) / N, 2 * (Y * Z - W * X) / N],
        [2 * (X * Z - W * Y) / N, 2 * (Y * Z + W * X) / N, (W * W - X * X - Y * Y + Z * Z) / N],
    ]


def exact_rotation(R: Sequence) -> list:
    """A constant rotation as exact, exactly orthogonal numbers: exact entries
    are kept; a float matrix becomes the nearest rational rotation."""
    if all(isinstance(x, (int, sp.Rational)) for row in R for x in row):
        E = [[exact(x) for x in row] for row in R]
        if sp.Matrix(E) * sp.Matrix(E).T == sp.eye(3):
            return E
    return rational_rotation(R)


# --------------------------------------------------------------------------- what the file readers share

_IDENTITY = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))


def compose(A: tuple, B: tuple) -> tuple:
    """A·B of two 4×4 transforms given as rows (exact numbers stay exact)."""
    return tuple(tuple(sum(A[i][k] * B[k][j] for k in range(4)) for j in range(4)) for i in range(4))


def link_number(x: sp.Expr):
    """A value for a `Link` read from a file: an int, or a float when its decimal is the exact
    value (as a derivation reads it back), else the exact Rational."""
    x = sp.sympify(x)  # the identity's entries are plain ints
    if x.is_Integer:
        return int(x)
    return float(x) if exact(float(x)) == x else x


def joint_motion(kind: str, axis: tuple, value: float) -> tuple:
    """The 4×4 transform of a revolute or prismatic joint along its unit `axis` at `value`
    (exact numbers: ±x, ±y, ±z turn exactly, any other axis by the nearest rational rotation)."""
    if value == 0:
        return _IDENTITY
    if kind == "prismatic":
        p = [exact(a) * exact(value) for a in axis]
        return tuple(tuple(int(i == j) for j in range(3)) + (p[i],) for i in range(3)) + ((0, 0, 0, 1),)
    unit = [k for k in range(3) if axis[k] != 0]
    if len(unit) == 1:  # ±x, ±y, ±z: an exact rotation by the signed angle
        rpy = [0, 0, 0]
        rpy[unit[0]] = float(value) * float(np.sign(axis[unit[0]]))
        R = rpy_rotation(rpy)
    else:  # Rodrigues, then the nearest exactly orthogonal rational rotation
        u = np.array([float(a) for a in axis])
        K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
        R = rational_rotation(np.eye(3) + math.sin(value) * K + (1 - math.cos(value)) * K @ K)
    return tuple(tuple(R[i]) + (sp.S.Zero,) for i in range(3)) + ((0, 0, 0, 1),)


# --------------------------------------------------------------------------- 4×4 transforms


def rotx(angle: Any) -> tuple:
    """4×4 homogeneous rotation about x (exact for multiples of π/2).

    Raises:
        TypeError: an angle that is not a number, a numeric string or a sympy
            expression (`exact_cos_sin`).
        ValueError: a NaN or infinite angle, or a non-numeric string.
    """
    c, s = exact_cos_sin(angle)
    return ((1, 0, 0, 0), (0, c, -s, 0), (0, s, c, 0), (0, 0, 0, 1))


def roty(angle: Any) -> tuple:
    """4×4 homogeneous rotation about y (exact for multiples of π/2).

    Raises:
        TypeError: an angle that is not a number, a numeric string or a sympy
            expression (`exact_cos_sin`).
        ValueError: a NaN or infinite angle, or a non-numeric string.
    """
    c, s = exact_cos_sin(angle)
    return ((c, 0, s, 0), (0, 1, 0, 0), (-s, 0, c, 0), (0, 0, 0, 1))


def rotz(angle: Any) -> tuple:
    """4×4 homogeneous rotation about z (exact for multiples of π/2).

    Raises:
        TypeError: an angle that is not a number, a numeric string or a sympy
            expression (`exact_cos_sin`).
        ValueError: a NaN or infinite angle, or a non-numeric string.
    """
    c, s = exact_cos_sin(angle)
    return ((c, -s, 0, 0), (s, c, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))


def transl(x: Any, y: Any, z: Any) -> tuple:
    """4×4 homogeneous translation."""
    return ((1, 0, 0, x), (0, 1, 0, y), (0, 0, 1, z), (0, 0, 0, 1))


def is_symbolic(x: Any) -> bool:
    """Whether a parameter is a sympy expression other than a number (a symbol to substitute)."""
    return isinstance(x, sp.Basic) and not x.is_Number


def walk(x):
    """The entries of nested tuples (a vector, a matrix, a link's parameters), depth first."""
    if isinstance(x, tuple):
        for e in x:
            yield from walk(e)
    else:
        yield x
