"""A floating base in the customized recursion: its symbols, its motion, its rows of τ and M.

The base body's velocity v = (linear, angular) and acceleration are given in its own
frame (Pinocchio's free-flyer), so its position never enters the dynamics and its
orientation only through gravity, Rᵀ·g₀ with R read from the quaternion without
assuming its norm: R = 1 + (2/|q|²)(w·[u×] + [u×]²), u = (qx, qy, qz) — any non-zero
quaternion names its rotation.  A planar base moves in frame {0}'s x-y plane (x, y,
yaw; velocities vx, vy, ω in its frame).  The recursion starts from the base body's
motion instead of a base at rest; the base joint's rows of τ are the force and moment
on the base body (its own and what its children hand it), in its frame.
"""

from __future__ import annotations

import functools

import sympy as sp

from ..model.rotations import quaternion_entries

__all__ = [
    "base_symbols",
    "base_rotation",
    "base_columns",
    "bracket_term",
    "BASE_COORDINATES",
    "BASE_VELOCITIES",
    "BASE_WRENCH",
]

#: Names of the base joint's coordinates, velocities and accelerations (before the joints' in q, v, v̇).
BASE_COORDINATES = {"free": ("x", "y", "z", "qx", "qy", "qz", "qw"), "planar": ("x", "y", "yaw")}
BASE_VELOCITIES = {"free": ("vx", "vy", "vz", "wx", "wy", "wz"), "planar": ("vx", "vy", "wz")}
#: Names of τ's base rows: the force and moment on the base body, in its frame (`rows`).
BASE_WRENCH = {"free": ("fx", "fy", "fz", "nx", "ny", "nz"), "planar": ("fx", "fy", "nz")}


def base_columns(kind: str) -> dict[str, tuple[str, ...]]:
    """A base joint's data columns by kind of quantity ("q", "qd", "qdd", "tau"): base_x …,
    base_vx …, base_dvx …, base_fx … (the names of `base_symbols`, and of τ's rows)."""
    return {
        "q": tuple(f"base_{c}" for c in BASE_COORDINATES[kind]),
        "qd": tuple(f"base_{c}" for c in BASE_VELOCITIES[kind]),
        "qdd": tuple(f"base_d{c}" for c in BASE_VELOCITIES[kind]),
        "tau": tuple(f"base_{c}" for c in BASE_WRENCH[kind]),
    }


@functools.lru_cache(maxsize=None)
def base_symbols(kind: str) -> tuple[tuple, tuple, tuple]:
    """(q, v, v̇) Symbols of a base joint of `kind`: base_x …, base_vx …, base_dvx …"""
    sym = lambda name: sp.Symbol(f"base_{name}", real=True)  # noqa: E731
    return (
        tuple(sym(n) for n in BASE_COORDINATES[kind]),
        tuple(sym(n) for n in BASE_VELOCITIES[kind]),
        tuple(sym("d" + n) for n in BASE_VELOCITIES[kind]),
    )


def base_rotation(kind: str, qb) -> sp.Matrix:
    """The base body's rotation in frame {0} from its coordinates (free: any non-zero quaternion)."""
    if kind == "planar":
        c, s = sp.cos(qb[2]), sp.sin(qb[2])
        return sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    x, y, z, w = qb[3:7]
    return sp.Matrix(3, 3, quaternion_entries(x, y, z, w, 2 / (x * x + y * y + z * z + w * w)))


def spatial(kind: str, values) -> tuple[list, list]:
    """(linear, angular) 3-vectors of a base velocity or acceleration given in v's order."""
    if kind == "free":
        return list(values[:3]), list(values[3:6])
    return [values[0], values[1], 0], [0, 0, values[2]]


def rows(kind: str, force: list, moment: list) -> list:
    """τ's base rows of the total force and moment on the base body, in v's order."""
    if kind == "free":
        return list(force) + list(moment)
    return [force[0], force[1], moment[2]]


def columns(kind: str) -> list[tuple[list, list]]:
    """Unit base velocities as (linear, angular) pairs, one per base velocity, in v's order."""
    count = len(BASE_VELOCITIES[kind])
    return [spatial(kind, [1 if k == j else 0 for k in range(count)]) for j in range(count)]


def bracket(kind: str, vb) -> sp.Matrix:
    """ad(ξ) in v's order: [ξ, η] = ad(ξ)·η, the Lie bracket of the base's body-frame velocity ξ
    with η (se(3): [[ω×, v×], [0, ω×]] on (linear, angular); se(2) its planar rows)."""
    if kind == "planar":
        vx, vy, w = vb
        return sp.Matrix([[0, -w, vy], [w, 0, -vx], [0, 0, 0]])
    (vx, vy, vz), (wx, wy, wz) = vb[:3], vb[3:6]
    cross = lambda x, y, z: sp.Matrix([[0, -z, y], [z, 0, -x], [-y, x, 0]])  # noqa: E731
    return sp.Matrix(sp.BlockMatrix([[cross(wx, wy, wz), cross(vx, vy, vz)], [sp.zeros(3), cross(wx, wy, wz)]]))


def bracket_term(kind: str, M, v) -> sp.Matrix:
    """What a floating base adds to ½ ∂(C v)/∂v to make C the Christoffel matrix of its velocities.

    The base's velocities are body-frame (left-invariant) fields whose brackets do not vanish,
    so the connection's symbols are not symmetric in their two lower indices: with torsion
    zero, Γ_i,jk − Γ_i,kj = M([X_j, X_k], X_i), and C = ½ ∂(C v)/∂v + ½ M[:, base]·ad(v_base)
    in the base's columns (zero elsewhere).  Ṁ − 2C is then skew, and C is Pinocchio's
    computeCoriolisMatrix (`symdyn.reference.coriolis`)."""
    nb = len(BASE_VELOCITIES[kind])
    M = sp.Matrix(M)
    extra = M[:, :nb] * bracket(kind, list(v[:nb])) / 2
    return sp.Matrix.hstack(extra, sp.zeros(M.rows, M.cols - nb))
