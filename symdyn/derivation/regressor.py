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
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .dynamics import rotor_inertia
from .kinematics import along_z, link_frames
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
    robot = along_z(robot)
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
    column outputs in terms of the tape's names)."""

    robot: Robot
    params: tuple
    tape: Tape
    columns: tuple  # per parameter: n expressions in the tape's names

    @property
    def Y(self) -> sp.ImmutableMatrix:
        """Y (n × 14n) written out in full, the names substituted: for small arms (it grows
        exponentially with the joints; code generation uses the named columns)."""
        n = self.robot.n
        return sp.ImmutableMatrix(n, len(self.params), lambda i, k: self.tape.full(self.columns[k][i]))


def regressor(robot: Robot, *, progress: bool = False) -> Regressor:
    """The joint-torque regressor of `robot` (geometry numeric or symbolic)."""
    n = robot.n
    q, qd, qdd = joint_symbols(n)
    frames = link_frames(along_z(robot), q)
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
    return Regressor(robot=robot, params=params, tape=tape, columns=tuple(columns))


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
    inertial ones.

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
    pi = parameter_symbols(n)
    analysis = analyse(robot, per, seed)
    friction = [k for k in range(len(pi)) if k % per >= len(INERTIAL)]
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
