"""Rigid bodies of a URDF: a link's `<inertial>` read and checked, moved between frames, merged exactly.

Bodies that ride on one moving link (fixed joints, locked branches) are
combined into one: total mass, common centre of mass and the inertia about
it (parallel-axis theorem), in exact arithmetic.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Callable

import numpy as np
import sympy as sp

from .. import inertia
from ..placement import exact
from .xml import Element, URDFError, numbers, where

__all__ = ["Body", "read_body", "nearest_physical", "balanced"]


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
    if not inertia.semidefinite(eig):
        return f"is not positive semidefinite: principal moments {eig.tolist()}"
    if not inertia.obeys_triangle(eig):
        return (
            f"is physically impossible: its principal moments {eig.tolist()} "
            "violate the triangle inequality (I1 + I2 >= I3)"
        )
    return None


#: The triangle inequalities of principal moments (a, b, c) as rows r with r·(a, b, c) ≥ 0;
#: together they imply a, b, c ≥ 0, so they are all a physical inertia needs.
_TRIANGLE = np.array([[1.0, 1.0, -1.0], [1.0, -1.0, 1.0], [-1.0, 1.0, 1.0]])


def nearest_physical(moments) -> np.ndarray:
    """The principal moments nearest `moments` (Euclidean) that obey the triangle inequalities.

    The physical moments form a polyhedral cone; its nearest point is the projection of
    `moments` onto the span of one of its faces (none, one, two or all three inequalities
    made equalities).  Every candidate that is feasible is physical, and the nearest feasible
    one is the projection.  Since the Frobenius norm is unitarily invariant and physical
    inertias are closed under rotation, keeping the principal axes and projecting the
    moments gives the physical inertia nearest in the Frobenius norm.

    Raises:
        ValueError: `moments` is not three finite numbers.
    """
    lam = np.asarray(moments, dtype=float)
    if lam.shape != (3,) or not np.isfinite(lam).all():
        raise ValueError(f"expected three finite principal moments, got {moments!r}")
    best, best_d = None, np.inf
    for k in range(4):
        for rows in itertools.combinations(range(3), k):
            A = _TRIANGLE[list(rows)]
            x = lam - A.T @ np.linalg.solve(A @ A.T, A @ lam) if rows else lam.copy()
            if inertia.semidefinite(x) and inertia.obeys_triangle(x):
                d = float(np.linalg.norm(x - lam))
                if d < best_d:
                    best, best_d = x, d
    return best


def balanced(I: tuple) -> tuple[tuple, np.ndarray, np.ndarray]:
    """(the physical inertia nearest `I` in the Frobenius norm, as exact numbers; `I`'s principal
    moments; the new ones), same principal axes (`nearest_physical`).

    Raises:
        ValueError: `I` has entries that are not finite.
    """
    A = np.array(I, dtype=float)
    eig, R = np.linalg.eigh((A + A.T) / 2)
    new = nearest_physical(eig)
    J = R @ np.diag(new) @ R.T
    J = (J + J.T) / 2
    return tuple(tuple(exact(float(J[i, j])) for j in range(3)) for i in range(3)), eig, new


def read_body(
    source: str,
    link: Element,
    origin,
    complain,
    balance: Callable[[Element, tuple, str], tuple] | None = None,
) -> Body:
    """A link's `<inertial>` in the link frame (massless when absent).

    `origin(element)` reads the inertial's `<origin>`; `complain(message)`
    decides what a defect is: an error where the body enters the dynamics, a
    warning where it cannot (the body is then left out: it is massless).
    `balance(element, I, defect)`, where given, repairs an impossible inertia
    instead (returns the inertia to use; it records the repair).
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
    if defect and balance is not None:
        I, defect = balance(tensor, I, defect), None
    if defect:
        complain(f"{where(source, tensor)} of link {link.name!r} {defect}")
        return Body.empty()
    return Body(exact(m), (sp.S.Zero,) * 3, I).moved(origin(inertial))


def strict(message: str) -> None:
    """The `complain` of a body that enters the dynamics: refuse."""
    raise URDFError(message)
