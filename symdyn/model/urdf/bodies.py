"""Rigid bodies of a URDF: a link's `<inertial>` read and checked, moved between frames, merged exactly.

Bodies that ride on one moving link (fixed joints, locked branches) are
combined into one: total mass, common centre of mass and the inertia about
it (parallel-axis theorem), in exact arithmetic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..placement import exact
from .xml import Element, URDFError, numbers, where

__all__ = ["Body", "read_body"]


@dataclass(frozen=True)
class Body:
    """Mass, COM and COM inertia of a rigid body in some frame (exact numbers)."""

    m: sp.Expr
    r: tuple
    I: tuple

    @staticmethod
    def empty() -> "Body":
        zero = sp.S.Zero
        return Body(zero, (zero,) * 3, ((zero,) * 3,) * 3)

    def moved(self, T: tuple) -> "Body":
        """The same body seen from the frame in which T places its frame."""
        R = [row[:3] for row in T[:3]]
        r = tuple(T[i][3] + sum(R[i][k] * self.r[k] for k in range(3)) for i in range(3))
        I = tuple(
            tuple(sum(R[i][k] * self.I[k][l] * R[j][l] for k in range(3) for l in range(3)) for j in range(3))
            for i in range(3)
        )
        return Body(self.m, r, I)

    def __add__(self, other: "Body") -> "Body":
        m = self.m + other.m
        if m == 0:  # no COM; an inertia without mass is the same about any point (Pinocchio keeps it too)
            return Body(m, (sp.S.Zero,) * 3, tuple(tuple(a + b for a, b in zip(p, q)) for p, q in zip(self.I, other.I)))
        c = tuple((self.m * a + other.m * b) / m for a, b in zip(self.r, other.r))

        def about_c(body):
            d = [body.r[i] - c[i] for i in range(3)]
            dd = sum(x * x for x in d)
            return [[body.I[i][j] + body.m * ((dd if i == j else 0) - d[i] * d[j]) for j in range(3)] for i in range(3)]

        a, b = about_c(self), about_c(other)
        return Body(m, c, tuple(tuple(a[i][j] + b[i][j] for j in range(3)) for i in range(3)))


def _inertia_defect(I: tuple) -> str | None:
    """Why an inertia is impossible (not positive semidefinite, or the triangle
    inequality violated; the tolerances of the `Link` checks), or None."""
    eig = np.linalg.eigvalsh(np.array(I, dtype=float))
    if eig.min() < -1e-12 * max(1.0, abs(eig).max()):
        return f"is not positive semidefinite: principal moments {eig.tolist()}"
    if eig[0] + eig[1] < eig[2] * (1 - 1e-9):
        return (
            f"is physically impossible: its principal moments {eig.tolist()} "
            "violate the triangle inequality (I1 + I2 >= I3)"
        )
    return None


def read_body(source: str, link: Element, origin, complain) -> Body:
    """A link's `<inertial>` in the link frame (massless when absent).

    `origin(element)` reads the inertial's `<origin>`; `complain(message)`
    decides what a defect is: an error where the body enters the dynamics, a
    warning where it cannot (the body is then left out: it is massless).
    Checked before any merge, which could hide an impossible inertia.
    """
    inertial = link.find("inertial")
    if inertial is None:
        return Body.empty()
    mass = inertial.find("mass")
    if mass is None:
        complain(f"{where(source, inertial)} of link {link.name!r} has no <mass>")
        return Body.empty()
    m = numbers(source, mass, "value", 1)[0]
    if m < 0:
        complain(f"{where(source, mass)}: the mass of link {link.name!r} is negative: {m}")
        return Body.empty()
    tensor = inertial.find("inertia")
    if tensor is None:
        complain(f"{where(source, inertial)} of link {link.name!r} has no <inertia>")
        return Body.empty()
    names = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    xx, xy, xz, yy, yz, zz = (exact(numbers(source, tensor, k, 1, (0,))[0]) for k in names)
    I = ((xx, xy, xz), (xy, yy, yz), (xz, yz, zz))
    defect = _inertia_defect(I)
    if defect:
        complain(f"{where(source, tensor)} of link {link.name!r} {defect}")
        return Body.empty()
    return Body(exact(m), (sp.S.Zero,) * 3, I).moved(origin(inertial))


def strict(message: str) -> None:
    """The `complain` of a body that enters the dynamics: refuse."""
    raise URDFError(message)
