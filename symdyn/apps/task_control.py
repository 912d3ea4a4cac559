"""Control in the task space on the generated functions: inverse kinematics by damped least
squares, and Khatib's operational-space controller for a redundant arm.

An application of the generated code (`symdyn.load(robot, target)`): the frame's pose,
its world-aligned Jacobian J and drift J̇·v, the joint-space inertia M and the bias
τ(q, v, 0), each one call.  The chapter's operational-space controller
(`symdyn.apps.control.OperationalSpace`) takes the Puma's square Jacobian and J̇·q̇ by finite
differences; this one takes any arm, its J̇·v exact, and spends the redundancy on a posture
in the null space (Khatib 1987; Siciliano et al., *Robotics*, §8.6 and §9.3).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.spatial.transform import Rotation

from ..model import Robot

__all__ = ["IKResult", "inverse_kinematics", "pose_error", "check_pose", "frame_index", "OperationalSpaceController"]

#: How far a given rotation may be from orthonormal (|RᵀR − 1|, largest entry) and a pose's last
#: row from [0 0 0 1]: a rounded matrix passes, a sheared or scaled one does not.
POSE_TOL = 1e-6


def check_pose(pose, what: str) -> np.ndarray:
    """`pose` as a float 4 × 4 homogeneous transform, checked: finite, its last row [0 0 0 1] and
    its rotation proper (RᵀR = 1, det R = +1, to `POSE_TOL`) — a matrix that is not would be
    read as some other rotation (SciPy takes the nearest) or make a goal unreachable.

    Raises:
        ValueError: naming `what`: not 4 × 4, NaN or infinite, a wrong last row, a rotation that
            is not orthonormal (by how much) or is a reflection.
    """
    try:
        T = np.asarray(pose, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a 4x4 pose, got {pose!r}") from None
    if T.shape != (4, 4):
        raise ValueError(f"{what} must be a 4x4 pose, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        raise ValueError(f"{what} must be finite: it has a NaN or infinite entry")
    if np.abs(T[3] - (0, 0, 0, 1)).max() > POSE_TOL:
        raise ValueError(f"{what}: the last row of a pose is [0 0 0 1], got {T[3].tolist()}")
    R = T[:3, :3]
    off = float(np.abs(R.T @ R - np.eye(3)).max())
    if off > POSE_TOL:
        raise ValueError(
            f"{what}: the rotation is not orthonormal (RᵀR differs from 1 by {off:.3g}): give a rotation "
            "matrix (scipy's Rotation.as_matrix(), say)"
        )
    if np.linalg.det(R) < 0:
        raise ValueError(f"{what}: the rotation is a reflection (det R = -1), not a rotation")
    return T


def frame_index(robot, frame, what: str, served: int | None = None) -> int:
    """The index of `frame` (a name of `robot.task_frames`, or an index) among the frames a
    function serves (`served` of them, default `robot`'s count; `robot` None: indices only).

    Raises:
        ValueError: naming `what`: an unknown name (the served ones listed), an index out of range.
    """
    names = [f.name for f in robot.task_frames] if robot is not None else None
    m = served if served is not None else len(names)
    if isinstance(frame, str):
        if names is None:
            raise ValueError(
                f"{what}: frame {frame!r} is a name: give robot= (the robot whose frames the function serves) "
                f"or its index (0 … {m - 1})"
            )
        if frame not in names:
            raise ValueError(
                f"{what}: the model serves no frame {frame!r}; it serves {', '.join(names)} "
                f"(build it on robot.with_frames([..., {frame!r}]))"
            )
        return names.index(frame)
    if isinstance(frame, (int, np.integer)) and not isinstance(frame, bool) and 0 <= frame < m:
        return int(frame)
    served_names = f": {', '.join(names)}" if names else ""
    raise ValueError(f"{what}: frame {frame!r} out of range: the model serves {m} frames{served_names}")


def pose_error(target, T) -> np.ndarray:
    """[p* − p; log(R* Rᵀ)] (6,): the world-aligned twist that moves pose T (4 × 4) to
    `target` to first order (the rotation vector of the remaining turn, world axes)."""
    target, T = np.asarray(target, float), np.asarray(T, float)
    turn = Rotation.from_matrix(target[:3, :3] @ T[:3, :3].T).as_rotvec()
    return np.concatenate([target[:3, 3] - T[:3, 3], turn])


@dataclass(frozen=True)
class IKResult:
    """q (nq,), whether the error fell below the tolerance, the iterations taken and the final
    error's norm (m and rad of `pose_error`, rows outside `axes` not counted)."""

    q: np.ndarray
    converged: bool
    iterations: int
    error: float


def inverse_kinematics(
    model,
    robot: Robot,
    target,
    q0,
    *,
    frame: int | str = 0,
    axes=(True,) * 6,
    damping: float = 1e-3,
    tol: float = 1e-10,
    max_iter: int = 200,
    limits: bool = True,
) -> IKResult:
    """Joint coordinates that put frame `frame` (its name or index in `robot.task_frames`) at the
    pose `target` (4 × 4, world), by damped least squares (Levenberg–Marquardt) on the generated
    `frame_pose` and `frame_jacobian_aligned`: Δq = Jᵀ(J Jᵀ + λ²1)⁻¹ e with e = `pose_error`,
    λ² = damping·(1 + |e|²) (firm far away, vanishing at the solution, where the steps become
    Newton's), q ← q ⊕ Δq (`robot.integrate`: a free base's quaternion stays on its manifold).
    `axes`: the rows of e to meet ([x y z rx ry rz]; position only: (True,)*3 + (False,)*3).
    `limits`: joints clipped into `robot.qlim` after each step.

    Raises:
        ValueError: target not a pose (`check_pose`: 4 × 4, finite, a proper rotation), q0 of the
            wrong size or not finite, an unknown frame or an index out of range.
    """
    target = check_pose(target, "inverse_kinematics: target")
    frame = frame_index(robot, frame, "inverse_kinematics")
    rows = np.flatnonzero(np.asarray(axes, bool))
    q = np.array(q0, float)
    if q.shape != (robot.nq,):
        raise ValueError(f"inverse_kinematics: q0 must have shape ({robot.nq},), got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise ValueError("inverse_kinematics: q0 must be finite: it has a NaN or infinite entry")
    lo, hi = robot.qlim.T
    joints = slice(robot.nq - robot.n, robot.nq)
    for k in range(max_iter + 1):
        e = pose_error(target, model.frame_pose(q)[frame])[rows]
        norm = float(np.linalg.norm(e))
        if norm < tol or k == max_iter:
            return IKResult(q, norm < tol, k, norm)
        J = model.frame_jacobian_aligned(q)[frame][rows]
        lam = damping * (1.0 + norm**2)
        dq = J.T @ np.linalg.solve(J @ J.T + lam * np.eye(len(rows)), e)
        q = robot.integrate(q, dq)
        if limits:
            q[joints] = np.clip(q[joints], lo, hi)
    raise AssertionError("unreachable")


class OperationalSpaceController:
    """Khatib's operational-space controller of one frame of a fixed-base arm, redundant or not:

        a* = ẍ*(t) + Kv (ẋ* − J v) + Kp e,   e = [p* − p; log(R* Rᵀ)],
        τ = Jᵀ Λ (a* − J̇ v) + Nᵀ M (Kq (q₀ − q) − Kqv v) + τ(q, v, 0),

    with J the frame's world-aligned Jacobian, Λ = (J M⁻¹ Jᵀ)⁻¹ the task-space inertia,
    J̄ = M⁻¹ Jᵀ Λ its dynamically consistent inverse and N = 1 − J̄ J the null space in which a
    joint posture q₀ is held without disturbing the task; τ(q, v, 0) = C v + G + F the bias.
    `path(t)` → (p*, ṗ*, p̈*) (3,) each, the frame's position; its orientation is held at R*.
    Everything comes from the generated functions of `model` (frame_pose,
    frame_jacobian_aligned, frame_drift, M, tau).  Stateless: a pure function of (t, q, v).
    `frame`: the frame's name or index in `robot.task_frames`.

    Raises:
        ValueError: a floating base; an unknown frame; R_goal not a 3 × 3 rotation (`check_pose`).
    """

    def __init__(
        self,
        model,
        robot: Robot,
        path: Callable,
        R_goal,
        *,
        frame: int | str = 0,
        Kp: float = 400.0,
        Kv: float = 40.0,
        posture=None,
        Kq: float = 25.0,
        Kqv: float = 10.0,
    ) -> None:
        robot.require_fixed_base("OperationalSpaceController")
        self.model, self.robot, self.path = model, robot, path
        self.frame = frame_index(robot, frame, "OperationalSpaceController")
        if np.shape(R_goal) != (3, 3):
            raise ValueError(f"OperationalSpaceController: R_goal must be a 3x3 rotation, got shape {np.shape(R_goal)}")
        pose = np.eye(4)
        pose[:3, :3] = R_goal
        self.R_goal = check_pose(pose, "OperationalSpaceController: R_goal")[:3, :3]
        self.Kp, self.Kv, self.Kq, self.Kqv = Kp, Kv, Kq, Kqv
        self.posture = np.zeros(robot.n) if posture is None else np.asarray(posture, float)

    def __call__(self, t: float, q, v) -> np.ndarray:
        f, k = self.model, self.frame
        p_goal, pd_goal, pdd_goal = (np.asarray(x, float) for x in self.path(t))
        T = f.frame_pose(q)[k]
        J = f.frame_jacobian_aligned(q)[k]
        drift = f.frame_drift(q, v)[k]
        goal = np.eye(4)
        goal[:3, :3], goal[:3, 3] = self.R_goal, p_goal
        e = pose_error(goal, T)
        xd = J @ v
        a = np.concatenate([pdd_goal, np.zeros(3)]) + self.Kv * (np.concatenate([pd_goal, np.zeros(3)]) - xd)
        a = a + self.Kp * e
        M = f.M(q)
        Minv_Jt = np.linalg.solve(M, J.T)
        Lam = np.linalg.inv(J @ Minv_Jt)
        Jbar = Minv_Jt @ Lam
        N = np.eye(len(q)) - Jbar @ J
        tau0 = M @ (self.Kq * (self.posture - q) - self.Kqv * v)
        return J.T @ (Lam @ (a - drift)) + N.T @ tau0 + f.tau(q, v, np.zeros_like(v))
