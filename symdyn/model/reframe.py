"""Re-expressing a robot in other link frames, its dynamics unchanged: a standard-DH chain in
modified (Craig) DH (`to_modified`), a general robot with each joint axis along its link's z
(`axes_along_z`), the frames both recursions work in.  Exact numbers stay exact.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sp

from .placement import (
    axis_rotation,
    compose,
    exact,
    exact_cos_sin_of,
    exact_rotation,
    is_symbolic,
    rational_rotation,
    rotx,
    transl,
    walk,
)

if TYPE_CHECKING:
    from .robot import Robot

__all__ = ["to_modified", "axes_along_z"]

IDENTITY = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))


def to_modified(robot: "Robot") -> "Robot":
    """The same arm in modified (Craig) DH; dynamics unchanged.

    MDH frame {j} sits where standard frame {j-1} was, turned with joint j
    and shifted by d_j: link j takes α_{j-1}, a_{j-1}; its COM and
    inertia are re-expressed through Tx(a_j)·Rx(α_j); the last link's
    Tx(a_n)·Rx(α_n) moves into the tool.

    The link frames move, so the file's frames (`frame_catalog`), the chosen `frames` and the
    contact set do not carry over: the result serves its tool (choose its frames anew).

    Raises:
        NotImplementedError: a standard-DH tree (`symdyn.derivation.kinematics.along_z` converts those).
    """
    if robot.convention == "modified":
        return robot
    if robot.frames or robot.frame_catalog or robot.contacts:
        return to_modified(dataclasses.replace(robot, frames=(), frame_catalog=(), contacts=(), baumgarte=(0.0, 0.0)))
    if robot.convention == "standard" and any(link.parent is not None for link in robot.links):
        raise NotImplementedError(
            f"robot {robot.name!r} is a standard-DH tree: to_modified converts chains (a floating base "
            "included); the derivations convert trees with symdyn.derivation.kinematics.along_z"
        )
    if robot.convention == "general":
        return axes_along_z(robot)
    links = []
    prev_a, prev_alpha = 0, 0
    for link in robot.links:
        # exact, as the derivations read the standard model (`exact`, `exact_cos_sin_of`, I's upper
        # triangle): a float sum a + r_x or a float rotation would hand Newton–Euler constants an
        # ulp off Lagrange's
        c, s = exact_cos_sin_of(link.alpha)
        R = ((1, 0, 0), (0, c, -s), (0, s, c))
        a, rc = exact(link.a), [exact(x) for x in link.r]
        Ic = [[exact(link.I[min(k, l)][max(k, l)]) for l in range(3)] for k in range(3)]
        floats = isinstance(link.a, float) or any(isinstance(x, float) for x in link.r)
        r = tuple(_plain((a if i == 0 else 0) + sum(R[i][k] * rc[k] for k in range(3)), floats) for i in range(3))
        floats = any(isinstance(x, float) for x in walk(link.I))
        upper = {
            (i, j): _plain(sum(R[i][k] * Ic[k][l] * R[j][l] for k in range(3) for l in range(3)), floats)
            for i in range(3)
            for j in range(i, 3)
        }  # computed once per pair: exactly symmetric
        I = tuple(tuple(upper[min(i, j), max(i, j)] for j in range(3)) for i in range(3))
        links.append(dataclasses.replace(link, a=prev_a, alpha=prev_alpha, r=r, I=I))
        prev_a, prev_alpha = link.a, link.alpha
    tool = compose(compose(transl(prev_a, 0, 0), rotx(prev_alpha)), robot.tool)
    return dataclasses.replace(
        robot,
        links=tuple(links),
        convention="modified",
        tool=tool,
        name=f"{robot.name}_mdh" if not robot.name.endswith("_mdh") else robot.name,
    )


def axes_along_z(robot: "Robot") -> "Robot":
    """A general robot with every joint axis along its link's z and exact,
    exactly orthogonal placements: the frames both recursions work in.

    Link frame i turns by R_a (R_a·z = axis_i, `axis_rotation`): its COM
    and inertia are re-expressed by R_aᵀ, the next origin becomes
    R_aᵀ·origin, and the last R_aᵀ moves into the tool.
    """
    links, turned, unturned = [], [], [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    for link, parent in zip(robot.links, robot.parents):
        prev = unturned if parent < 0 else turned[parent]  # the frame this link's origin is given in
        Ra = axis_rotation(link.axis)
        T = link.origin or IDENTITY
        R0 = exact_rotation([row[:3] for row in T[:3]])
        turns = (prev, R0, Ra)
        generic = sum(not all(isinstance(x, int) or x.is_Integer for row in M for x in row) for M in turns)
        if generic <= 1 or any(is_symbolic(x) for x in (*walk(T), *link.r, *walk(link.I))):
            R = [
                [sum(prev[k][i] * R0[k][l] * Ra[l][j] for k in range(3) for l in range(3)) for j in range(3)]
                for i in range(3)
            ]
            p = [sum(prev[k][i] * exact(T[k][3]) for k in range(3)) for i in range(3)]
            r = tuple(sum(Ra[k][i] * exact(link.r[k]) for k in range(3)) for i in range(3))
            upper = {
                (i, j): sum(Ra[k][i] * exact(link.I[k][l]) * Ra[l][j] for k in range(3) for l in range(3))
                for i in range(3)
                for j in range(i, 3)
            }  # computed once per pair: exactly symmetric
        else:  # several generic turns: their exact product grows to hundreds of digits, so the
            # composed rotation is made exact once, and vectors and inertias are read as decimals
            P, Q, A = (np.array(M, dtype=float) for M in turns)
            R = rational_rotation(P.T @ Q @ A)
            p = [exact(x) for x in P.T @ np.array([float(T[k][3]) for k in range(3)])]
            r = tuple(exact(x) for x in A.T @ np.array(link.r, dtype=float))
            Ic = A.T @ np.array(link.I, dtype=float) @ A
            upper = {(i, j): exact(Ic[i, j]) for i in range(3) for j in range(i, 3)}
        I = tuple(tuple(upper[min(i, j), max(i, j)] for j in range(3)) for i in range(3))
        origin = tuple(tuple(R[i]) + (p[i],) for i in range(3)) + ((0, 0, 0, 1),)
        links.append(dataclasses.replace(link, origin=origin, axis=(0, 0, 1), r=r, I=I))
        turned.append(Ra)
    prev = turned[-1] if turned else unturned  # the tool hangs on the last link (the base body without one)
    back = tuple(tuple(prev[k][i] for k in range(3)) + (0,) for i in range(3)) + ((0, 0, 0, 1),)
    return dataclasses.replace(robot, links=tuple(links), tool=compose(back, robot.tool))


def _plain(x: sp.Expr, floats: bool) -> Any:
    """An exact parameter as a plain number where one is that exact value: a float whose
    shortest decimal it is (0.068, not 17/250; `floats`: the inputs were floats) or an int;
    else the exact sympy number (a sum of decimals that no float is, a generic twist's rational)."""
    if isinstance(x, sp.Integer) and not floats:
        return int(x)
    if isinstance(x, sp.Rational) and exact(float(x)) == x:
        return float(x)
    return x
