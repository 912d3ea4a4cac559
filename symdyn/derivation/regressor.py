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
a standard-DH robot these are the frames of `robot.to_modified()`
(`kinematics.along_z` for a tree, whose links hand what their joints cannot
move to their parents).
The regrouped parameters give a numeric model with the same joint-space
dynamics and many zero parameters, which the customized recursion skips.

A floating base (`robot.base_joint`): π starts with the base body's ten
parameters XX0, XY0, XZ0, YY0, YZ0, ZZ0, MX0, MY0, MZ0, M0 (in frame {0},
the body's own; no rotor, no friction), then each link's fourteen; Y has
nv rows, the base joint's first (`floating.rows`: the force and moment on
the base body, in its frame).  Links on the base hand what their joints
cannot move to the base body; which of its parameters the base joint moves
(all ten on a free base, fewer on a planar one) the rank analysis decides.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from . import floating
from .dynamics import rotor_inertia
from .kinematics import along_z, link_frames
from ..model import Robot, exact_cos_sin
from .newton_euler import (
    LinkInertia,
    backward,
    base_inertia,
    base_motion,
    body_force,
    forward,
    gravity_in_base,
    link_inertias,
)
from .progress import Progress
from .symbols import exact, joint_symbols
from .tape import Tape

INERTIAL = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M", "IA")
FRICTION = ("FV", "FS", "FO")
_IO_INDEX = {"XX": (0, 0), "XY": (0, 1), "XZ": (0, 2), "YY": (1, 1), "YZ": (1, 2), "ZZ": (2, 2)}


#: The base body's standard parameters (a floating base's): a link's inertial ones without the rotor.
BODY = INERTIAL[:10]


def parameter_symbols(n: int, floating: bool = False) -> tuple[sp.Symbol, ...]:
    """XX1, XY1, …, FO1, XX2, … : 14 per link; `floating`: the base body's XX0 … M0 first."""
    body = tuple(sp.Symbol(f"{name}0", real=True) for name in BODY) if floating else ()
    return body + tuple(sp.Symbol(f"{name}{j + 1}", real=True) for j in range(n) for name in INERTIAL + FRICTION)


def body_count(robot: Robot) -> int:
    """How many of π's parameters belong to the base body: 10 on a floating base, else 0
    (link j's parameters start at body_count + 14·j)."""
    return len(BODY) if robot.base_joint is not None else 0


def parameter_values(robot: Robot) -> tuple:
    """The robot's standard parameters, exact, in the order of parameter_symbols
    (in modified-DH link frames: see the module docstring; a floating base's body first)."""
    values = []
    robot = along_z(robot)
    if robot.base_joint is not None:
        body = base_inertia(robot)
        values += [body.Io[i, j] for i, j in _IO_INDEX.values()] + [*body.h, body.m]
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
    """τ = Y·π: its parameter symbols and the named program behind Y (tape and
    column outputs in terms of the tape's names).  `q`, `qd`, `qdd` are Y's inputs:
    the joints' symbols, a floating base's (`floating.base_symbols`) first."""

    robot: Robot
    params: tuple
    tape: Tape
    columns: tuple  # per parameter: nv expressions in the tape's names
    q: tuple = ()
    qd: tuple = ()
    qdd: tuple = ()

    @property
    def Y(self) -> sp.ImmutableMatrix:
        """Y (nv × len(params)) written out in full, the names substituted: for small arms (it
        grows exponentially with the joints; code generation uses the named columns)."""
        return sp.ImmutableMatrix(self.robot.nv, len(self.params), lambda i, k: self.tape.full(self.columns[k][i]))


def regressor(robot: Robot, *, progress: bool = False) -> Regressor:
    """The joint-torque regressor of `robot` (geometry numeric or symbolic): τ = Y·π with π
    in the order of `parameter_symbols(robot.n, floating)`.  A floating base: its body's ten
    columns first and its rows first (each column's force and moment on the base body, what the
    links hand it included), in the base's body-frame velocities (`floating.base_symbols`)."""
    n = robot.n
    q, qd, qdd = joint_symbols(n)
    frames = link_frames(along_z(robot), q)
    tape = Tape()
    kind = robot.base_joint
    g0 = gravity_in_base(robot)
    params = parameter_symbols(n, kind is not None)
    columns = []
    inputs = (q, qd, qdd)
    base_mo = None
    if kind is not None:
        qb, vb, ab = floating.base_symbols(kind)
        gb = tape.vector(list(floating.base_rotation(kind, qb).T * sp.Matrix(g0)), "gb")
        base_mo = base_motion(tape, kind, vb, ab, gb)
        inputs = (qb + q, vb + qd, ab + qdd)
        for name in BODY:
            nn, ff = body_force(tape, base_mo, _unit_inertia(name), f"{name}_", 0)
            rows = [tape.name(x, f"{name}0_r{r}") for r, x in enumerate(floating.rows(kind, ff, nn))]
            columns.append(tuple(rows) + (sp.S.Zero,) * n)
    motions = forward(tape, frames, qd, qdd, g0, base=base_mo)
    zero_inertia = [_unit_inertia("none")] * n
    bar = Progress(f"regressor {robot.name}", n, enabled=progress)
    for j in range(n):
        for name in INERTIAL:
            col = [sp.S.Zero] * n
            on_base = [] if kind is None else [sp.S.Zero] * len(floating.BASE_VELOCITIES[kind])
            if name == "IA":
                col[j] = qdd[j]
            else:
                forces = [None] * n
                forces[j] = body_force(tape, motions[j], _unit_inertia(name), f"{name}_", j + 1)
                total = None if kind is None else [[0, 0, 0], [0, 0, 0]]
                tag = f"{name}{j + 1}_"
                col = backward(tape, frames, forces, [0] * n, zero_inertia, tag=tag, last=j, base=total)
                if kind is not None:
                    n0, f0 = tape.vector(total[0], f"{tag}n0"), tape.vector(total[1], f"{tag}f0")
                    on_base = floating.rows(kind, f0, n0)
            columns.append(tuple(on_base) + tuple(col))
        s = sp.sign(qd[j])
        pad = (sp.S.Zero,) * (robot.nv - n)
        for expr in (qd[j], s, s**2):
            columns.append(pad + tuple(expr if i == j else sp.S.Zero for i in range(n)))
        bar.step(f"link {j + 1}")
    bar.done()
    return Regressor(
        robot=robot, params=params, tape=tape, columns=tuple(columns), q=inputs[0], qd=inputs[1], qdd=inputs[2]
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


def generic_turns(robot: Robot) -> int:
    """How many links of the robot's recursion frames turn by a generic constant rotation."""
    mdh = along_z(robot)
    if mdh.convention == "general":
        return sum(any(not sp.sympify(x).is_Integer for row in link.origin[:3] for x in row[:3]) for link in mdh.links)
    return sum(
        isinstance(exact_cos_sin(link.alpha)[0], float) for link in mdh.links if not isinstance(link.alpha, sp.Basic)
    )


def base_parameters(robot: Robot, *, seed: int = 1) -> BaseParameters:
    """Exact base parameters of a robot with numeric geometry (`symdyn.derivation.base_parameters`:
    Khalil's rules, a rank analysis in doubles, exact checks modulo a prime).

    Only the inertial parameters (XX…M and the rotor inertia IA) are
    regrouped.  The friction parameters FV, FS, FO are base parameters as
    they stand — their columns q̇ⱼ, sgn q̇ⱼ and sgn² q̇ⱼ are no combination of
    inertial ones.  A floating base: the base body's parameters come first and
    take what the links on it cannot move; on a free base all ten of them are
    identifiable, on a planar base those the plane's motion does not see drop out.

    Raises:
        ValueError: symbols in the geometry or gravity.
        RuntimeError: the exact checks refuse the numeric rank analysis.
    """
    from .base_parameters import analyse

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
    n = robot.n
    per = len(INERTIAL) + len(FRICTION)
    off = body_count(robot)
    pi = parameter_symbols(n, off > 0)
    analysis = analyse(robot, per, seed)
    friction = [k for k in range(off, len(pi)) if (k - off) % per >= len(INERTIAL)]
    independent = sorted(analysis.independent + friction)
    exprs = [
        sp.Add(*(sp.Rational(c.numerator, c.denominator) * pi[k] for k, c in sorted(analysis.combos[b].items())))
        if b in analysis.combos
        else pi[b]
        for b in independent
    ]
    subs = dict(zip(pi, parameter_values(robot)))
    values = tuple(sp.expand(e.xreplace(subs)) for e in exprs)
    regrouped = [sp.S.Zero] * len(pi)
    for b, v in zip(independent, values):
        regrouped[b] = v
    return BaseParameters(
        params=pi, independent=tuple(independent), expressions=tuple(exprs), values=values, regrouped=tuple(regrouped)
    )


def _regrouped(values: dict) -> LinkInertia:
    v = values
    Io = sp.Matrix([[v["XX"], v["XY"], v["XZ"]], [v["XY"], v["YY"], v["YZ"]], [v["XZ"], v["YZ"], v["ZZ"]]])
    return LinkInertia(Io=Io, h=(v["MX"], v["MY"], v["MZ"]), m=v["M"], Ia=v.get("IA", sp.S.Zero))


def _check_length(robot: Robot, base: BaseParameters) -> None:
    want = body_count(robot) + robot.n * (len(INERTIAL) + len(FRICTION))
    if len(base.regrouped) != want:
        raise ValueError(
            f"base parameters of {len(base.regrouped)} standard slots do not fit robot {robot.name!r} "
            f"({want}: base_parameters(robot) of this robot)"
        )


def regrouped_inertias(robot: Robot, base: BaseParameters) -> list[LinkInertia]:
    """Per-link standard parameters with the regrouped values: fewer non-zeros,
    the same joint-space τ, M, C and G (not the same base wrench).  A floating base's
    body has its own (`regrouped_base_body`).

    Raises:
        ValueError: `base` belongs to a robot with another number of parameters.
    """
    _check_length(robot, base)
    per, off = len(INERTIAL) + len(FRICTION), body_count(robot)
    return [
        _regrouped(dict(zip(INERTIAL, base.regrouped[off + j * per : off + j * per + len(INERTIAL)])))
        for j in range(robot.n)
    ]


def regrouped_base_body(robot: Robot, base: BaseParameters) -> LinkInertia:
    """The base body's standard parameters with the regrouped values (a floating base): with
    `regrouped_inertias`, the same τ, M, C·v and G, base rows included.

    Raises:
        ValueError: a fixed base (no base body), or `base` belongs to another robot's layout.
    """
    if robot.base_joint is None:
        raise ValueError(f"robot {robot.name!r} has a fixed base: no base body to regroup")
    _check_length(robot, base)
    return _regrouped(dict(zip(BODY, base.regrouped[: len(BODY)])))
