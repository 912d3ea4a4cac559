"""Symbolic kinematics: exact link transforms, forward kinematics, Jacobians.

Part of the derive stage.  Each link's transform from its parent is
pre · joint(q) · post, exactly as in `symdyn.reference`: standard DH has
pre = 1, post = Tx(a)Rx(α); modified DH has pre = Rx(α)Tx(a), post = 1; a general joint (URDF) has pre = its
origin and turns about (slides along) its own axis.
Constant angles are exact (α = π/2 gives 0 and 1) and float parameters
become exact rationals, so two derivations can be compared exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..model import IDENTITY, Robot
from ..model.placement import axis_rotation, exact_rotation
from .symbols import exact, exact_cos_sin_of, joint_symbols


@dataclass(frozen=True)
class LinkFrame:
    """Exact pieces of one link: its transform from the parent (R, p) as
    functions of the joint symbol, and the joint's axis S = (ω, v) in body
    coordinates (constant)."""

    R: sp.Matrix
    p: sp.Matrix
    S: tuple


def _rx(alpha) -> sp.Matrix:
    c, s = exact_cos_sin_of(alpha)
    return sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])


def _cos_sin_of(q: sp.Symbol, offset) -> tuple[sp.Expr, sp.Expr]:
    """cos and sin of q + offset, written in cos(q), sin(q) with exact constants."""
    co, so = exact_cos_sin_of(offset)
    c, s = sp.cos(q), sp.sin(q)
    return c * co - s * so, s * co + c * so


def link_frames(robot: Robot, q=None) -> list[LinkFrame]:
    """The exact transform of every body from its parent, in the joint symbols."""
    q = joint_symbols(robot.n)[0] if q is None else q
    if robot.convention == "general":
        return [_general_frame(link, qi) for link, qi in zip(robot.links, q)]
    frames = []
    for link, qi in zip(robot.links, q):
        Rx, a = _rx(link.alpha), exact(link.a)
        if link.is_revolute:
            c, s = _cos_sin_of(qi, link.offset)
            d = exact(link.d)
        else:
            c, s = exact_cos_sin_of(link.theta)
            d = qi + exact(link.offset)
        Rz = sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        if robot.convention == "standard":
            post_R, post_p = Rx, sp.Matrix([a, 0, 0])
            R = Rz * post_R
            p = Rz * post_p + sp.Matrix([0, 0, d])
        else:
            post_R, post_p = sp.eye(3), sp.zeros(3, 1)
            R = Rx * Rz
            p = sp.Matrix([a, 0, 0]) + Rx * sp.Matrix([0, 0, d])
        z = sp.Matrix([0, 0, 1])
        if link.is_revolute:
            S = tuple(post_R.T * z) + tuple(post_R.T * z.cross(post_p))
        else:
            S = (0, 0, 0) + tuple(post_R.T * z)
        frames.append(LinkFrame(R=R, p=p, S=tuple(sp.sympify(x) for x in S)))
    return frames


def _general_frame(link, qi) -> LinkFrame:
    """origin · Rot(a, q + offset) (Rodrigues) or origin · Trans(a·(q + offset)),
    with the exact placement and axis of `model.placement`."""
    T = link.origin or IDENTITY
    R0 = sp.Matrix(exact_rotation([row[:3] for row in T[:3]]))
    p0 = sp.Matrix([exact(T[i][3]) for i in range(3)])
    a = sp.Matrix(axis_rotation(link.axis))[:, 2]
    if link.is_revolute:
        c, s = _cos_sin_of(qi, link.offset)
        ax = sp.Matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
        Rj = c * sp.eye(3) + s * ax + (1 - c) * a * a.T
        return LinkFrame(R=R0 * Rj, p=p0, S=tuple(a) + (sp.S.Zero,) * 3)
    return LinkFrame(R=R0, p=p0 + R0 * a * (qi + exact(link.offset)), S=(sp.S.Zero,) * 3 + tuple(a))


def _homogeneous(R: sp.Matrix, p: sp.Matrix) -> sp.Matrix:
    return sp.Matrix(sp.BlockMatrix([[R, p], [sp.zeros(1, 3), sp.ones(1, 1)]]))


def _exact_matrix(T) -> sp.Matrix:
    return sp.Matrix([[exact(x) for x in row] for row in T])


def link_poses(robot: Robot, q=None) -> list[sp.Matrix]:
    """World pose (4×4) of every body frame: base · A₁ ⋯ Aᵢ."""
    T = _exact_matrix(robot.base)
    poses = []
    for f in link_frames(robot, q):
        T = T * _homogeneous(f.R, f.p)
        poses.append(T)
    return poses


def fkine(robot: Robot, q=None) -> sp.Matrix:
    """End-effector pose (4×4, sympy) in the world: base · A₁ ⋯ Aₙ · tool."""
    return link_poses(robot, q)[-1] * _exact_matrix(robot.tool)


def jacob0(robot: Robot, q=None) -> sp.Matrix:
    """Geometric Jacobian (6×n, sympy) of the tool point, [v; ω], world frame."""
    frames = link_frames(robot, q)
    poses = link_poses(robot, q)
    pe = fkine(robot, q)[:3, 3]
    J = sp.zeros(6, robot.n)
    for i, (f, T) in enumerate(zip(frames, poses)):
        R, o = T[:3, :3], T[:3, 3]
        w = R * sp.Matrix(f.S[:3])
        v = R * sp.Matrix(f.S[3:])
        if robot.links[i].is_revolute:
            J[:3, i] = v + w.cross(pe - o)
            J[3:, i] = w
        else:
            J[:3, i] = v
    return J
