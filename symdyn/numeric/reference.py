"""Numeric recursive Newton–Euler in NumPy: the yardstick for everything else.

No sympy here.  Every derivation and every emitted function is checked
against these functions, and they in turn against Pinocchio (tests).  All
functions are batched over leading axes: q of shape (n,) or (..., n).

Conventions (Corke's Robotics Toolbox): τ = M(q)q̈ + C(q,q̇)q̇ + F(q̇) + G(q)
+ J(q)ᵀW; M includes the rotor term G²·Jm; gravity is the base's upward
acceleration in the world (rotated into frame {0} by the base rotation);
C is the Christoffel-symbol matrix.

The recursion is Featherstone's RNEA in body coordinates: each link's
transform from its parent is pre · joint(q) · post, with pre = 1,
post = Tx(a)Rx(α) for standard DH and pre = Rx(α)Tx(a), post = 1 for
modified DH.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Callable, Literal, overload

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp

from ..model import Robot, exact_cos_sin

__all__ = [
    "rne",
    "inertia",
    "coriolis",
    "christoffel",
    "gravload",
    "friction",
    "friction_law",
    "accel",
    "fdyn",
    "fkine",
    "jacob0",
    "energy",
]


# --------------------------------------------------------------------------- the chain


@dataclass(frozen=True)
class _Chain:
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
def _chain(robot: Robot) -> _Chain:
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
    m = np.array([f(l.m) for l in robot.links])
    r = np.array([[f(x) for x in l.r] for l in robot.links])
    Ic = np.array([[[f(x) for x in row] for row in l.I] for l in robot.links])
    Io = Ic + m[:, None, None] * (np.einsum("ij,k->kij", np.eye(3), (r * r).sum(1)) - np.einsum("ki,kj->kij", r, r))
    G = np.array([f(l.G) for l in robot.links])
    T = lambda M: np.array([[f(x) for x in row] for row in M])  # noqa: E731
    base, tool = T(robot.base), T(robot.tool)
    return _Chain(
        n=n,
        revolute=np.array([l.is_revolute for l in robot.links]),
        theta=np.array([0.0 if l.is_revolute else f(l.theta) for l in robot.links]),
        d=np.array([f(l.d) if l.is_revolute else 0.0 for l in robot.links]),
        offset=np.array([f(l.offset) for l in robot.links]),
        pre_R=np.array(pre_R),
        pre_p=np.array(pre_p),
        post_R=np.array(post_R),
        post_p=np.array(post_p),
        S=np.array(S),
        m=m,
        h=m[:, None] * r,
        Io=Io,
        armature=G**2 * np.array([f(l.Jm) for l in robot.links]),
        G=G,
        B=np.array([f(l.B) for l in robot.links]),
        Tc=np.array([[f(x) for x in l.Tc] for l in robot.links]),
        base_R=base[:3, :3],
        base_p=base[:3, 3],
        tool_R=tool[:3, :3],
        tool_p=tool[:3, 3],
        gravity=np.array([f(x) for x in robot.gravity]),
    )


def _link_transforms(c: _Chain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def _state(c: _Chain, x, name: str) -> np.ndarray:
    """A float array of shape (..., n), finite, or a ValueError naming `name`."""
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a numeric array of shape ({c.n},) or (N, {c.n}), got {x!r}") from None
    if a.ndim == 0 or a.shape[-1] != c.n:
        raise ValueError(f"{name} must have shape ({c.n},) or (N, {c.n}); got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))[0]
        raise ValueError(f"{name} contains NaN or infinity (first at index {tuple(bad.tolist())})")
    return a


def _states(c: _Chain, **arrays) -> list[np.ndarray]:
    out = [_state(c, v, k) for k, v in arrays.items()]
    try:
        shape = np.broadcast_shapes(*(a.shape for a in out))
    except ValueError:
        shapes = ", ".join(f"{k} {a.shape}" for k, a in zip(arrays, out))
        raise ValueError(f"state arrays have incompatible shapes: {shapes}") from None
    return [np.broadcast_to(a, shape) for a in out]


def _vector3(x, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be a finite 3-vector, got {x!r}")
    return a


# --------------------------------------------------------------------------- recursion

_NEXT, _PREV = np.array([1, 2, 0]), np.array([2, 0, 1])


def _cross(a, b) -> np.ndarray:
    """a × b over the last axis, broadcast: (a_y b_z − a_z b_y, a_z b_x − a_x b_z,
    a_x b_y − a_y b_x), the same roundings as np.cross without its overhead
    (np.cross on 3-vectors dominated the recursion's run time)."""
    return a[..., _NEXT] * b[..., _PREV] - a[..., _PREV] * b[..., _NEXT]


def _recursion(c: _Chain, q, qd, qdd, g_up_world, wrench=None):
    """RNEA core: joint forces without friction (rotor inertia included) and
    the spatial force (n, f) on link 1 in body-1 coordinates.  g_up_world (3,)
    or one per state (..., 3)."""
    R, p = _link_transforms(c, q)
    batch = q.shape[:-1]
    w = np.zeros(batch + (3,))
    v = np.zeros(batch + (3,))
    dw = np.zeros(batch + (3,))
    dv = np.broadcast_to(np.einsum("ji,...j->...i", c.base_R, g_up_world), batch + (3,)).copy()
    forces = []
    for i in range(c.n):
        Rt = np.swapaxes(R[..., i, :, :], -1, -2)
        pi = p[..., i, :]
        sw, sv = c.S[i, :3], c.S[i, 3:]
        # transform parent motion into this body, then add the joint's
        w_new = np.einsum("...ij,...j->...i", Rt, w)
        v_new = np.einsum("...ij,...j->...i", Rt, v + _cross(w, pi))
        dw_new = np.einsum("...ij,...j->...i", Rt, dw)
        dv_new = np.einsum("...ij,...j->...i", Rt, dv + _cross(dw, pi))
        qdi, qddi = qd[..., i, None], qdd[..., i, None]
        w, v = w_new + sw * qdi, v_new + sv * qdi
        # a = X a_p + S q̈ + v ×m (S q̇)
        dw = dw_new + sw * qddi + _cross(w, sw * qdi)
        dv = dv_new + sv * qddi + _cross(w, sv * qdi) + _cross(v, sw * qdi)
        m, h, Io = c.m[i], c.h[i], c.Io[i]
        # f = I a + v ×* I v
        L = np.einsum("ij,...j->...i", Io, w) + _cross(h, v)
        P = m * v + _cross(w, h)
        n_ = np.einsum("ij,...j->...i", Io, dw) + _cross(h, dv) + _cross(w, L) + _cross(v, P)
        f_ = m * dv + _cross(dw, h) + _cross(w, P)
        forces.append([n_, f_])
    if wrench is not None:
        fe, ne = wrench[..., :3], wrench[..., 3:]
        fB = np.einsum("ij,...j->...i", c.tool_R, fe)
        forces[-1][1] = forces[-1][1] + fB
        forces[-1][0] = forces[-1][0] + np.einsum("ij,...j->...i", c.tool_R, ne) + _cross(c.tool_p, fB)
    tau = np.empty(q.shape)
    for i in range(c.n - 1, -1, -1):
        n_, f_ = forces[i]
        tau[..., i] = n_ @ c.S[i, :3] + f_ @ c.S[i, 3:] + c.armature[i] * qdd[..., i]
        if i > 0:
            Ri, pi = R[..., i, :, :], p[..., i, :]
            fp = np.einsum("...ij,...j->...i", Ri, f_)
            forces[i - 1][1] = forces[i - 1][1] + fp
            forces[i - 1][0] = forces[i - 1][0] + np.einsum("...ij,...j->...i", Ri, n_) + _cross(pi, fp)
    return tau, forces[0], (R[..., 0, :, :], p[..., 0, :])


# --------------------------------------------------------------------------- public API


def friction(robot: Robot, qd: ArrayLike) -> np.ndarray:
    """Joint friction F(q̇) (..., n): G²·B·q̇ + |G|·Tc⁺ (q̇ > 0) or |G|·Tc⁻ (q̇ < 0), 0 at rest.

    Raises:
        ValueError: a symbolic robot, or `qd` that is not a finite numeric array of
            shape (n,) or (..., n).
    """
    return friction_law(robot)(_state(_chain(robot), qd, "qd"))


def friction_law(robot: Robot) -> Callable[[np.ndarray], np.ndarray]:
    """q̇ ↦ `friction(robot, q̇)` with the robot's constants read once and no
    input checks: for inner loops (simulators, model adapters).

    Returns:
        F(q̇) -> (..., n), the friction of `friction` (NumPy's own errors for a bad q̇).

    Raises:
        ValueError: a symbolic robot.
    """
    c = _chain(robot)
    viscous, gain, up, down = c.G**2 * c.B, np.abs(c.G), c.Tc[:, 0], c.Tc[:, 1]

    def F(qd) -> np.ndarray:
        qd = np.asarray(qd, dtype=float)
        return viscous * qd + gain * np.where(qd > 0, up, np.where(qd < 0, down, 0.0))

    return F


@overload
def rne(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    qdd: ArrayLike,
    *,
    gravity: ArrayLike | None = ...,
    wrench: ArrayLike | None = ...,
    base_wrench: Literal[False] = ...,
) -> np.ndarray: ...
@overload
def rne(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    qdd: ArrayLike,
    *,
    gravity: ArrayLike | None = ...,
    wrench: ArrayLike | None = ...,
    base_wrench: Literal[True],
) -> tuple[np.ndarray, np.ndarray]: ...
@overload
def rne(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    qdd: ArrayLike,
    *,
    gravity: ArrayLike | None = ...,
    wrench: ArrayLike | None = ...,
    base_wrench: bool,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]: ...
def rne(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    qdd: ArrayLike,
    *,
    gravity: ArrayLike | None = None,
    wrench: ArrayLike | None = None,
    base_wrench: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Inverse dynamics τ (..., n), friction included.

    gravity: override of the robot's (Corke's convention, world frame).
    wrench: (6,) or (..., 6) [f; n] exerted by the end-effector on the
    environment, in the tool frame, moment about the tool point (adds JᵀW).
    base_wrench: also return [f; n] (..., 6) exerted by the base on link 1,
    in frame {0}, moment about its origin.

    Raises:
        ValueError: a symbolic robot; q, qd or qdd that are not finite numeric arrays
            of shape (n,) or (..., n), or whose leading shapes do not broadcast; a
            gravity that is not a finite 3-vector; a wrench that is not a finite
            (6,) or (..., 6) array broadcasting with the states.
    """
    c = _chain(robot)
    q, qd, qdd = _states(c, q=q, qd=qd, qdd=qdd)
    g = c.gravity if gravity is None else _vector3(gravity, "gravity")
    W = None
    if wrench is not None:
        W = np.asarray(wrench, dtype=float)
        if W.shape[-1:] != (6,) or not np.all(np.isfinite(W)):
            raise ValueError(f"wrench must be a finite array of shape (6,) or (N, 6); got shape {W.shape}")
        W = np.broadcast_to(W, q.shape[:-1] + (6,))
    tau, (n1, f1), (R1, p1) = _recursion(c, q, qd, qdd, g, W)
    tau = tau + friction(robot, qd)
    if not base_wrench:
        return tau
    f0 = np.einsum("...ij,...j->...i", R1, f1)
    n0 = np.einsum("...ij,...j->...i", R1, n1) + _cross(p1, f0)
    return tau, np.concatenate([f0, n0], -1)


def _rne_nofriction(c: _Chain, q, qd, qdd, g) -> np.ndarray:
    return _recursion(c, q, qd, qdd, g)[0]


def inertia(robot: Robot, q: ArrayLike) -> np.ndarray:
    """Joint-space inertia M(q) (..., n, n), rotor term G²·Jm on the diagonal.

    Raises:
        ValueError: a symbolic robot, or `q` that is not a finite numeric array of
            shape (n,) or (..., n).
    """
    c = _chain(robot)
    q = _state(c, q, "q")
    qs = np.repeat(q[..., None, :], c.n, axis=-2)  # (..., n copies, n)
    eye = np.broadcast_to(np.eye(c.n), qs.shape)
    cols = _rne_nofriction(c, qs, np.zeros_like(qs), eye, np.zeros(3))
    return np.swapaxes(cols, -1, -2)


def christoffel(robot: Robot, q: ArrayLike) -> np.ndarray:
    """Christoffel symbols Γ[..., k, i, j] = ½(∂M_kj/∂q_i + ∂M_ki/∂q_j − ∂M_ij/∂q_k),
    from velocity-product forces of the recursion (symmetric split).

    Raises:
        ValueError: a symbolic robot, or `q` that is not a finite numeric array of
            shape (n,) or (..., n).
    """
    c = _chain(robot)
    q = _state(c, q, "q")
    n = c.n
    pairs = [(i, j) for i in range(n) for j in range(i, n)]
    V = np.zeros((len(pairs), n))
    for k, (i, j) in enumerate(pairs):
        V[k, i] = V[k, j] = 1.0
    qs = np.repeat(q[..., None, :], len(pairs), axis=-2)
    h = _rne_nofriction(c, qs, np.broadcast_to(V, qs.shape), np.zeros_like(qs), np.zeros(3))
    Gam = np.zeros(q.shape[:-1] + (n, n, n))
    single = {i: k for k, (i, j) in enumerate(pairs) if i == j}
    for k, (i, j) in enumerate(pairs):
        if i == j:
            Gam[..., :, i, i] = h[..., k, :]
        else:
            val = 0.5 * (h[..., k, :] - h[..., single[i], :] - h[..., single[j], :])
            Gam[..., :, i, j] = val
            Gam[..., :, j, i] = val
    return Gam


def coriolis(robot: Robot, q: ArrayLike, qd: ArrayLike) -> np.ndarray:
    """Christoffel Coriolis matrix C(q, q̇) (..., n, n): C_kj = Σ_i Γ_kij q̇_i.

    Raises:
        ValueError: a symbolic robot; q or qd that are not finite numeric arrays of
            shape (n,) or (..., n), or whose leading shapes do not broadcast.
    """
    c = _chain(robot)
    q, qd = _states(c, q=q, qd=qd)
    return np.einsum("...kij,...i->...kj", christoffel(robot, q), qd)


def gravload(robot: Robot, q: ArrayLike, *, gravity: ArrayLike | None = None) -> np.ndarray:
    """Gravity load G(q) (..., n): the joint torques that hold the arm still.

    Raises:
        ValueError: a symbolic robot; `q` that is not a finite numeric array of
            shape (n,) or (..., n); a gravity that is not a finite 3-vector.
    """
    c = _chain(robot)
    q = _state(c, q, "q")
    g = c.gravity if gravity is None else _vector3(gravity, "gravity")
    z = np.zeros_like(q)
    return _rne_nofriction(c, q, z, z, g)


def accel(robot: Robot, q: ArrayLike, qd: ArrayLike, tau: ArrayLike) -> np.ndarray:
    """Forward dynamics q̈ = M⁻¹(τ − C q̇ − F − G) (..., n), friction included.

    Raises:
        ValueError: a symbolic robot; q, qd or tau that are not finite numeric arrays
            of shape (n,) or (..., n), or whose leading shapes do not broadcast.
        SingularInertia: M(q) is singular (a `ValueError`; it names the joint that
            moves no mass where one does not).
    """
    c = _chain(robot)
    q, qd, tau = _states(c, q=q, qd=qd, tau=tau)
    n, batch = c.n, q.shape[:-1]
    # one recursion over n + 1 rows: q̈ = e_i (q̇ = 0, no gravity) give M's columns, the last the bias
    rows = np.concatenate([np.zeros(batch + (n, n)), qd[..., None, :]], -2)
    unit = np.concatenate([np.broadcast_to(np.eye(n), batch + (n, n)), np.zeros(batch + (1, n))], -2)
    g = np.concatenate([np.zeros((n, 3)), c.gravity[None]])
    out = _recursion(c, np.broadcast_to(q[..., None, :], batch + (n + 1, n)), rows, unit, g)[0]
    bias = out[..., n, :] + friction(robot, qd)
    M = np.swapaxes(out[..., :n, :], -1, -2)
    diagonal = np.diagonal(M, axis1=-2, axis2=-1)
    dead = diagonal <= 1e-12 * np.maximum(diagonal.max(-1, keepdims=True), 1e-300)
    if dead.any():
        raise SingularInertia(robot, int(np.nonzero(dead.reshape(-1, n))[1][0]))
    try:
        return np.linalg.solve(M, (tau - bias)[..., None])[..., 0]
    except np.linalg.LinAlgError:
        raise SingularInertia(robot, None) from None


class SingularInertia(ValueError):
    """M(q) is singular: forward dynamics is undefined (names the joint when one has no inertia)."""

    def __init__(self, robot: Robot, joint: int | None):
        where = (
            f"joint {joint + 1} moves no mass and has no rotor inertia (M[{joint + 1},{joint + 1}] = 0)"
            if joint is not None
            else "its joints' motions are not independent there"
        )
        super().__init__(
            f"the joint-space inertia M(q) of {robot.name!r} is singular: {where}; forward "
            "dynamics is undefined. Give a link beyond that joint mass and inertia, or the "
            "joint a rotor (Jm and G)"
        )


def fdyn(
    robot: Robot,
    T: float,
    q0: ArrayLike,
    qd0: ArrayLike | None = None,
    torque: Callable | None = None,
    *,
    rtol: float = 1e-10,
    atol: float = 1e-10,
    t_eval: ArrayLike | None = None,
    method: str = "DOP853",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate the forward dynamics from (q0, qd0) over [0, T] with scipy.

    torque(t, q, qd) -> τ (n,), or None for zero torque.  Returns (t, q, qd)
    with q, qd of shape (len(t), n).

    Raises:
        ValueError: a symbolic robot; T that is not a positive finite time; q0 or
            qd0 that is not one finite state of shape (n,); a torque(t, q, qd) that
            returns no finite (n,) torque.
        SingularInertia: M(q) is singular along the motion (a `ValueError`).
        RuntimeError: the integrator fails (scipy's message).
    """
    c = _chain(robot)
    if not (np.isscalar(T) and np.isfinite(T) and T > 0):
        raise ValueError(f"T must be a positive finite time, got {T!r}")
    q0 = _state(c, q0, "q0")
    qd0 = np.zeros(c.n) if qd0 is None else _state(c, qd0, "qd0")
    if q0.shape != (c.n,) or qd0.shape != (c.n,):
        raise ValueError(f"fdyn integrates one state: q0 and qd0 must have shape ({c.n},)")
    zero = np.zeros(c.n)

    def rhs(t, x):
        q, qd = x[: c.n], x[c.n :]
        tau = zero if torque is None else _state(c, torque(t, q, qd), "torque(t, q, qd)")
        return np.concatenate([qd, accel(robot, q, qd, tau)])

    sol = solve_ivp(rhs, (0.0, float(T)), np.concatenate([q0, qd0]), method=method, rtol=rtol, atol=atol, t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(f"forward dynamics integration failed: {sol.message}")
    return sol.t, sol.y[: c.n].T, sol.y[c.n :].T


def _frames(c: _Chain, q):
    """World rotation and origin of each body frame: (..., n, 3, 3), (..., n, 3)."""
    R, p = _link_transforms(c, q)
    Rw, pw = c.base_R, c.base_p  # broadcast against the batch by the first product
    Rs, ps = [], []
    for i in range(c.n):
        pw = pw + np.einsum("...ij,...j->...i", Rw, p[..., i, :])
        Rw = Rw @ R[..., i, :, :]
        Rs.append(Rw)
        ps.append(pw)
    return np.stack(Rs, -3), np.stack(ps, -2)


def _tool_point(c: _Chain, Rs, ps) -> np.ndarray:
    """World position (..., 3) of the tool point from the body frames of `_frames`."""
    return ps[..., -1, :] + np.einsum("...ij,j->...i", Rs[..., -1, :, :], c.tool_p)


def fkine(robot: Robot, q: ArrayLike) -> np.ndarray:
    """End-effector pose (..., 4, 4) in the world: base · A₁ ⋯ Aₙ · tool.

    Raises:
        ValueError: a symbolic robot, or `q` that is not a finite numeric array of
            shape (n,) or (..., n).
    """
    c = _chain(robot)
    q = _state(c, q, "q")
    Rs, ps = _frames(c, q)
    Rn = Rs[..., -1, :, :]
    T = np.zeros(q.shape[:-1] + (4, 4))
    T[..., :3, :3] = Rn @ c.tool_R
    T[..., :3, 3] = _tool_point(c, Rs, ps)
    T[..., 3, 3] = 1.0
    return T


def jacob0(robot: Robot, q: ArrayLike) -> np.ndarray:
    """Geometric Jacobian (..., 6, n) of the tool point, [v; ω], world frame.

    Raises:
        ValueError: a symbolic robot, or `q` that is not a finite numeric array of
            shape (n,) or (..., n).
    """
    c = _chain(robot)
    q = _state(c, q, "q")
    Rs, ps = _frames(c, q)
    pe = _tool_point(c, Rs, ps)
    # each joint's axis in the world (S_i in body coordinates mapped by body i's pose); a
    # revolute joint moves the tool point at v_body + z × (p_e − p_body)
    revolute = c.revolute[:, None]
    z = np.einsum("...nij,nj->...ni", Rs, np.where(revolute, c.S[:, :3], c.S[:, 3:]))
    vb = np.einsum("...nij,nj->...ni", Rs, c.S[:, 3:])
    v = np.where(revolute, vb + _cross(z, pe[..., None, :] - ps), z)
    return np.swapaxes(np.concatenate([v, np.where(revolute, z, 0.0)], -1), -1, -2)


def energy(robot: Robot, q: ArrayLike, qd: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic ½q̇ᵀMq̇ (rotors included) and potential Σ mᵢ·a_up·p_cᵢ energy.

    Returns:
        (kinetic, potential), each of shape (...).

    Raises:
        ValueError: a symbolic robot; q or qd that are not finite numeric arrays of
            shape (n,) or (..., n), or whose leading shapes do not broadcast.
    """
    c = _chain(robot)
    q, qd = _states(c, q=q, qd=qd)
    kinetic = 0.5 * np.einsum("...i,...ij,...j->...", qd, inertia(robot, q), qd)
    Rs, ps = _frames(c, q)
    com = ps + np.einsum("...nij,nj->...ni", Rs, c.h / np.where(c.m > 0, c.m, 1.0)[:, None])
    potential = np.einsum("n,...ni,i->...", c.m, com, c.gravity)
    return kinetic, potential
