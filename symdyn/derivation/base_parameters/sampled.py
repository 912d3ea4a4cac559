"""The inertial regressor evaluated at sample states, over a number field, without sympy.

τ = Y(q, q̇, q̈)·π is linear in Khalil's standard parameters; the columns of
the regressor of link j's parameters are body wrenches of unit parameters
carried inward to the joints.  This module runs that recursion on arrays of
K states at once in one of three fields:

- `Floats`: doubles, for the numeric rank analysis;
- `Modular`: integers modulo the prime 2³¹ − 1, for exact identity checks
  (a rational identity that holds at random points mod p holds over ℚ with
  probability ≥ 1 − degree/p; an independent set of columns mod p is
  independent over ℚ);
- `Rationals`: exact Fractions, for the few exact solves of the analysis.

Sample states have rational cos qᵢ, sin qᵢ ((1 − t²)/(1 + t²), 2t/(1 + t²)),
so the same identity holds in all three.  The link frames are the modified,
axis-along-z frames of both derivations (`kinematics.link_frames` of
`kinematics.along_z(robot)`), each placed in its parent's (a tree's too):
each is a constant rotation R₀ and origin p₀, then a turn about z
(revolute) or a slide along R₀·z (prismatic).

A floating base: frame {0} is the base body's, drawn in a random orientation
(a rational quaternion or yaw: gravity Rᵀ·g₀ in its frame) with random
body-frame velocity and acceleration; its ten columns and the base joint's
rows come first, as in `regressor.regressor`.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import sympy as sp

from ...model import Robot
from .. import floating
from ..kinematics import along_z, link_frames
from ..newton_euler import gravity_in_base
from ..symbols import joint_symbols

__all__ = ["Frame", "frames", "Floats", "Modular", "Rationals", "regressor_columns", "PRIME"]

#: The Mersenne prime 2³¹ − 1: products of two residues fit in a signed 64-bit integer.
PRIME = 2**31 - 1

#: Per link, the ten inertial parameters whose unit wrenches the recursion carries (IA is q̈ⱼ itself).
_IO = {"XX": (0, 0), "XY": (0, 1), "XZ": (0, 2), "YY": (1, 1), "YZ": (1, 2), "ZZ": (2, 2)}


@dataclass(frozen=True)
class Frame:
    """Link i's placement in its parent, exact: R = R0·Rz(qᵢ), p = p0 (revolute) or
    R = R0, p = p0 + qᵢ·R0·z (prismatic); entries are Fractions."""

    R0: tuple
    p0: tuple
    revolute: bool
    parent: int = -1  # the link it hangs on (-1: the base)


def _fraction(x) -> Fraction:
    x = sp.nsimplify(x) if not isinstance(x, sp.Basic) else x
    if not x.is_Rational:
        raise ValueError(f"a link frame has the irrational constant {x}: the sampled analysis needs rational ones")
    return Fraction(int(x.p), int(x.q))


def frames(robot: Robot) -> list[Frame]:
    """The exact constant parts of every link frame of `kinematics.along_z(robot)`.

    Raises:
        ValueError: a symbolic or irrational constant in a placement.
    """
    q = joint_symbols(robot.n)[0]
    out = []
    for qi, f in zip(q, link_frames(along_z(robot), q)):
        revolute = f.S[2] == 1
        at_zero = {sp.cos(qi): 1, sp.sin(qi): 0, qi: 0}
        R0 = f.R.xreplace(at_zero)
        p0 = f.p.xreplace(at_zero)
        if revolute:
            c, s = sp.cos(qi), sp.sin(qi)
            turned = R0 * sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])
            if sp.expand(f.R - turned) != sp.zeros(3, 3) or f.p.free_symbols:
                raise ValueError(f"link frame {qi} is not a constant placement then a turn about z")
        elif f.R.free_symbols or sp.expand(f.p - p0 - qi * R0[:, 2]) != sp.zeros(3, 1):
            raise ValueError(f"link frame {qi} is not a constant placement then a slide along z")
        out.append(
            Frame(
                R0=tuple(tuple(_fraction(R0[r, c]) for c in range(3)) for r in range(3)),
                p0=tuple(_fraction(x) for x in p0),
                revolute=revolute,
                parent=f.parent,
            )
        )
    return out


class Floats:
    """Doubles: states drawn at random, constants rounded."""

    def const(self, x: Fraction):
        return float(x)

    def inverse(self, a):
        return 1 / a

    def reduce(self, a):
        return a

    def states(self, n: int, count: int, rng: random.Random) -> tuple:
        t = np.array([[rng.uniform(-3, 3) for _ in range(count)] for _ in range(n)])
        qd = np.array([[rng.gauss(0, 1) for _ in range(count)] for _ in range(n)])
        qdd = np.array([[rng.gauss(0, 1) for _ in range(count)] for _ in range(n)])
        return (1 - t * t) / (1 + t * t), 2 * t / (1 + t * t), t, qd, qdd


class Modular:
    """Integers modulo PRIME; division by a constant's denominator is its modular inverse."""

    def const(self, x: Fraction) -> int:
        return x.numerator % PRIME * pow(x.denominator % PRIME, -1, PRIME) % PRIME

    def inverse(self, a):
        return np.vectorize(lambda x: pow(int(x), -1, PRIME), otypes=[np.int64])(a % PRIME)

    def reduce(self, a):
        return a % PRIME

    def states(self, n: int, count: int, rng: random.Random) -> tuple:
        def draw():
            return np.array([[rng.randrange(PRIME) for _ in range(count)] for _ in range(n)], dtype=np.int64)

        t, qd, qdd = draw(), draw(), draw()
        inv = np.vectorize(lambda x: pow(int(x), -1, PRIME), otypes=[np.int64])(
            (1 + t * t % PRIME) % PRIME
        )  # 1 + t² ≠ 0 mod p: −1 is no square mod 2³¹ − 1 (p ≡ 3 mod 4)
        return (1 - t * t % PRIME) % PRIME * inv % PRIME, 2 * t % PRIME * inv % PRIME, t, qd, qdd


class Rationals:
    """Exact Fractions (object arrays): small rational states."""

    def const(self, x: Fraction) -> Fraction:
        return x

    def inverse(self, a):
        return np.array([[1 / x for x in row] for row in np.atleast_2d(a)], dtype=object).reshape(np.shape(a))

    def reduce(self, a):
        return a

    def states(self, n: int, count: int, rng: random.Random) -> tuple:
        def draw(lo, hi, den):
            return np.array(
                [[Fraction(rng.randint(lo, hi), rng.randint(1, den)) for _ in range(count)] for _ in range(n)],
                dtype=object,
            )

        t, qd, qdd = draw(-40, 40, 40), draw(-30, 30, 7), draw(-30, 30, 11)
        return (1 - t * t) / (1 + t * t), 2 * t / (1 + t * t), t, qd, qdd


def regressor_columns(robot: Robot, field, count: int, seed: int, links=None) -> np.ndarray:
    """The inertial columns of Y at `count` sample states: an array (columns, nv, count), for each
    of the `links` asked (default all) its 11 in the order of `regressor.INERTIAL` (XX … M, IA);
    link −1 is a floating base's body, with 10 (XX … M; asked first by default).  Rows: the base
    joint's (`floating.rows`), then the joints'.

    Raises:
        ValueError: link −1 asked of a fixed base; a symbolic or irrational constant in a
            placement (`frames`).
    """
    fs = frames(robot)
    n = robot.n
    kind = robot.base_joint
    nb = robot.nv - n
    rng = random.Random(seed)
    cos, sin, q, qd, qdd = field.states(max(n, 1), count, rng)  # a row even without joints: the field's zero
    zero = q[0] * 0
    cos, sin, q, qd, qdd = (a[:n] for a in (cos, sin, q, qd, qdd))
    red, k = field.reduce, field.const
    g0 = [k(_fraction(x)) for x in gravity_in_base(robot)]
    consts = [
        ([[k(x) for x in row] for row in f.R0], [k(x) for x in f.p0], [k(f.R0[r][2]) for r in range(3)]) for f in fs
    ]

    def m(a, b):  # a product, reduced (mod p: before any sum, so that nothing overflows)
        return red(a * b)

    def add(*terms):
        return red(sum(terms))

    def mat_t(R, v):  # Rᵀ·v, R constant
        return [add(*(m(R[r][c], v[r]) for r in range(3))) for c in range(3)]

    def mat(R, v):  # R·v
        return [add(*(m(R[r][c], v[c]) for c in range(3))) for r in range(3)]

    def cross(a, b):
        return [
            red(m(a[1], b[2]) - m(a[2], b[1])),
            red(m(a[2], b[0]) - m(a[0], b[2])),
            red(m(a[0], b[1]) - m(a[1], b[0])),
        ]

    def u_times(U, x):
        return [add(*(m(U[3 * r + c], x[c]) for c in range(3))) for r in range(3)]

    def turn(co, si, v):  # Rz(q)·v
        return [red(m(co, v[0]) - m(si, v[1])), add(m(si, v[0]), m(co, v[1])), v[2]]

    def turn_t(co, si, v):  # Rz(q)ᵀ·v
        return [add(m(co, v[0]), m(si, v[1])), red(m(co, v[1]) - m(si, v[0])), v[2]]

    def u_of(w, dw):  # U = dw× + w×w×, row-major
        sq = [m(x, x) for x in w]
        wxy, wxz, wyz = m(w[0], w[1]), m(w[0], w[2]), m(w[1], w[2])
        return [
            red(-(sq[1] + sq[2])),
            red(wxy - dw[2]),
            add(wxz, dw[1]),
            add(wxy, dw[2]),
            red(-(sq[0] + sq[2])),
            red(wyz - dw[0]),
            red(wxz - dw[1]),
            add(wyz, dw[0]),
            red(-(sq[0] + sq[1])),
        ]

    # the base: at rest (fixed), or the body a base joint moves, in its own frame
    at_rest = ([zero] * 3, [zero] * 3, [zero + g for g in g0], [zero] * 9)
    if kind is not None:
        bcos, bsin, bt, bv, ba = field.states(nb, count, rng)  # drawn after the joints': fixed bases unchanged
        if kind == "free":
            x, y, z, w = bt[0], bt[1], bt[2], bt[3]
            two = field.inverse(add(m(x, x), m(y, y), m(z, z), m(w, w)))
            two = red(2 * two)
            R = [
                [red(1 - m(two, add(m(y, y), m(z, z)))), m(two, red(m(x, y) - m(z, w))), m(two, add(m(x, z), m(y, w)))],
                [m(two, add(m(x, y), m(z, w))), red(1 - m(two, add(m(x, x), m(z, z)))), m(two, red(m(y, z) - m(x, w)))],
                [m(two, red(m(x, z) - m(y, w))), m(two, add(m(y, z), m(x, w))), red(1 - m(two, add(m(x, x), m(y, y))))],
            ]
            gb = mat_t(R, [zero + g for g in g0])
        else:
            gb = turn_t(bcos[0], bsin[0], [zero + g for g in g0])
        lin, ang = floating.spatial(kind, [row for row in bv])
        dlin, dang = floating.spatial(kind, [row for row in ba])
        lin, ang, dlin, dang = ([zero + x for x in vec] for vec in (lin, ang, dlin, dang))
        dV = [add(a, c, g) for a, c, g in zip(dlin, cross(ang, lin), gb)]
        at_rest = (ang, dang, dV, u_of(ang, dang))

    # outward: w, dw, dV (gravity included) and U of every link, in its own frame, from its parent's
    motion, placements = [], []
    for i, (f, (R0, p0, z0)) in enumerate(zip(fs, consts)):
        w, dw, dV, U = at_rest if f.parent < 0 else motion[f.parent]
        p = p0 if f.revolute else [add(p0[r], m(q[i], z0[r])) for r in range(3)]
        a, b, c = mat_t(R0, w), mat_t(R0, dw), mat_t(R0, [add(x, y) for x, y in zip(dV, u_times(U, p))])
        co = si = None
        if f.revolute:
            co, si = cos[i], sin[i]
            wI, dwI, dV = turn_t(co, si, a), turn_t(co, si, b), turn_t(co, si, c)
            w = [wI[0], wI[1], add(wI[2], qd[i])]
            dw = [add(dwI[0], m(wI[1], qd[i])), red(dwI[1] - m(wI[0], qd[i])), add(dwI[2], qdd[i])]
        else:
            w, dw = a, b
            dV = [add(c[0], m(2 * a[1], qd[i])), red(c[1] - m(2 * a[0], qd[i])), add(c[2], qdd[i])]
        motion.append((w, dw, dV, u_of(w, dw)))
        placements.append((R0, p, co, si))

    def unit_wrenches(w, dw, dV, U) -> list:
        out = []
        for r, c in _IO.values():  # a unit inertia tensor entry: n = E·dw + w × (E·w)
            Ew = [w[c] if a == r else w[r] if a == c else zero for a in range(3)]
            Edw = [dw[c] if a == r else dw[r] if a == c else zero for a in range(3)]
            out.append(([add(x, y) for x, y in zip(Edw, cross(w, Ew))], [zero] * 3))
        for axis in range(3):  # a unit first moment: n = e × dV, f = U·e
            e = [zero + (1 if a == axis else 0) for a in range(3)]
            out.append((cross(e, dV), [U[3 * a + axis] for a in range(3)]))
        out.append(([zero] * 3, list(dV)))
        return out

    wanted = ([-1] if kind is not None else []) + list(range(n)) if links is None else list(links)
    if kind is None and -1 in wanted:
        raise ValueError(f"robot {robot.name!r} has a fixed base: no base body's columns (link -1)")
    sizes = [10 if j < 0 else 11 for j in wanted]
    out = np.empty((sum(sizes), robot.nv, count), dtype=zero.dtype)
    start = 0
    for j, size in zip(wanted, sizes):
        columns = out[start : start + size]
        start += size
        columns[:] = 0
        if j < 0:  # the base body's own parameters: its rows only
            for c, (nn, ff) in enumerate(unit_wrenches(*at_rest)):
                columns[c, :nb] = floating.rows(kind, ff, nn)
            continue
        wrenches = unit_wrenches(*motion[j])
        columns[10, nb + j] = qdd[j]
        i = j
        while True:  # down through the links j hangs from: the other joints' entries stay 0
            revolute = fs[i].revolute
            for c, (nn, ff) in enumerate(wrenches):
                columns[c, nb + i] = nn[2] if revolute else ff[2]
            if fs[i].parent < 0 and kind is None:
                break
            R0, p, co, si = placements[i]
            moved = []
            for nn, ff in wrenches:  # R = R0·Rz(q) (revolute) or R0
                if revolute:
                    nn, ff = turn(co, si, nn), turn(co, si, ff)
                ff = mat(R0, ff)
                moved.append(([add(x, y) for x, y in zip(mat(R0, nn), cross(p, ff))], ff))
            wrenches, i = moved, fs[i].parent
            if i < 0:  # on the base body: the base joint's rows
                for c, (nn, ff) in enumerate(wrenches):
                    columns[c, :nb] = floating.rows(kind, ff, nn)
                break
    return out
