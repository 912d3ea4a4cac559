"""The result of a symbolic derivation, shared by Lagrange and Newton–Euler.

`derive(robot, method)` returns a `Dynamics`: sympy matrices M (n×n), C
(n×n, Christoffel), G (n), F (n) and tau (n) in the symbols q, qd, qdd and
the robot's own symbolic parameters, with τ = M q̈ + C q̇ + F + G.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..model import Robot
from .floating import bracket_term
from .symbols import exact, joint_symbols

METHODS = ("lagrange", "newton-euler")
TERMS = ("M", "C", "Cqd", "G", "F", "tau")


@dataclass(frozen=True)
class Dynamics:
    """Closed-form dynamics of one robot, from one method.

    `definitions` are the derivation's named intermediates (Symbol, expr) in
    order and `named[term]` the term written in them (a DAG); M, C, G, tau
    are the same terms as plain expressions in q, qd, qdd.  A derivation may
    hand them over (`expanded`) or leave them to be expanded from the DAG on
    first request: a 7-joint arm's expanded C is a tree of 10⁵–10⁶ nodes that
    code generation never needs.
    """

    robot: Robot
    method: str
    q: tuple
    qd: tuple
    qdd: tuple
    F: sp.ImmutableMatrix
    definitions: tuple = ()
    named: dict = field(default_factory=dict, compare=False)
    stats: dict = field(default_factory=dict, compare=False)
    expanded: dict = field(default_factory=dict, compare=False, repr=False)

    M = property(lambda self: self._expanded("M"), doc="Joint-space inertia M(q), n×n.")
    C = property(
        lambda self: self._expanded("C"),
        doc="Christoffel Coriolis/centripetal matrix C(q, v), nv×nv (a floating base's: `floating.bracket_term`).",
    )
    G = property(lambda self: self._expanded("G"), doc="Gravity load G(q), n×1.")
    tau = property(lambda self: self._expanded("tau"), doc="Inverse dynamics τ = M q̈ + C q̇ + F + G, n×1.")

    def _expanded(self, term: str) -> sp.ImmutableMatrix:
        """A term as plain expressions: handed over, or its named form with every
        definition substituted (shared subtrees; computed once)."""
        if term not in self.expanded:
            if "_definitions" not in self.expanded:
                full: dict = {}
                for sym, definition in self.definitions:
                    full[sym] = sp.sympify(definition).xreplace(full)
                self.expanded["_definitions"] = full
            if term == "C" and "C" not in self.named:  # a recursion without the Christoffel passes
                C = self.Cqd.jacobian(self.qd) / 2
                if self.robot.base_joint is not None:  # its velocities' brackets: floating.bracket_term
                    C += bracket_term(self.robot.base_joint, self.M, self.qd)
                self.expanded[term] = sp.ImmutableMatrix(C)
            else:
                self.expanded[term] = sp.ImmutableMatrix(self.named[term].xreplace(self.expanded["_definitions"]))
        return self.expanded[term]

    @property
    def n(self) -> int:
        """Number of joints (the base joint's velocities not counted: `nv`)."""
        return self.robot.n

    @property
    def nv(self) -> int:
        """Size of v and τ: the base joint's velocities, then the joints'."""
        return len(self.qd)

    @property
    def params(self) -> tuple:
        """The robot's symbolic parameters, sorted by name."""
        return tuple(sorted(self.robot.free_symbols, key=str))

    def term(self, name: str) -> sp.ImmutableMatrix:
        """One of M, C, Cqd, G, F, tau by name."""
        if name not in TERMS:
            raise ValueError(f"unknown term {name!r}: expected one of {', '.join(TERMS)}")
        return getattr(self, name)

    def inputs(self, name: str) -> list:
        """The argument lists a term depends on: [("q", q), ("qd", qd), …]."""
        args = {
            "M": ("q",),
            "C": ("q", "qd"),
            "Cqd": ("q", "qd"),
            "G": ("q",),
            "F": ("qd",),
            "tau": ("q", "qd", "qdd"),
        }[name]
        out = [(a, getattr(self, a)) for a in args]
        return out + [("p", self.params)] if self.params else out

    @property
    def Cqd(self) -> sp.ImmutableMatrix:
        """The Coriolis/centripetal vector C(q, q̇)·q̇ (named apart from C)."""
        if "C" not in self.named and "Cqd" in self.named:
            return self._expanded("Cqd")
        return sp.ImmutableMatrix(self.C * sp.Matrix(self.qd))


def friction_expr(robot: Robot, qd) -> sp.ImmutableMatrix:
    """Friction F(q̇) as sympy: G²·B·q̇ + |G|·[(Tc⁺−Tc⁻)/2·sgn q̇ + (Tc⁺+Tc⁻)/2·sgn² q̇].

    The sign polynomial gives Tc⁺ for q̇ > 0, Tc⁻ for q̇ < 0 and 0 at rest.
    """
    out = []
    for link, v in zip(robot.links, qd):
        G, B, (tp, tn) = (exact(link.G), exact(link.B), map(exact, link.Tc))
        s = sp.sign(v)
        out.append(G**2 * B * v + sp.Abs(G) * ((tp - tn) / 2 * s + (tp + tn) / 2 * s**2))
    return sp.ImmutableMatrix(out)


def rotor_inertia(robot: Robot) -> list:
    """G²·Jm per joint, exact."""
    return [exact(link.G) ** 2 * exact(link.Jm) for link in robot.links]


__all__ = ["Dynamics", "METHODS", "friction_expr", "rotor_inertia", "joint_symbols"]
