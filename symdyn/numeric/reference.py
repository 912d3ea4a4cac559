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

from typing import Callable, Literal, overload

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp

from ..model import Robot
from ..model.base_joint import base_pose, coordinate_rates, normalize
from .chain import BASE_AXES, Chain, chain_of, cross, dynamics, link_transforms, split_state, state, states, vector3

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
    "body_frames",
    "jacob0",
    "energy",
    "momentum",
]


# --------------------------------------------------------------------------- public API


def friction(robot: Robot, qd: ArrayLike) -> np.ndarray:
    """Joint friction F(q̇) (..., nv): G²·B·q̇ + |G|·Tc⁺ (q̇ > 0) or |G|·Tc⁻ (q̇ < 0), 0 at rest
    (and 0 on a base joint's rows).

    Raises:
        ValueError: a symbolic robot, or `qd` that is not a finite numeric array of
            shape (n,) or (..., n).
    """
    return friction_law(robot)(state(chain_of(robot), qd, "qd"))


def friction_law(robot: Robot) -> Callable[[np.ndarray], np.ndarray]:
    """q̇ ↦ `friction(robot, q̇)` with the robot's constants read once and no
    input checks: for inner loops (simulators, model adapters).

    Returns:
        F(q̇) -> (..., n), the friction of `friction` (NumPy's own errors for a bad q̇).

    Raises:
        ValueError: a symbolic robot.
    """
    c = chain_of(robot)
    viscous, gain, up, down = (np.concatenate([np.zeros(c.nb), x]) for x in (c.G**2 * c.B, np.abs(c.G), *c.Tc.T))

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
    """Inverse dynamics τ (..., nv), friction included: q (..., nq), qd = v and qdd = v̇ (..., nv).

    A tree: each link moves with its parent (`robot.parents`).  A floating base
    (`robot.base_joint`): τ's first rows are the force, then the moment, the base joint
    exerts on the base body, in the base frame (Pinocchio's order; planar: fx, fy, n_z).
    gravity: override of the robot's (Corke's convention, world frame).
    wrench: (6,) or (..., 6) [f; n] exerted by the end-effector on the
    environment, in the tool frame, moment about the tool point (adds JᵀW).
    base_wrench: also return [f; n] (..., 6) exerted by the base on the links it
    carries, in frame {0}, moment about its origin (a fixed base only).

    Raises:
        ValueError: a symbolic robot; q, qd or qdd that are not finite numeric arrays
            of shape (n,) or (..., n), or whose leading shapes do not broadcast; a
            gravity that is not a finite 3-vector; a wrench that is not a finite
            (6,) or (..., 6) array broadcasting with the states; base_wrench for a
            floating base (its wrench is τ's first rows); a base quaternion whose norm is not 1.
    """
    c = chain_of(robot)
    if base_wrench and c.base_joint is not None:
        raise ValueError(
            f"base_wrench: robot {robot.name!r} has a {c.base_joint} base joint, whose forces are τ's first {c.nb} rows"
        )
    q, qd, qdd = states(c, q=q, qd=qd, qdd=qdd)
    g = c.gravity if gravity is None else vector3(gravity, "gravity")
    W = None
    if wrench is not None:
        W = np.asarray(wrench, dtype=float)
        if W.shape[-1:] != (6,) or not np.all(np.isfinite(W)):
            raise ValueError(f"wrench must be a finite array of shape (6,) or (N, 6); got shape {W.shape}")
        W = np.broadcast_to(W, q.shape[:-1] + (6,))
    tau, (n0, f0) = dynamics(c, q, qd, qdd, g, W)
    tau = tau + friction(robot, qd)
    if not base_wrench:
        return tau
    return tau, np.concatenate([f0, n0], -1)


def _rne_nofriction(c: Chain, q, qd, qdd, g) -> np.ndarray:
    return dynamics(c, q, qd, qdd, g)[0]


def inertia(robot: Robot, q: ArrayLike) -> np.ndarray:
    """Joint-space inertia M(q) (..., nv, nv), rotor term G²·Jm on the diagonal.

    Raises:
        ValueError: a symbolic robot, or `q` that is not a finite numeric array of
            shape (nq,) or (..., nq).
    """
    c = chain_of(robot)
    q = state(c, q, "q")
    qs = np.repeat(q[..., None, :], c.nv, axis=-2)  # (..., nv copies, nq)
    eye = np.broadcast_to(np.eye(c.nv), qs.shape[:-1] + (c.nv,))
    cols = _rne_nofriction(c, qs, np.zeros_like(eye), eye, np.zeros(3))
    return np.swapaxes(cols, -1, -2)


def christoffel(robot: Robot, q: ArrayLike) -> np.ndarray:
    """Christoffel symbols Γ[..., k, i, j] = ½(∂M_kj/∂q_i + ∂M_ki/∂q_j − ∂M_ij/∂q_k),
    from velocity-product forces of the recursion (symmetric split); trees included.

    Raises:
        ValueError: a symbolic robot, or `q` that is not a finite numeric array of
            shape (n,) or (..., n).
        NotImplementedError: a floating base (its velocities are not q̇).
    """
    c = chain_of(robot)
    if c.base_joint is not None:
        raise NotImplementedError(
            f"Christoffel symbols of robot {robot.name!r}: its {c.base_joint} base's velocities are not the "
            "derivatives of coordinates; its C(q, v)·v is rne(robot, q, v, 0, gravity=(0, 0, 0))"
        )
    q = state(c, q, "q")
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
    """Coriolis matrix C(q, v) (..., nv, nv) with C·v the velocity-product forces and Ṁ − 2C
    skew-symmetric: the Christoffel matrix C_kj = Σ_i Γ_kij q̇_i on a fixed base; on a floating
    base, whose velocities are no coordinates' rates, the spatial factorisation
    C = Σ Jᵢᵀ(Iᵢ J̇ᵢ + Bᵢ Jᵢ), Bᵢ = ½[(Vᵢ×*)Iᵢ + Iᵢ(Vᵢ×) + (IᵢVᵢ)×̄] (`_spatial_coriolis`).

    Raises:
        ValueError: a symbolic robot; q or qd that are not finite numeric arrays of
            shape (nq,) / (nv,) or (..., nq) / (..., nv), or whose leading shapes do not
            broadcast; a base quaternion whose norm is not 1.
    """
    c = chain_of(robot)
    q, qd = states(c, q=q, qd=qd)
    if c.base_joint is not None:
        return _spatial_coriolis(c, q, qd)
    return np.einsum("...kij,...i->...kj", christoffel(robot, q), qd)


def _motion_cross(V: np.ndarray) -> np.ndarray:
    """V× (..., 6, 6) of motions V = (ω, v): [[ω×, 0], [v×, ω×]]."""
    w, v = _skew3(V[..., :3]), _skew3(V[..., 3:])
    zero = np.zeros_like(w)
    return np.concatenate([np.concatenate([w, zero], -1), np.concatenate([v, w], -1)], -2)


def _force_bar(f: np.ndarray) -> np.ndarray:
    """f×̄ (..., 6, 6) with (f×̄)·V = V×*·f, forces f = (n, f): [[−n×, −f×], [−f×, 0]] (skew)."""
    n, fl = _skew3(f[..., :3]), _skew3(f[..., 3:])
    return -np.concatenate([np.concatenate([n, fl], -1), np.concatenate([fl, np.zeros_like(fl)], -1)], -2)


def _skew3(a: np.ndarray) -> np.ndarray:
    S = np.zeros(a.shape + (3,))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -a[..., 2], a[..., 1], -a[..., 0]
    return S - np.swapaxes(S, -1, -2)


def _spatial_coriolis(c: Chain, q, v) -> np.ndarray:
    """C = Σ Jᵢᵀ(Iᵢ J̇ᵢ + Bᵢ Jᵢ) over every body (the base body's included) in body coordinates,
    where Iᵢ is constant: Bᵢ skew with Bᵢ Vᵢ = Vᵢ ×* Iᵢ Vᵢ makes Ṁ − 2C skew.  Body Jacobians
    down the tree: Jᵢ = X Jₚ + Sᵢ eᵢᵀ, J̇ᵢ = X J̇ₚ − (Sᵢ q̇ᵢ)× X Jₚ."""
    qj, vj = split_state(c, q)[1], split_state(c, v)[1]
    R, p = link_transforms(c, qj)
    batch, nb = q.shape[:-1], c.nb

    def spatial(m, h, Io):  # 6×6 inertia about the origin, (ω, v) → (n, f)
        H = _skew3(h)
        return np.block([[Io, H], [-H, m * np.eye(3)]])

    J0 = np.zeros(batch + (6, c.nv))
    J0[..., :, :nb] = BASE_AXES[c.base_joint]
    Jd0 = np.zeros_like(J0)
    C = np.zeros(batch + (c.nv, c.nv))

    def add(J, Jd, inertia):
        V = np.einsum("...ij,...j->...i", J, v)
        cross = _motion_cross(V)  # V×* = −(V×)ᵀ
        B = 0.5 * (
            -np.swapaxes(cross, -1, -2) @ inertia + inertia @ cross + _force_bar(np.einsum("ij,...j->...i", inertia, V))
        )
        return np.swapaxes(J, -1, -2) @ (inertia @ Jd + B @ J)

    C += add(J0, Jd0, spatial(*c.base_body))
    Js, Jds = [], []
    for i in range(c.n):
        Jp, Jdp = (Js[c.parents[i]], Jds[c.parents[i]]) if c.parents[i] >= 0 else (J0, Jd0)
        Rt = np.swapaxes(R[..., i, :, :], -1, -2)
        X = np.zeros(batch + (6, 6))
        X[..., :3, :3] = X[..., 3:, 3:] = Rt
        X[..., 3:, :3] = -Rt @ _skew3(p[..., i, :])
        J = X @ Jp
        J[..., :, nb + i] += c.S[i]
        motion = c.S[i] * vj[..., i, None]
        Jd = X @ Jdp - _motion_cross(motion) @ X @ Jp
        Js.append(J)
        Jds.append(Jd)
        C += add(J, Jd, spatial(c.m[i], c.h[i], c.Io[i]))
    return C


def gravload(robot: Robot, q: ArrayLike, *, gravity: ArrayLike | None = None) -> np.ndarray:
    """Gravity load G(q) (..., n): the joint torques that hold the arm still.

    Raises:
        ValueError: a symbolic robot; `q` that is not a finite numeric array of
            shape (n,) or (..., n); a gravity that is not a finite 3-vector.
    """
    c = chain_of(robot)
    q = state(c, q, "q")
    g = c.gravity if gravity is None else vector3(gravity, "gravity")
    z = np.zeros(q.shape[:-1] + (c.nv,))
    return _rne_nofriction(c, q, z, z, g)


def accel(robot: Robot, q: ArrayLike, qd: ArrayLike, tau: ArrayLike) -> np.ndarray:
    """Forward dynamics v̇ = M⁻¹(τ − C v − F − G) (..., nv), friction included; q (..., nq).

    Raises:
        ValueError: a symbolic robot; q, qd or tau that are not finite numeric arrays
            of shape (nq,) / (nv,) or (..., nq) / (..., nv), or whose leading shapes do
            not broadcast; a base quaternion whose norm is not 1.
        SingularInertia: M(q) is singular (a `ValueError`; it names the joint that
            moves no mass where one does not).
    """
    c = chain_of(robot)
    q, qd, tau = states(c, q=q, qd=qd, tau=tau)
    n, batch = c.nv, q.shape[:-1]
    # one recursion over n + 1 rows: q̈ = e_i (q̇ = 0, no gravity) give M's columns, the last the bias
    rows = np.concatenate([np.zeros(batch + (n, n)), qd[..., None, :]], -2)
    unit = np.concatenate([np.broadcast_to(np.eye(n), batch + (n, n)), np.zeros(batch + (1, n))], -2)
    g = np.concatenate([np.zeros((n, 3)), c.gravity[None]])
    out = dynamics(c, np.broadcast_to(q[..., None, :], batch + (n + 1, c.nq)), rows, unit, g)[0]
    bias = out[..., n, :] + friction(robot, qd)
    M = np.swapaxes(out[..., :n, :], -1, -2)
    diagonal = np.diagonal(M, axis1=-2, axis2=-1)
    dead = diagonal <= 1e-12 * np.maximum(diagonal.max(-1, keepdims=True), 1e-300)
    if dead.any():
        k = int(np.nonzero(dead.reshape(-1, n))[1][0]) - c.nb
        raise SingularInertia(robot, k if k >= 0 else None)
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

    torque(t, q, qd) -> τ (nv,), or None for zero torque.  Returns (t, q, qd)
    with q of shape (len(t), nq), qd = v of shape (len(t), nv).  A floating base's
    coordinates follow `coordinate_rates`; its quaternion is normalised in the output.

    Raises:
        ValueError: a symbolic robot; T that is not a positive finite time; q0 or
            qd0 that is not one finite state of shape (nq,) / (nv,); a torque(t, q, qd)
            that returns no finite (nv,) torque; a quaternion whose norm is not 1.
        SingularInertia: M(q) is singular along the motion (a `ValueError`).
        RuntimeError: the integrator fails (scipy's message).
    """
    c = chain_of(robot)
    if not (np.isscalar(T) and np.isfinite(T) and T > 0):
        raise ValueError(f"T must be a positive finite time, got {T!r}")
    q0 = state(c, q0, "q0")
    qd0 = np.zeros(c.nv) if qd0 is None else state(c, qd0, "qd0")
    if q0.shape != (c.nq,) or qd0.shape != (c.nv,):
        shapes = f"shape ({c.nq},)" if c.nq == c.nv else f"shapes ({c.nq},) and ({c.nv},)"
        raise ValueError(f"fdyn integrates one state: q0 and qd0 must have {shapes}")
    base_pose(c.base_joint, q0) if c.base_joint else None  # a quaternion of the wrong norm is refused here
    zero = np.zeros(c.nv)

    def rhs(t, x):
        q, qd = x[: c.nq], x[c.nq :]
        if c.base_joint == "free":  # the integrator's drift off the unit sphere, not the user's input
            q = np.concatenate([q[:3], q[3:7] / np.linalg.norm(q[3:7]), q[7:]])
        tau = zero if torque is None else state(c, torque(t, q, qd), "torque(t, q, qd)")
        return np.concatenate([coordinate_rates(robot, q, qd), accel(robot, q, qd, tau)])

    sol = solve_ivp(rhs, (0.0, float(T)), np.concatenate([q0, qd0]), method=method, rtol=rtol, atol=atol, t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(f"forward dynamics integration failed: {sol.message}")
    q = sol.y[: c.nq].T
    return sol.t, (normalize(robot, q) if c.base_joint == "free" else q), sol.y[c.nq :].T


def _base_frame(c: Chain, q) -> tuple[np.ndarray, np.ndarray]:
    """World rotation and origin of frame 0 (the base, or the body a base joint moves) from q (nq)."""
    if c.base_joint is None:
        return np.broadcast_to(c.base_R, q.shape[:-1] + (3, 3)), np.broadcast_to(c.base_p, q.shape[:-1] + (3,))
    Rb, pb = base_pose(c.base_joint, q)
    return c.base_R @ Rb, c.base_p + np.einsum("ij,...j->...i", c.base_R, pb)


def _frames(c: Chain, q):
    """World rotation and origin of each body frame from q (nq): (..., n, 3, 3), (..., n, 3)."""
    R, p = link_transforms(c, split_state(c, q)[1])
    R0, p0 = _base_frame(c, q)
    Rs, ps = [], []
    for i in range(c.n):
        Rw, pw = (Rs[c.parents[i]], ps[c.parents[i]]) if c.parents[i] >= 0 else (R0, p0)
        ps.append(pw + np.einsum("...ij,...j->...i", Rw, p[..., i, :]))
        Rs.append(Rw @ R[..., i, :, :])
    if not Rs:  # a lone body on its base joint
        return np.zeros(q.shape[:-1] + (0, 3, 3)), np.zeros(q.shape[:-1] + (0, 3))
    return np.stack(Rs, -3), np.stack(ps, -2)


def _ancestors(c: Chain, i: int) -> list[int]:
    """Link i and the links it hangs on, down to the base."""
    out = []
    while i >= 0:
        out.append(i)
        i = c.parents[i]
    return out


def _tool_point(c: Chain, Rs, ps) -> np.ndarray:
    """World position (..., 3) of the tool point from the body frames of `_frames`."""
    return ps[..., -1, :] + np.einsum("...ij,j->...i", Rs[..., -1, :, :], c.tool_p)


def fkine(robot: Robot, q: ArrayLike) -> np.ndarray:
    """End-effector pose (..., 4, 4) in the world: base · A₁ ⋯ Aₙ · tool.

    Raises:
        ValueError: a symbolic robot, or `q` that is not a finite numeric array of
            shape (n,) or (..., n).
    """
    c = chain_of(robot)
    tool = np.eye(4)
    tool[:3, :3], tool[:3, 3] = c.tool_R, c.tool_p
    return body_frames(robot, q)[..., -1, :, :] @ tool


def body_frames(robot: Robot, q: ArrayLike) -> np.ndarray:
    """World placements (..., n + 1, 4, 4) of frame 0 (the base, or the body a base joint moves)
    and of each link's body frame (its parent's · A_i: base·A₁, base·A₁·A₂, … on a chain).

    Raises:
        ValueError: a symbolic robot, or `q` that is not a finite numeric array of
            shape (nq,) or (..., nq).
    """
    c = chain_of(robot)
    q = state(c, q, "q")
    Rs, ps = _frames(c, q)
    R0, p0 = _base_frame(c, q)
    T = np.zeros(q.shape[:-1] + (c.n + 1, 4, 4))
    T[..., 0, :3, :3], T[..., 0, :3, 3] = R0, p0
    T[..., 1:, :3, :3], T[..., 1:, :3, 3] = Rs, ps
    T[..., 3, 3] = 1.0
    return T


def jacob0(robot: Robot, q: ArrayLike) -> np.ndarray:
    """Geometric Jacobian (..., 6, nv) of the tool point (on the last link), [v; ω], world
    frame: zero in the columns of joints on other branches; a floating base's columns map
    its body-frame velocity.

    Raises:
        ValueError: a symbolic robot, or `q` that is not a finite numeric array of
            shape (nq,) or (..., nq).
    """
    c = chain_of(robot)
    q = state(c, q, "q")
    Rs, ps = _frames(c, q)
    pe = _tool_point(c, Rs, ps)
    # each joint's axis in the world (S_i in body coordinates mapped by body i's pose); a
    # revolute joint moves the tool point at v_body + z × (p_e − p_body)
    revolute = c.revolute[:, None]
    z = np.einsum("...nij,nj->...ni", Rs, np.where(revolute, c.S[:, :3], c.S[:, 3:]))
    vb = np.einsum("...nij,nj->...ni", Rs, c.S[:, 3:])
    v = np.where(revolute, vb + cross(z, pe[..., None, :] - ps), z)
    on_path = np.isin(np.arange(c.n), _ancestors(c, c.n - 1))[:, None]
    J = np.swapaxes(np.where(on_path, np.concatenate([v, np.where(revolute, z, 0.0)], -1), 0.0), -1, -2)
    if c.base_joint is None:
        return J
    R0, p0 = _base_frame(c, q)
    arm = pe - p0  # (ω × arm) = −[arm]× ω
    skew = np.zeros(arm.shape + (3,))
    skew[..., 0, 1], skew[..., 0, 2], skew[..., 1, 2] = -arm[..., 2], arm[..., 1], -arm[..., 0]
    skew = skew - np.swapaxes(skew, -1, -2)
    top = np.concatenate([R0, -skew @ R0], -1)
    bottom = np.concatenate([np.zeros_like(R0), R0], -1)
    base = np.concatenate([top, bottom], -2) @ BASE_AXES[c.base_joint][[3, 4, 5, 0, 1, 2]]
    return np.concatenate([base, J], -1)


def energy(robot: Robot, q: ArrayLike, qd: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic ½q̇ᵀMq̇ (rotors included) and potential Σ mᵢ·a_up·p_cᵢ energy.

    Returns:
        (kinetic, potential), each of shape (...).

    Raises:
        ValueError: a symbolic robot; q or qd that are not finite numeric arrays of
            shape (n,) or (..., n), or whose leading shapes do not broadcast.
    """
    c = chain_of(robot)
    q, qd = states(c, q=q, qd=qd)
    kinetic = 0.5 * np.einsum("...i,...ij,...j->...", qd, inertia(robot, q), qd)
    Rs, ps, m, h = _bodies(c, q)
    com = ps + np.einsum("...nij,nj->...ni", Rs, h / np.where(m > 0, m, 1.0)[:, None])
    potential = np.einsum("n,...ni,i->...", m, com, c.gravity)
    return kinetic, potential


def _bodies(c: Chain, q) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """World rotations (..., k, 3, 3), origins (..., k, 3), masses (k,) and first moments (k, 3)
    of every body: the links, then the body a base joint moves (massless for a fixed base)."""
    Rs, ps = _frames(c, q)
    R0, p0 = _base_frame(c, q)
    m0, h0, _ = c.base_body
    return (
        np.concatenate([Rs, R0[..., None, :, :]], -3),
        np.concatenate([ps, p0[..., None, :]], -2),
        np.append(c.m, m0),
        np.concatenate([c.h, h0[None]]),
    )


def momentum(robot: Robot, q: ArrayLike, qd: ArrayLike) -> np.ndarray:
    """The robot's momentum (..., 6) in the world: linear, then angular about the world origin
    (every body, a floating base's included; rotors not counted).

    Raises:
        ValueError: a symbolic robot; q or qd that are not finite numeric arrays of
            shape (nq,) / (nv,) or (..., nq) / (..., nv), or whose leading shapes do not
            broadcast; a base quaternion whose norm is not 1.
    """
    c = chain_of(robot)
    q, qd = states(c, q=q, qd=qd)
    Rs, ps, m, h = _bodies(c, q)
    w, v = _velocities(c, q, qd)  # body coordinates, bodies as in `_bodies`
    Io = np.concatenate([c.Io, c.base_body[2][None]])
    # spatial momentum about each body's origin in its frame: (Io w + h × v, m v + w × h)
    L = np.einsum("kij,...kj->...ki", Io, w) + cross(h, v)
    P = m[:, None] * v + cross(w, h)
    Pw = np.einsum("...kij,...kj->...ki", Rs, P)
    Lw = np.einsum("...kij,...kj->...ki", Rs, L) + cross(ps, Pw)
    return np.concatenate([Pw.sum(-2), Lw.sum(-2)], -1)


def _velocities(c: Chain, q, qd) -> tuple[np.ndarray, np.ndarray]:
    """Angular and linear velocity (..., n + 1, 3) of every body in its own frame (`_bodies`' order)."""
    qj, (vb, vj) = split_state(c, q)[1], split_state(c, qd)
    R, p = link_transforms(c, qj)
    batch = q.shape[:-1]
    if c.base_joint is None:
        w0 = v0 = np.zeros(batch + (3,))
    else:
        w0, v0 = np.split(np.einsum("ij,...j->...i", BASE_AXES[c.base_joint], vb), 2, -1)
    ws, vs = [], []
    for i in range(c.n):
        w, v = (ws[c.parents[i]], vs[c.parents[i]]) if c.parents[i] >= 0 else (w0, v0)
        Rt = np.swapaxes(R[..., i, :, :], -1, -2)
        qdi = vj[..., i, None]
        vs.append(np.einsum("...ij,...j->...i", Rt, v + cross(w, p[..., i, :])) + c.S[i, 3:] * qdi)
        ws.append(np.einsum("...ij,...j->...i", Rt, w) + c.S[i, :3] * qdi)
    return np.stack(ws + [w0], -2), np.stack(vs + [v0], -2)
