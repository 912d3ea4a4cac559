"""The robot as arrays and the recursion every reference function runs on: `chain_of(robot)`
(each link's constant transforms, screw axis and inertia, the base joint), the checks of q,
q̇, q̈ (`state`), and Featherstone's RNEA in body coordinates (`dynamics`).  No sympy here.

Each link's transform from its parent is pre · joint(q) · post, with pre = 1, post = Tx(a)Rx(α)
for standard DH, pre = Rx(α)Tx(a), post = 1 for modified DH, and pre = origin·R_a, post = R_aᵀ
for a general joint (its axis turned onto z).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..model import Link, Robot, exact_cos_sin
from ..model.base_joint import base_pose


@dataclass(frozen=True)
class Chain:
    """Numeric arrays of a robot, in the shape the recursion wants."""

    n: int
    revolute: np.ndarray  # (n,) bool
    theta: np.ndarray  # constant θ (prismatic) or 0
    d: np.ndarray  # constant d (revolute) or 0
    offset: np.ndarray
    pre_R: np.ndarray  # (n, 3, 3)
    pre_p: np.ndarray  # (n, 3)
    post_R: np.ndarray
    post_p: np.ndarray
    S: np.ndarray  # (n, 6) joint axis (ω, v) in body coordinates
    m: np.ndarray  # (n,)
    h: np.ndarray  # (n, 3) first moment m·r
    Io: np.ndarray  # (n, 3, 3) inertia about the body origin
    armature: np.ndarray  # (n,) G²·Jm
    G: np.ndarray
    B: np.ndarray
    Tc: np.ndarray  # (n, 2)
    base_R: np.ndarray
    base_p: np.ndarray
    tool_R: np.ndarray
    tool_p: np.ndarray
    gravity: np.ndarray  # (3,) Corke's convention, world
    parents: tuple  # each link's parent, -1 for the base
    base_joint: str | None  # None, "free" or "planar"
    base_body: tuple  # (m, h, Io) of the body a base joint moves (zeros where none)
    nq: int
    nv: int

    @property
    def nb(self) -> int:
        """Velocities of the base joint (6 free, 3 planar, 0 fixed): the first rows of v and τ."""
        return self.nv - self.n


#: The base joint's motion subspace in the recursion's (ω, v) order, from v's (v, ω) order.
BASE_AXES = {
    "free": np.concatenate([np.eye(6)[3:], np.eye(6)[:3]]).T,  # columns: vx vy vz ωx ωy ωz
    "planar": np.array([[0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 1, 0, 0, 0]], dtype=float).T,
}


def _rx(alpha) -> np.ndarray:
    c, s = exact_cos_sin(alpha)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=float)


def _rz(theta: np.ndarray) -> np.ndarray:
    """Batched rotation about z; theta of shape (...)."""
    c, s = np.cos(theta), np.sin(theta)
    R = np.zeros(np.shape(theta) + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1], R[..., 2, 2] = c, -s, s, c, 1.0
    return R


def rotation_z_to(a: np.ndarray) -> np.ndarray:
    """A rotation taking z to the unit vector a (Rodrigues about z × a)."""
    a = a / np.linalg.norm(a)
    if a[2] < -1 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    v = np.cross([0.0, 0.0, 1.0], a)
    V = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + V + V @ V / (1 + a[2])


@functools.lru_cache(maxsize=64)
def chain_of(robot: Robot) -> Chain:
    robot.require_numeric("the numeric reference")
    n = robot.n
    f = lambda x: float(x)  # noqa: E731
    pre_R, pre_p, post_R, post_p, S = [], [], [], [], []
    for link in robot.links:
        Rx = _rx(link.alpha)
        if robot.convention == "general":  # origin · Rot(axis): pre = origin·R_a, post = R_aᵀ
            T, Ra = np.array(link.origin or np.eye(4), dtype=float), rotation_z_to(np.array(link.axis, dtype=float))
            pre_R.append(T[:3, :3] @ Ra)
            pre_p.append(T[:3, 3])
            post_R.append(Ra.T)
            post_p.append(np.zeros(3))
        elif robot.convention == "standard":
            pre_R.append(np.eye(3))
            pre_p.append(np.zeros(3))
            post_R.append(Rx)
            post_p.append(np.array([f(link.a), 0.0, 0.0]))
        else:
            pre_R.append(Rx)
            pre_p.append(np.array([f(link.a), 0.0, 0.0]))  # Rx(α)·Tx(a)
            post_R.append(np.eye(3))
            post_p.append(np.zeros(3))
        z = np.array([0.0, 0.0, 1.0])
        Rt = post_R[-1].T
        if link.is_revolute:
            S.append(np.concatenate([Rt @ z, Rt @ np.cross(z, post_p[-1])]))
        else:
            S.append(np.concatenate([np.zeros(3), Rt @ z]))
    m, h, Io = _origin_inertias(robot.links)
    G = np.array([f(l.G) for l in robot.links])
    T = lambda M: np.array([[f(x) for x in row] for row in M])  # noqa: E731
    base, tool = T(robot.base), T(robot.tool)
    return Chain(
        n=n,
        revolute=np.array([l.is_revolute for l in robot.links], dtype=bool),
        theta=np.array([0.0 if l.is_revolute else f(l.theta) for l in robot.links]),
        d=np.array([f(l.d) if l.is_revolute else 0.0 for l in robot.links]),
        offset=np.array([f(l.offset) for l in robot.links]),
        pre_R=np.array(pre_R).reshape(n, 3, 3),
        pre_p=np.array(pre_p).reshape(n, 3),
        post_R=np.array(post_R).reshape(n, 3, 3),
        post_p=np.array(post_p).reshape(n, 3),
        S=np.array(S).reshape(n, 6),
        m=m,
        h=h,
        Io=Io,
        armature=G**2 * np.array([f(l.Jm) for l in robot.links]),
        G=G,
        B=np.array([f(l.B) for l in robot.links]),
        Tc=np.array([[f(x) for x in l.Tc] for l in robot.links]).reshape(n, 2),
        base_R=base[:3, :3],
        base_p=base[:3, 3],
        tool_R=tool[:3, :3],
        tool_p=tool[:3, 3],
        gravity=np.array([f(x) for x in robot.gravity]),
        parents=robot.parents,
        base_joint=robot.base_joint,
        base_body=tuple(a[0] for a in _origin_inertias([robot.base_body] if robot.base_body else [_MASSLESS])),
        nq=robot.nq,
        nv=robot.nv,
    )


_MASSLESS = Link()


def _origin_inertias(links) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mass (k,), first moment m·r (k, 3) and inertia about the frame origin (k, 3, 3) of links."""
    m = np.array([float(l.m) for l in links])
    r = np.array([[float(x) for x in l.r] for l in links]).reshape(-1, 3)
    Ic = np.array([[[float(x) for x in row] for row in l.I] for l in links]).reshape(-1, 3, 3)
    Io = Ic + m[:, None, None] * (np.einsum("ij,k->kij", np.eye(3), (r * r).sum(1)) - np.einsum("ki,kj->kij", r, r))
    return m, m[:, None] * r, Io


def link_transforms(c: Chain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (..., n, 3, 3) and origin (..., n, 3) of each body in its parent."""
    theta = np.where(c.revolute, q + c.offset, c.theta)
    d = np.where(c.revolute, c.d, q + c.offset)
    Rj = _rz(theta)  # (..., n, 3, 3)
    R = c.pre_R @ Rj @ c.post_R
    pj = np.einsum("...ij,...j->...i", Rj, c.post_p)
    pj = pj + d[..., None] * np.array([0.0, 0.0, 1.0])
    p = c.pre_p + np.einsum("nij,...nj->...ni", c.pre_R, pj)
    return R, p


# --------------------------------------------------------------------------- input checks


def state(c: Chain, x, name: str) -> np.ndarray:
    """A float array of shape (..., nq) for q (a name starting "q" that is not "qd…": q, q0),
    else (..., nv), finite, or a ValueError naming `name`."""
    size = c.nq if name in ("q", "q0") else c.nv
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a numeric array of shape ({size},) or (N, {size}), got {x!r}") from None
    if a.ndim == 0 or a.shape[-1] != size:
        raise ValueError(f"{name} must have shape ({size},) or (N, {size}); got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))[0]
        raise ValueError(f"{name} contains NaN or infinity (first at index {tuple(bad.tolist())})")
    return a


def states(c: Chain, **arrays) -> list[np.ndarray]:
    out = [state(c, v, k) for k, v in arrays.items()]
    try:
        batch = np.broadcast_shapes(*(a.shape[:-1] for a in out))
    except ValueError:
        shapes = ", ".join(f"{k} {a.shape}" for k, a in zip(arrays, out))
        raise ValueError(f"state arrays have incompatible shapes: {shapes}") from None
    return [np.broadcast_to(a, batch + a.shape[-1:]) for a in out]


def vector3(x, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be a finite 3-vector, got {x!r}")
    return a


# --------------------------------------------------------------------------- recursion

_NEXT, _PREV = np.array([1, 2, 0]), np.array([2, 0, 1])


def cross(a, b) -> np.ndarray:
    """a × b over the last axis, broadcast: (a_y b_z − a_z b_y, a_z b_x − a_x b_z,
    a_x b_y − a_y b_x), the same roundings as np.cross without its overhead
    (np.cross on 3-vectors dominated the recursion's run time)."""
    return a[..., _NEXT] * b[..., _PREV] - a[..., _PREV] * b[..., _NEXT]


def _body_force(m, h, Io, w, v, dw, dv) -> tuple[np.ndarray, np.ndarray]:
    """f = I a + v ×* I v of one body about its frame origin, in its frame: (moment, force)."""
    L = np.einsum("ij,...j->...i", Io, w) + cross(h, v)
    P = m * v + cross(w, h)
    n_ = np.einsum("ij,...j->...i", Io, dw) + cross(h, dv) + cross(w, L) + cross(v, P)
    return n_, m * dv + cross(dw, h) + cross(w, P)


def _recursion(c: Chain, q, qd, qdd, g_up_world, wrench=None, base=None):
    """RNEA core on the tree: the joints' forces without friction (rotor inertia included), and
    the spatial force (n, f) that frame 0 — the fixed base, or the body a base joint moves —
    exerts on what it carries (its own body included), about its origin, in its coordinates.
    q, qd, qdd: the joints' (..., n); g_up_world (3,) or one per state (..., 3).  base: None for a
    fixed base, else (R, v, a): the base joint's rotation (..., 3, 3) and its velocity and
    acceleration (..., nb) in v's order (`BASE_AXES`)."""
    R, p = link_transforms(c, q)
    batch = q.shape[:-1]
    g0 = np.einsum("ji,...j->...i", c.base_R, g_up_world)
    if base is None:
        w0, v0, dw0 = np.zeros(batch + (3,)), np.zeros(batch + (3,)), np.zeros(batch + (3,))
        dv0 = np.broadcast_to(g0, batch + (3,)).copy()
    else:
        Rb, vb, ab = base
        axes = BASE_AXES[c.base_joint]
        w0, v0 = np.split(np.einsum("ij,...j->...i", axes, vb), 2, -1)
        dw0, dv0 = np.split(np.einsum("ij,...j->...i", axes, ab), 2, -1)
        dv0 = dv0 + np.einsum("...ji,...j->...i", Rb, g0)
    motion = []  # (w, v, dw, dv) of each body
    forces = []
    for i in range(c.n):
        w, v, dw, dv = motion[c.parents[i]] if c.parents[i] >= 0 else (w0, v0, dw0, dv0)
        Rt = np.swapaxes(R[..., i, :, :], -1, -2)
        pi = p[..., i, :]
        sw, sv = c.S[i, :3], c.S[i, 3:]
        # transform parent motion into this body, then add the joint's
        w_new = np.einsum("...ij,...j->...i", Rt, w)
        v_new = np.einsum("...ij,...j->...i", Rt, v + cross(w, pi))
        dw_new = np.einsum("...ij,...j->...i", Rt, dw)
        dv_new = np.einsum("...ij,...j->...i", Rt, dv + cross(dw, pi))
        qdi, qddi = qd[..., i, None], qdd[..., i, None]
        w, v = w_new + sw * qdi, v_new + sv * qdi
        # a = X a_p + S q̈ + v ×m (S q̇)
        dw = dw_new + sw * qddi + cross(w, sw * qdi)
        dv = dv_new + sv * qddi + cross(w, sv * qdi) + cross(v, sw * qdi)
        motion.append((w, v, dw, dv))
        forces.append(list(_body_force(c.m[i], c.h[i], c.Io[i], w, v, dw, dv)))
    if wrench is not None:
        fe, ne = wrench[..., :3], wrench[..., 3:]
        fB = np.einsum("ij,...j->...i", c.tool_R, fe)
        forces[-1][1] = forces[-1][1] + fB
        forces[-1][0] = forces[-1][0] + np.einsum("ij,...j->...i", c.tool_R, ne) + cross(c.tool_p, fB)
    if base is None:
        root = [np.zeros(batch + (3,)), np.zeros(batch + (3,))]
    else:
        root = list(_body_force(*c.base_body, w0, v0, dw0, dv0))
    tau = np.empty(q.shape)
    for i in range(c.n - 1, -1, -1):
        n_, f_ = forces[i]
        tau[..., i] = n_ @ c.S[i, :3] + f_ @ c.S[i, 3:] + c.armature[i] * qdd[..., i]
        target = forces[c.parents[i]] if c.parents[i] >= 0 else root
        Ri, pi = R[..., i, :, :], p[..., i, :]
        fp = np.einsum("...ij,...j->...i", Ri, f_)
        target[1] = target[1] + fp
        target[0] = target[0] + np.einsum("...ij,...j->...i", Ri, n_) + cross(pi, fp)
    return tau, root


def split_state(c: Chain, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(base part, joints' part) of q, v or τ."""
    k = x.shape[-1] - c.n
    return x[..., :k], x[..., k:]


def dynamics(c: Chain, q, qd, qdd, g_up_world, wrench=None) -> tuple[np.ndarray, list]:
    """τ (..., nv) without friction of checked states q (..., nq), v, v̇ (..., nv), the base
    joint's forces first (`BASE_AXES`: the base body's force, then moment, in its frame), and the
    root force of `_recursion`."""
    if c.base_joint is None:
        return _recursion(c, q, qd, qdd, g_up_world, wrench)
    qb, qj = split_state(c, q)
    (vb, vj), (ab, aj) = split_state(c, qd), split_state(c, qdd)
    Rb = base_pose(c.base_joint, q)[0]
    tau, root = _recursion(c, qj, vj, aj, g_up_world, wrench, (Rb, vb, ab))
    moment, force = root
    tau_b = np.einsum("ji,...j->...i", BASE_AXES[c.base_joint], np.concatenate([moment, force], -1))
    return np.concatenate([tau_b, tau], -1), root
