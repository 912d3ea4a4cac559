"""Symbolic kinematics: exact link transforms, forward kinematics, Jacobians.

Part of the derive stage.  Each link's transform from its parent is
pre · joint(q) · post, exactly as in `symdyn.reference`: standard DH has
pre = 1, post = Tx(a)Rx(α); modified DH has pre = Rx(α)Tx(a), post = 1; a general joint (URDF) has pre = its
origin and turns about (slides along) its own axis.
Constant angles are exact (α = π/2 gives 0 and 1) and float parameters
become exact rationals, so two derivations can be compared exactly.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import sympy as sp

from ..model import IDENTITY, Robot
from ..model.placement import axis_rotation, exact_rotation
from .symbols import exact, exact_cos_sin_of, joint_symbols


@dataclass(frozen=True)
class LinkFrame:
    """Exact pieces of one link: its transform from the parent (R, p) as
    functions of the joint symbol, the joint's axis S = (ω, v) in body
    coordinates (constant), and `parent`, the index of the link it hangs on
    (-1: the base; a tree's recursions run through it)."""

    R: sp.Matrix
    p: sp.Matrix
    S: tuple
    parent: int = -1


def ancestors(parents, i: int) -> list[int]:
    """Link i and the links it hangs from, i first, down to the one on the base."""
    out = []
    while i >= 0:
        out.append(i)
        i = parents[i]
    return out


def along_z(robot: Robot) -> Robot:
    """The robot in frames whose joint axes are their z (`Robot.to_modified`), trees included.

    A standard-DH tree is converted as a chain is: link j takes the (a, α) of its parent's
    standard link (0, 0 on the base) and its COM and inertia move through its own
    Tx(a)·Rx(α); the last link's Tx(a)·Rx(α) goes into the tool, which stays on it.
    """
    if robot.convention != "standard" or robot.is_chain:
        return robot.to_modified()
    chain = dataclasses.replace(robot, links=tuple(dataclasses.replace(link, parent=None) for link in robot.links))
    mdh = chain.to_modified()
    links = []
    for link, own, parent in zip(mdh.links, robot.links, robot.parents):
        a, alpha = (0, 0) if parent < 0 else (robot.links[parent].a, robot.links[parent].alpha)
        links.append(dataclasses.replace(link, a=a, alpha=alpha, parent=own.parent))
    return dataclasses.replace(mdh, links=tuple(links))


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
        return [
            dataclasses.replace(_general_frame(link, qi), parent=parent)
            for link, qi, parent in zip(robot.links, q, robot.parents)
        ]
    frames = []
    for link, qi, parent in zip(robot.links, q, robot.parents):
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
        frames.append(LinkFrame(R=R, p=p, S=tuple(sp.sympify(x) for x in S), parent=parent))
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
    """World pose (4×4) of every body frame: base · A₁ ⋯ Aᵢ, the A of link i and of the links
    it hangs from (a tree's other branches do not enter)."""
    base = _exact_matrix(robot.base)
    poses: list = []
    for f in link_frames(robot, q):
        poses.append((base if f.parent < 0 else poses[f.parent]) * _homogeneous(f.R, f.p))
    return poses


def fkine(robot: Robot, q=None) -> sp.Matrix:
    """End-effector pose (4×4, sympy) in the world: the last link's pose · tool (the tool
    hangs on the last link, a tree's too)."""
    return link_poses(robot, q)[-1] * _exact_matrix(robot.tool)


def jacob0(robot: Robot, q=None) -> sp.Matrix:
    """Geometric Jacobian (6×n, sympy) of the tool point, [v; ω], world frame; on a tree the
    columns of joints the last link does not hang from are zero."""
    frames = link_frames(robot, q)
    poses = link_poses(robot, q)
    pe = fkine(robot, q)[:3, 3]
    J = sp.zeros(6, robot.n)
    path = set(ancestors(robot.parents, robot.n - 1))
    for i, (f, T) in enumerate(zip(frames, poses)):
        if i not in path:
            continue
        R, o = T[:3, :3], T[:3, 3]
        w = R * sp.Matrix(f.S[:3])
        v = R * sp.Matrix(f.S[3:])
        if robot.links[i].is_revolute:
            J[:3, i] = v + w.cross(pe - o)
            J[3:, i] = w
        else:
            J[:3, i] = v
    return J


def _signed_permutation(M: sp.Matrix) -> bool:
    return all(sum(1 for x in M.row(i) if x != 0) == 1 for i in range(3)) and all(x in (0, 1, -1) for x in M)


def _turn(R: sp.Matrix) -> tuple | None:
    """(a, i, j, c, s) when R is a turn about its axis a by the angle of cos c and sin s
    (R[i][i] = R[j][j] = c, R[j][i] = −R[i][j] = s, (a, i, j) cyclic), else None."""
    for a in range(3):
        i, j = (a + 1) % 3, (a + 2) % 3
        if R[a, a] == 1 and all(R[a, x] == 0 and R[x, a] == 0 for x in (i, j)):
            c, s = R[i, i], R[j, i]
            if c != 0 and s != 0 and sp.expand(R[j, j] - c) == 0 and sp.expand(R[i, j] + s) == 0:
                return a, i, j, c, s
    return None


def turned_inertia(tape, R, J, label: str) -> list:
    """R·J·Rᵀ of a symmetric J (its upper triangle read), R a joint's rotation, both 3×3 Matrices
    or rows; as rows.

    A revolute joint's R is P·Rot(a, q) or Rot(a, q)·P with P a signed permutation (a URDF
    axis, DH's α of 0 or ±π/2; the second is P·Rot(b, q) too, b = Pᵀa, so Pᵀ·R is always the
    turn): P only renames entries, and the turn changes one plane of J,
    done with the double angle (cos 2q = c² − s², sin 2q = 2cs, named {label} C2, S2):
    J'ᵢᵢ, J'ⱼⱼ = m ± t with m = (Jᵢᵢ + Jⱼⱼ)/2, d = (Jᵢᵢ − Jⱼⱼ)/2, t = d·C2 − Jᵢⱼ·S2, J'ᵢⱼ =
    d·S2 + Jᵢⱼ·C2, and the axis's column turned as a vector: 22 operations against 27 for the
    product (Talos' A_G: 3 639 → 3 529 operations).  Any other R: the product."""
    R, given = sp.Matrix(R), sp.Matrix(J)
    J = sp.Matrix(3, 3, lambda x, y: given[min(x, y), max(x, y)])
    trig = {f for e in R for f in e.atoms(sp.cos, sp.sin)}
    angles = {f.args[0] for f in trig}
    if len(angles) == 1:
        angle = angles.pop()
        P = R.xreplace({sp.cos(angle): 1, sp.sin(angle): 0})
        turn = _turn((P.T * R).applyfunc(sp.expand)) if _signed_permutation(P) else None
        if turn:
            return rows(P * _turned(tape, J, *turn, label) * P.T)
    RJ = R * J
    return [[sp.Add(*(RJ[x, k] * R[y, k] for k in range(3))) for y in range(3)] for x in range(3)]


def _turned(tape, J: sp.Matrix, a: int, i: int, j: int, c, s, label: str) -> sp.Matrix:
    """Rot(a)·J·Rot(a)ᵀ by the double angle (`turned_inertia`)."""
    C2 = tape.name(c * c - s * s, f"C2_{label}")
    S2 = tape.name(2 * c * s, f"S2_{label}")
    half = sp.Rational(1, 2)
    mean = (J[i, i] + J[j, j]) * half
    d = tape.name((J[i, i] - J[j, j]) * half, f"dJ{label}")
    t = tape.name(d * C2 - J[i, j] * S2, f"tJ{label}")
    out = sp.zeros(3, 3)
    out[a, a] = J[a, a]
    out[i, i], out[j, j] = mean + t, mean - t
    out[i, j] = out[j, i] = d * S2 + J[i, j] * C2
    out[i, a] = out[a, i] = c * J[i, a] - s * J[j, a]
    out[j, a] = out[a, j] = s * J[i, a] + c * J[j, a]
    return out


def rows(M: sp.Matrix) -> list:
    """A matrix as a list of its rows (lists of entries)."""
    return [[M[i, j] for j in range(M.cols)] for i in range(M.rows)]
