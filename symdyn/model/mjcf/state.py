"""MuJoCo's states and symdyn's, converted at the edge, in one place.

symdyn holds Pinocchio's state: a free base's q is [x y z qx qy qz qw] (the quaternion's w
last) and its velocity v [linear, angular] both in the body's own frame, then the moving
joints in the robot's order.  MuJoCo's free joint holds qpos [x y z qw qx qy qz] (w first) and
qvel [linear in the world's axes, angular in the body's], and its qpos and qvel cover every
joint of the file (locked ones and other bodies too).  Hinge and slide joints are the same
numbers in both (symdyn's q is MuJoCo's qpos: a link's `offset` is −qpos0).  Accelerations
follow the velocities: the body-frame linear acceleration is Rᵀ·(world rate) − ω × v_body.
Generalized forces are dual to the velocities: a free joint's force is world-axis in MuJoCo's
qfrc, body-axis in symdyn's τ.  For robots read by `Robot.from_mjcf` (its record holds the
addresses: `MjcfRecord.qpos_address` …).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:  # the robot module attaches these functions to Robot: no import at run time
    from ..robot import Robot

__all__ = ["from_mujoco_state", "to_mujoco_state", "to_mujoco_force"]


def _record(robot):
    record = getattr(robot, "mjcf", None)
    if record is None or not record.qpos_address and robot.n:
        raise ValueError(
            f"robot {robot.name!r} was not read by Robot.from_mjcf (or by an older symdyn): it holds no "
            "MuJoCo addresses to convert states with"
        )
    if robot.base_joint == "planar" or (robot.base_joint == "free" and record.free_address[0] < 0):
        raise ValueError(
            f"robot {robot.name!r}: its {robot.base_joint} base is none of the file's joints, so MuJoCo has no "
            "state of it to convert (a base joint symdyn added: base_joint=...)"
        )
    return record


def _array(x: Any, size: int, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim == 0 or a.shape[-1] != size:
        raise ValueError(f"{name} must have shape (..., {size}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinity")
    return a


def _rotation(quat_xyzw: np.ndarray) -> np.ndarray:
    """The rotation of a quaternion taken as MuJoCo takes its qpos: normalised first (MuJoCo
    normalises its free joints' quaternions itself; `from_mujoco_state` returns them normalised)."""
    from ..rotations import quaternion_matrix

    return quaternion_matrix(quat_xyzw / np.linalg.norm(quat_xyzw, axis=-1, keepdims=True))


def from_mujoco_state(robot: "Robot", qpos: ArrayLike, qvel: ArrayLike, qacc: ArrayLike | None = None) -> tuple:
    """(q, v) — or (q, v, a) with `qacc` — in symdyn's (Pinocchio's) coordinates from MuJoCo's
    qpos (..., nq of the file), qvel and qacc (..., nv of the file).

    Raises:
        ValueError: a robot not read by `Robot.from_mjcf`, or with a base joint that is none of
            the file's; arrays of the wrong last size or not finite.
    """
    rec = _record(robot)
    qpos, qvel = _array(qpos, rec.file_nq, "qpos"), _array(qvel, rec.file_nv, "qvel")
    joints_q, joints_v = qpos[..., list(rec.qpos_address)], qvel[..., list(rec.qvel_address)]
    a = None if qacc is None else _array(qacc, rec.file_nv, "qacc")
    joints_a = None if a is None else a[..., list(rec.qvel_address)]
    if robot.base_joint is None:
        return (joints_q, joints_v) if a is None else (joints_q, joints_v, joints_a)
    i, d = rec.free_address
    quat = np.concatenate([qpos[..., i + 4 : i + 7], qpos[..., i + 3 : i + 4]], -1)  # w last
    quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)  # as MuJoCo reads it: normalised
    R = _rotation(quat)
    w = qvel[..., d + 3 : d + 6]
    lin = np.einsum("...ji,...j->...i", R, qvel[..., d : d + 3])  # Rᵀ v_world
    q = np.concatenate([qpos[..., i : i + 3], quat, joints_q], -1)
    v = np.concatenate([lin, w, joints_v], -1)
    if a is None:
        return q, v
    dlin = np.einsum("...ji,...j->...i", R, a[..., d : d + 3]) - np.cross(w, lin)
    return q, v, np.concatenate([dlin, a[..., d + 3 : d + 6], joints_a], -1)


def to_mujoco_state(robot: "Robot", q: ArrayLike, v: ArrayLike, a: ArrayLike | None = None) -> tuple:
    """(qpos, qvel) — or (qpos, qvel, qacc) with `a` — of the file's MuJoCo model from symdyn's
    q (..., nq), v and a (..., nv): the joints symdyn does not move at their locked values (qpos)
    and at rest (qvel, qacc).

    Raises:
        ValueError: as `from_mujoco_state`; a zero base quaternion.
    """
    rec = _record(robot)
    q, v = _array(q, robot.nq, "q"), _array(v, robot.nv, "v")
    a = None if a is None else _array(a, robot.nv, "a")
    lead = np.broadcast_shapes(q.shape[:-1], v.shape[:-1], *(() if a is None else (a.shape[:-1],)))
    qpos = np.broadcast_to(np.array(rec.qpos_locked), lead + (rec.file_nq,)).copy()
    qvel = np.zeros(lead + (rec.file_nv,))
    qacc = None if a is None else np.zeros(lead + (rec.file_nv,))
    k = robot.nq - robot.n
    qpos[..., list(rec.qpos_address)] = q[..., k:]
    qvel[..., list(rec.qvel_address)] = v[..., robot.nv - robot.n :]
    if a is not None:
        qacc[..., list(rec.qvel_address)] = a[..., robot.nv - robot.n :]
    if robot.base_joint == "free":
        i, d = rec.free_address
        quat = q[..., 3:7]
        if np.any(np.linalg.norm(quat, axis=-1) == 0):
            raise ValueError("q[3:7], the base quaternion, is zero: it names no orientation")
        R = _rotation(quat)
        lin, w = v[..., :3], v[..., 3:6]
        qpos[..., i : i + 3] = q[..., :3]
        qpos[..., i + 3] = quat[..., 3]
        qpos[..., i + 4 : i + 7] = quat[..., :3]
        qvel[..., d : d + 3] = np.einsum("...ij,...j->...i", R, lin)
        qvel[..., d + 3 : d + 6] = w
        if a is not None:
            qacc[..., d : d + 3] = np.einsum("...ij,...j->...i", R, a[..., :3] + np.cross(w, lin))
            qacc[..., d + 3 : d + 6] = a[..., 3:6]
    return (qpos, qvel) if a is None else (qpos, qvel, qacc)


def to_mujoco_force(robot: "Robot", q: ArrayLike, tau: ArrayLike) -> np.ndarray:
    """MuJoCo's generalized force (qfrc, ..., nv of the file) of symdyn's τ (..., nv) at q: a free
    base's force turned into the world's axes (its moment stays in the body's), the joints
    symdyn does not move at zero.

    Raises:
        ValueError: as `to_mujoco_state`.
    """
    rec = _record(robot)
    q, tau = _array(q, robot.nq, "q"), _array(tau, robot.nv, "tau")
    lead = np.broadcast_shapes(q.shape[:-1], tau.shape[:-1])
    out = np.zeros(lead + (rec.file_nv,))
    out[..., list(rec.qvel_address)] = tau[..., robot.nv - robot.n :]
    if robot.base_joint == "free":
        d = rec.free_address[1]
        out[..., d : d + 3] = np.einsum("...ij,...j->...i", _rotation(q[..., 3:7]), tau[..., :3])
        out[..., d + 3 : d + 6] = tau[..., 3:6]
    return out
