"""Configurations of a robot whose base moves: q of size nq, v of size nv, and the maps between them.

A free base (Pinocchio's free-flyer) has q = [x, y, z, qx, qy, qz, qw] — the base
frame's origin in the world and its orientation as a unit quaternion — and
v = [linear velocity, angular velocity], both in the base frame; a planar base has
q = [x, y, yaw] and v = [vx, vy, ω], again in the base frame.  The joints follow
with q̇ = v.  `integrate` moves along the body-frame twist by the group's
exponential (SE(3), SE(2)), `difference` is its inverse; a quaternion whose norm
is off by more than `QUATERNION_TOLERANCE` is refused (never silently used), one
within it is normalised.  NumPy only; every function is batched over leading axes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .rotations import quaternion_matrix

__all__ = ["integrate", "difference", "normalize", "base_pose", "coordinate_rates", "QUATERNION_TOLERANCE"]

#: Largest |‖quaternion‖ − 1| accepted (and then normalised); a larger one is refused.
QUATERNION_TOLERANCE = 1e-6


def _array(robot, x: Any, size: int, name: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a numeric array of shape ({size},) or (N, {size}), got {x!r}") from None
    if a.ndim == 0 or a.shape[-1] != size:
        raise ValueError(
            f"{name} of robot {robot.name!r} must have shape ({size},) or (N, {size}); got shape {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinity")
    return a


def _unit_quaternion(quat: np.ndarray, name: str) -> np.ndarray:
    norm = np.linalg.norm(quat, axis=-1, keepdims=True)
    off = np.abs(norm - 1.0)
    if np.any(off > QUATERNION_TOLERANCE):
        worst = float(norm.reshape(-1)[np.argmax(off.reshape(-1))])
        raise ValueError(
            f"the base quaternion (qx, qy, qz, qw) = {name}[3:7] has norm {worst:.9g}, not 1: "
            "normalise it first (robot.normalize(q))"
        )
    return quat / norm


def _skew(w: np.ndarray) -> np.ndarray:
    S = np.zeros(w.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    return S - np.swapaxes(S, -1, -2)


def _quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    av, aw, bv, bw = a[..., :3], a[..., 3:], b[..., :3], b[..., 3:]
    return np.concatenate([aw * bv + bw * av + np.cross(av, bv), aw * bw - (av * bv).sum(-1, keepdims=True)], -1)


def _exp_quaternion(phi: np.ndarray) -> np.ndarray:
    """The unit quaternion of the rotation vector phi (..., 3)."""
    angle = np.linalg.norm(phi, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(θ/2)/θ, with its series where θ is tiny (no 0/0)
    k = np.where(angle > 1e-8, np.sin(half) / np.where(angle > 1e-8, angle, 1.0), 0.5 - angle**2 / 48)
    return np.concatenate([k * phi, np.cos(half)], -1)


def _so3_terms(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(1 − cos θ)/θ² and (θ − sin θ)/θ³ of the rotation vector w, series below 1e-4."""
    t = np.linalg.norm(w, axis=-1)[..., None, None]
    small = t < 1e-4
    ts = np.where(small, 1.0, t)
    a = np.where(small, 0.5 - t**2 / 24, (1 - np.cos(ts)) / ts**2)
    b = np.where(small, 1 / 6 - t**2 / 120, (ts - np.sin(ts)) / ts**3)
    return a, b


def _exp6(v: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Translation of SE(3)'s exponential of the twist (v, ω) and the quaternion of its rotation."""
    W = _skew(w)
    a, b = _so3_terms(w)
    V = np.eye(3) + a * W + b * (W @ W)
    return np.einsum("...ij,...j->...i", V, v), _exp_quaternion(w)


def _log3(R: np.ndarray) -> np.ndarray:
    """The rotation vector (..., 3) of rotation matrices (angle in [0, π])."""
    cos = np.clip((np.trace(R, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0)
    axis_sin = 0.5 * np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1
    )
    sin = np.linalg.norm(axis_sin, axis=-1)
    angle = np.arctan2(sin, cos)
    near_pi = cos < -0.99
    out = axis_sin * np.where(sin > 1e-12, angle / np.where(sin > 1e-12, sin, 1.0), 1.0)[..., None]
    if np.any(near_pi):  # sin θ → 0 near π: the axis from R's symmetric part, cos θ·1 + (1 − cos θ)·a aᵀ
        Rp, c = R[near_pi], cos[near_pi][:, None, None]
        B = ((Rp + np.swapaxes(Rp, -1, -2)) / 2 - c * np.eye(3)) / (1 - c)
        k = np.argmax(np.diagonal(B, axis1=-2, axis2=-1), -1)
        a = B[np.arange(len(k)), k] / np.sqrt(B[np.arange(len(k)), k, k])[:, None]
        sign = np.sign((a * axis_sin[near_pi]).sum(-1))
        a *= np.where(sign == 0, 1.0, sign)[:, None]
        out[near_pi] = a * angle[near_pi][:, None]
    return out


def _split(robot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    k = robot.nq - robot.n
    return q[..., :k], q[..., k:]


def normalize(robot, q: Any) -> np.ndarray:
    """q with its base quaternion scaled to unit norm (a fixed or planar base: q as given)."""
    q = _array(robot, q, robot.nq, "q").copy()
    if robot.base_joint == "free":
        norm = np.linalg.norm(q[..., 3:7], axis=-1, keepdims=True)
        if np.any(norm == 0):
            raise ValueError("q[3:7], the base quaternion, is zero: it names no orientation")
        q[..., 3:7] /= norm
    return q


def base_pose(kind: str, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rotation (..., 3, 3) and translation (..., 3) of a base joint of `kind` ("free",
    "planar") from q (..., nq), its quaternion checked (`QUATERNION_TOLERANCE`)."""
    if kind == "free":
        return quaternion_matrix(_unit_quaternion(q[..., 3:7], "q")), q[..., :3]
    c, s = np.cos(q[..., 2]), np.sin(q[..., 2])
    R = np.zeros(q.shape[:-1] + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1], R[..., 2, 2] = c, -s, s, c, 1.0
    p = np.concatenate([q[..., :2], np.zeros(q.shape[:-1] + (1,))], -1)
    return R, p


def _planar_V(phi: np.ndarray) -> np.ndarray:
    """SE(2)'s left Jacobian of the turn phi: translation of exp(v, ω) is V(ω)·v."""
    small = np.abs(phi) < 1e-4
    ps = np.where(small, 1.0, phi)
    a = np.where(small, 1 - phi**2 / 6, np.sin(ps) / ps)
    b = np.where(small, phi / 2 - phi**3 / 24, (1 - np.cos(ps)) / ps)
    return np.stack([np.stack([a, -b], -1), np.stack([b, a], -1)], -2)


def integrate(robot, q: Any, v: Any, dt: float = 1.0) -> np.ndarray:
    """q ⊕ v·dt (see the module's docstring)."""
    q = _array(robot, q, robot.nq, "q")
    v = _array(robot, v, robot.nv, "v") * float(dt)
    batch = np.broadcast_shapes(q.shape[:-1], v.shape[:-1])
    q, v = np.broadcast_to(q, batch + q.shape[-1:]), np.broadcast_to(v, batch + v.shape[-1:])
    qb, qj = _split(robot, q)
    k = robot.nv - robot.n
    vb, vj = v[..., :k], v[..., k:]
    if robot.base_joint == "free":
        R, p = base_pose(robot.base_joint, q)
        dp, dquat = _exp6(vb[..., :3], vb[..., 3:])
        quat = _quaternion_product(_unit_quaternion(qb[..., 3:7], "q"), dquat)
        quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
        qb = np.concatenate([p + np.einsum("...ij,...j->...i", R, dp), quat], -1)
    elif robot.base_joint == "planar":
        R, _ = base_pose(robot.base_joint, q)
        dp = np.einsum("...ij,...j->...i", _planar_V(vb[..., 2]), vb[..., :2])
        qb = np.concatenate(
            [qb[..., :2] + np.einsum("...ij,...j->...i", R[..., :2, :2], dp), qb[..., 2:] + vb[..., 2:]], -1
        )
    return np.concatenate([qb, qj + vj], -1)


def difference(robot, q0: Any, q1: Any) -> np.ndarray:
    """v with integrate(q0, v) = q1 (the shorter turn where two reach it)."""
    q0 = _array(robot, q0, robot.nq, "q0")
    q1 = _array(robot, q1, robot.nq, "q1")
    q0, q1 = np.broadcast_arrays(q0, q1)
    vj = _split(robot, q1)[1] - _split(robot, q0)[1]
    if robot.base_joint is None:
        return vj
    R0, p0 = base_pose(robot.base_joint, q0)
    R1, p1 = base_pose(robot.base_joint, q1)
    dp = np.einsum("...ji,...j->...i", R0, p1 - p0)
    if robot.base_joint == "free":
        _unit_quaternion(q1[..., 3:7], "q1")
        w = _log3(np.swapaxes(R0, -1, -2) @ R1)
        W = _skew(w)
        a, b = _so3_terms(w)
        V = np.eye(3) + a * W + b * (W @ W)
        vb = np.concatenate([np.linalg.solve(V, dp[..., None])[..., 0], w], -1)
    else:
        phi = np.arctan2(np.sin(q1[..., 2] - q0[..., 2]), np.cos(q1[..., 2] - q0[..., 2]))
        lin = np.linalg.solve(_planar_V(phi), dp[..., :2, None])[..., 0]
        vb = np.concatenate([lin, phi[..., None]], -1)
    return np.concatenate([vb, vj], -1)


def coordinate_rates(robot, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """q̇ (..., nq) of the velocity v (..., nv): a free base's ṗ = R·v_lin and quaternion rate
    ½·quat ⊗ (ω, 0), a planar base's ṗ = R·v_xy, yaw rate ω; the joints' q̇ = v."""
    k = robot.nv - robot.n
    vb, vj = v[..., :k], v[..., k:]
    if robot.base_joint is None:
        return vj
    R, _ = base_pose(robot.base_joint, q)
    if robot.base_joint == "free":
        quat = q[..., 3:7]
        rate = 0.5 * _quaternion_product(quat, np.concatenate([vb[..., 3:], np.zeros(vb.shape[:-1] + (1,))], -1))
        qb = np.concatenate([np.einsum("...ij,...j->...i", R, vb[..., :3]), rate], -1)
    else:
        qb = np.concatenate([np.einsum("...ij,...j->...i", R[..., :2, :2], vb[..., :2]), vb[..., 2:]], -1)
    return np.concatenate([qb, vj], -1)
