"""The dynamics are linear in the inertial parameters: regressor and base parameters.

τ = Y(q, q̇, q̈)·π with Khalil's standard parameters per link j: XXj, XYj,
XZj, YYj, YZj, ZZj (inertia about the link-frame origin), MXj, MYj, MZj
(first moments m·r), Mj (mass), IAj (rotor inertia G²·Jm, joint side),
FVj (viscous G²·B), FSj and FOj (Coulomb, |G|(Tc⁺ − Tc⁻)/2 and
|G|(Tc⁺ + Tc⁻)/2, multiplying sgn q̇ and sgn² q̇).

Base (identifiable) parameters come from an exact rank analysis: Y is
evaluated at random exact rational states (sin and cos rational), reduced
over QQ, and each dependent column is written exactly in the independent
ones — Gautier's numeric method with Khalil's regrouping as its result.
As in Khalil's work, the parameters refer to modified-DH link frames; for
a standard-DH robot these are the frames of `robot.to_modified()`.
The regrouped parameters give a numeric model with the same joint-space
dynamics and many zero parameters, which the customized recursion skips.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Callable
from fractions import Fraction

import sympy as sp
from sympy.polys.domains import QQ
from sympy.polys.matrices import DomainMatrix
from sympy.printing.pycode import PythonCodePrinter

from .dynamics import rotor_inertia
from .kinematics import link_frames
from ..model import Robot, exact_cos_sin
from .newton_euler import LinkInertia, backward, body_force, forward, gravity_in_base, link_inertias
from .progress import Progress
from .symbols import exact, joint_symbols
from .tape import Tape

INERTIAL = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M", "IA")
FRICTION = ("FV", "FS", "FO")
_IO_INDEX = {"XX": (0, 0), "XY": (0, 1), "XZ": (0, 2), "YY": (1, 1), "YZ": (1, 2), "ZZ": (2, 2)}


def parameter_symbols(n: int) -> tuple[sp.Symbol, ...]:
    """XX1, XY1, …, FO1, XX2, … : 14 per link."""
    return tuple(sp.Symbol(f"{name}{j + 1}", real=True) for j in range(n) for name in INERTIAL + FRICTION)


def parameter_values(robot: Robot) -> tuple:
    """The robot's standard parameters, exact, in the order of parameter_symbols
    (in modified-DH link frames: see the module docstring)."""
    values = []
    robot = robot.to_modified()
    for link, I, Ia in zip(robot.links, link_inertias(robot), rotor_inertia(robot)):
        G, B, (tp, tn) = exact(link.G), exact(link.B), (exact(x) for x in link.Tc)
        values += [
            I.Io[0, 0],
            I.Io[0, 1],
            I.Io[0, 2],
            I.Io[1, 1],
            I.Io[1, 2],
            I.Io[2, 2],
            *I.h,
            I.m,
            Ia,
            G**2 * B,
            sp.Abs(G) * (tp - tn) / 2,
            sp.Abs(G) * (tp + tn) / 2,
        ]
    return tuple(sp.expand(v) for v in values)


def _unit_inertia(name: str) -> LinkInertia:
    Io = sp.zeros(3, 3)
    h = [0, 0, 0]
    m = Ia = sp.S.Zero
    if name in _IO_INDEX:
        i, j = _IO_INDEX[name]
        Io[i, j] = Io[j, i] = 1
    elif name in ("MX", "MY", "MZ"):
        h["XYZ".index(name[1])] = 1
    elif name == "M":
        m = sp.S.One
    return LinkInertia(Io=Io, h=tuple(h), m=m, Ia=Ia)


@dataclass(frozen=True)
class Regressor:
    """Y (n × 14n) with τ = Y·π, its parameter symbols, and the named program
    behind it (tape and column outputs in terms of the tape's names)."""

    robot: Robot
    Y: sp.ImmutableMatrix
    params: tuple
    tape: Tape
    columns: tuple  # per parameter: n expressions in the tape's names


def regressor(robot: Robot, *, progress: bool = False) -> Regressor:
    """The joint-torque regressor of `robot` (geometry numeric or symbolic)."""
    n = robot.n
    q, qd, qdd = joint_symbols(n)
    frames = link_frames(robot.to_modified(), q)
    tape = Tape()
    motions = forward(tape, frames, qd, qdd, gravity_in_base(robot))
    zero_inertia = [_unit_inertia("none")] * n
    params = parameter_symbols(n)
    bar = Progress(f"regressor {robot.name}", n, enabled=progress)
    columns = []
    for j in range(n):
        for name in INERTIAL:
            col = [sp.S.Zero] * n
            if name == "IA":
                col[j] = qdd[j]
            else:
                forces = [None] * n
                forces[j] = body_force(tape, motions[j], _unit_inertia(name), f"{name}_", j + 1)
                col = backward(tape, frames, forces, [0] * n, zero_inertia, tag=f"{name}{j + 1}_", last=j)
            columns.append(tuple(col))
        s = sp.sign(qd[j])
        for expr in (qd[j], s, s**2):
            columns.append(tuple(expr if i == j else sp.S.Zero for i in range(n)))
        bar.step(f"link {j + 1}")
    bar.done()
    Y = sp.ImmutableMatrix(n, len(params), lambda i, k: tape.full(columns[k][i]))
    return Regressor(robot=robot, Y=Y, params=params, tape=tape, columns=tuple(columns))


# --------------------------------------------------------------------------- exact evaluation


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


# --------------------------------------------------------------------------- base parameters


@dataclass(frozen=True)
class BaseParameters:
    """Identifiable parameters: β = P·π, with Y·π = Y[:, independent]·β.

    `expressions[b]` writes β_b in the standard symbols; `values` are the
    robot's; `regrouped` is the full-length parameter vector with β in the
    independent slots and zeros elsewhere (same joint torques).
    """

    params: tuple
    independent: tuple
    expressions: tuple
    values: tuple
    regrouped: tuple


#: Base parameters are exact rational linear algebra on the regressor at sample points; each
#: generic constant rotation (not a multiple of π/2) multiplies the digits of those numbers, so
#: beyond this many such links the analysis takes minutes (a generic 7-joint arm: ~10 min).
GENERIC_TURNS_MAX = 3


def generic_turns(robot: Robot) -> int:
    """How many links of the robot's recursion frames turn by a generic constant rotation."""
    mdh = robot.to_modified()
    if mdh.convention == "general":
        return sum(any(not sp.sympify(x).is_Integer for row in link.origin[:3] for x in row[:3]) for link in mdh.links)
    return sum(
        isinstance(exact_cos_sin(link.alpha)[0], float) for link in mdh.links if not isinstance(link.alpha, sp.Basic)
    )


def base_parameters(
    robot: Robot, reg: Regressor | None = None, *, samples: int | None = None, seed: int = 1
) -> BaseParameters:
    """Exact base parameters of a robot with numeric geometry.

    Only the inertial parameters (XX…M and the rotor inertia IA) are
    regrouped: the rank analysis runs on their columns alone.  The friction
    parameters FV, FS, FO are base parameters as they stand — their columns
    q̇ⱼ, sgn q̇ⱼ and sgn² q̇ⱼ are no combination of inertial ones, even where
    they coincide at the sample points (sgn² q̇ⱼ = 1 there, like a prismatic
    joint's constant gravity column).  The result is verified exactly at
    fresh points; a sample that found a dependency the dynamics do not have
    is retried with more points.
    """
    geometric = [
        x
        for link in robot.links
        for x in (
            link.a,
            link.d,
            link.alpha,
            link.theta,
            link.offset,
            *link.axis,
            *(x for row in link.origin or () for x in row),
        )
    ]
    geometric += [x for row in robot.base for x in row] + list(robot.gravity)
    if any(isinstance(x, sp.Basic) and x.free_symbols for x in geometric):
        raise ValueError(
            "base parameters need numeric geometry and gravity (a, d, α, θ, offset, origin, axis, base, "
            f"gravity); robot {robot.name!r} has symbols there"
        )
    reg = reg or regressor(robot)
    n, p = robot.n, len(reg.params)
    per = len(INERTIAL) + len(FRICTION)
    inertial = [k for k in range(p) if k % per < len(INERTIAL)]
    q, qd, qdd = joint_symbols(n)
    inputs = [f(x) for x in q for f in (sp.cos, sp.sin)] + list(q) + list(qd) + list(qdd)
    flat = [reg.columns[k][i] for k in inertial for i in range(n)]
    evaluate = compile_exact(reg.tape.defs.items(), flat, inputs)
    rng = random.Random(seed)

    def rows(count: int) -> list:
        out = []
        for _ in range(count):
            point = random_rational_point(n, rng)
            values = evaluate(*(Fraction(int(point[x].p), int(point[x].q)) for x in inputs))
            out += [
                [QQ(values[c * n + i].numerator, values[c * n + i].denominator) for c in range(len(inertial))]
                for i in range(n)
            ]
        return out

    samples = samples or max(4, 2 * len(INERTIAL) + 2)
    for _attempt in range(3):
        sample = rows(samples)
        rref, pivots = DomainMatrix(sample, (len(sample), len(inertial)), QQ).rref()
        R = rref.to_Matrix()
        # every column is R's combination of the pivot columns: check at fresh points
        check = DomainMatrix(rows(3), (3 * n, len(inertial)), QQ).to_Matrix()
        if check == check[:, list(pivots)] * R[: len(pivots), :]:
            break
        samples *= 2
    else:
        raise RuntimeError(
            f"base parameters of {robot.name!r}: the rank analysis did not settle after {samples} samples"
        )
    pi = reg.params
    exprs, independent = [], []
    for r, b in enumerate(pivots):
        deps = (R[r, d] * pi[inertial[d]] for d in range(len(inertial)) if d not in pivots and R[r, d] != 0)
        exprs.append(pi[inertial[b]] + sp.Add(*deps))
        independent.append(inertial[b])
    friction = [k for k in range(p) if k % per >= len(INERTIAL)]
    exprs += [pi[k] for k in friction]
    independent += friction
    order = sorted(range(len(independent)), key=independent.__getitem__)
    independent = [independent[i] for i in order]
    exprs = [exprs[i] for i in order]
    subs = dict(zip(pi, parameter_values(robot)))
    values = tuple(sp.expand(e.xreplace(subs)) for e in exprs)
    regrouped = [sp.S.Zero] * p
    for b, v in zip(independent, values):
        regrouped[b] = v
    return BaseParameters(
        params=pi, independent=tuple(independent), expressions=tuple(exprs), values=values, regrouped=tuple(regrouped)
    )


def regrouped_inertias(robot: Robot, base: BaseParameters) -> list[LinkInertia]:
    """Per-link standard parameters with the regrouped values: fewer non-zeros,
    the same joint-space τ, M, C and G (not the same base wrench)."""
    per = len(INERTIAL) + len(FRICTION)
    out = []
    for j in range(robot.n):
        v = dict(zip(INERTIAL, base.regrouped[j * per : j * per + len(INERTIAL)]))
        Io = sp.Matrix([[v["XX"], v["XY"], v["XZ"]], [v["XY"], v["YY"], v["YZ"]], [v["XZ"], v["YZ"], v["ZZ"]]])
        out.append(LinkInertia(Io=Io, h=(v["MX"], v["MY"], v["MZ"]), m=v["M"], Ia=v["IA"]))
    return out
