"""The legged OCP's baseline: a free-base recursion written plainly in CasADi SX.

What `casadi_rnea` is for an arm: Featherstone's RNEA in body coordinates, the free base the
root body (q = x y z qx qy qz qw then the joints; v and a the base's body twist and its derivative
then the joints — Pinocchio's convention and symdyn's), written once as a user would by hand.  The
feet's placements, world-aligned velocities and classical accelerations come from the same forward
pass; J is CasADi's derivative of the feet's velocities by v, M its derivative of τ by a, and the
impact a `casadi.solve`.  Only CasADi's own constant folding applies.  The legged OCP
(`symdyn.apps.ocp_legged.solve(source="plain")`) sets symdyn's generated functions against these.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..model import Robot
from ..model.rotations import quaternion_entries
from .casadi_rnea import body_force, joint_friction, link_constants, transform

__all__ = ["functions"]


def _base(robot: Robot) -> dict:
    """The base body's constants as `link_constants` gives a link's (a massless base: zeros)."""
    body = robot.base_body
    m = float(body.m) if body is not None else 0.0
    r = np.array(body.r, dtype=float) if body is not None else np.zeros(3)
    Ic = np.array(body.I, dtype=float) if body is not None else np.zeros((3, 3))
    return {"m": m, "h": m * r, "Io": Ic + m * (r @ r * np.eye(3) - np.outer(r, r))}


def _forward(robot: Robot, q, v, a, gravity: bool) -> list:
    """Each body's (R, p) in the world, (R, p) in its parent (None for the base), (ω, v, dω, dv) in
    its own axes — the base body first, then the links — and its force [moment, force] (body
    axes), by the forward pass."""
    links, nb = link_constants(robot), 6
    base = np.array(robot.base, dtype=float)
    R0 = ca.mtimes(
        ca.DM(base[:3, :3]), ca.reshape(ca.vertcat(*quaternion_entries(*(q[3 + k] for k in range(4)))), 3, 3).T
    )
    p0 = ca.DM(base[:3, 3]) + ca.mtimes(ca.DM(base[:3, :3]), q[:3])
    g = ca.DM(np.array(robot.gravity, dtype=float)) if gravity else ca.DM.zeros(3)
    motion = (v[3:6], v[:3], a[3:6], a[:3] + ca.mtimes(R0.T, g))  # the base's: Corke's upward g
    bodies = [((R0, p0), None, motion, body_force(_base(robot), *motion))]
    for i, k in enumerate(links):
        (Rw, pw), _, (w, vv, dw, dv), _ = bodies[robot.parents[i] + 1]
        R, p = transform(k, q[7 + i])
        qd, qdd = v[nb + i], a[nb + i]
        sw, sv = ca.DM(k["S"][:3]), ca.DM(k["S"][3:])
        w_in, v_in = ca.mtimes(R.T, w), ca.mtimes(R.T, vv + ca.cross(w, p))
        dw_in, dv_in = ca.mtimes(R.T, dw), ca.mtimes(R.T, dv + ca.cross(dw, p))
        w, vv = w_in + sw * qd, v_in + sv * qd
        dw = dw_in + sw * qdd + ca.cross(w, sw * qd)
        dv = dv_in + sv * qdd + ca.cross(w, sv * qd) + ca.cross(vv, sw * qd)
        world = (ca.mtimes(Rw, R), pw + ca.mtimes(Rw, p))
        bodies.append((world, (R, p), (w, vv, dw, dv), body_force(k, w, vv, dw, dv)))
    return bodies


def _tau(robot: Robot, q, v, a, friction: bool = True) -> ca.SX:
    """τ (nv) of the free-base RNEA: the base's wrench (force, moment; body axes), then the joints."""
    links, bodies = link_constants(robot), _forward(robot, q, v, a, gravity=True)
    forces = [list(b[3]) for b in bodies]
    tau = [None] * robot.n
    for i in range(robot.n - 1, -1, -1):
        k, (n_, f_) = links[i], forces[i + 1]
        tau[i] = ca.dot(n_, ca.DM(k["S"][:3])) + ca.dot(f_, ca.DM(k["S"][3:])) + k["armature"] * a[6 + i]
        if friction:
            tau[i] += joint_friction(k, v[6 + i])
        R, p = bodies[i + 1][1]
        parent, fp = forces[robot.parents[i] + 1], ca.mtimes(R, f_)
        parent[1] = parent[1] + fp
        parent[0] = parent[0] + ca.mtimes(R, n_) + ca.cross(p, fp)
    return ca.vertcat(forces[0][1], forces[0][0], *tau)


def _feet(robot: Robot, bodies: list) -> list:
    """Each task frame's (R, p) in the world, its velocity (linear, angular) and classical
    acceleration (linear, angular), world axes."""
    out = []
    for frame in robot.task_frames:
        (Rw, pw), _, (w, v, dw, dv), _ = bodies[frame.link + 1]
        T = np.array(frame.placement, dtype=float)
        r = ca.DM(T[:3, 3])
        velocity = v + ca.cross(w, r)
        acceleration = dv + ca.cross(dw, r) + ca.cross(w, velocity)
        placed = (ca.mtimes(Rw, ca.DM(T[:3, :3])), pw + ca.mtimes(Rw, r))
        out.append(
            (
                placed,
                ca.mtimes(Rw, ca.vertcat(velocity, w)[:3]),
                ca.mtimes(Rw, w),
                ca.mtimes(Rw, acceleration),
                ca.mtimes(Rw, dw),
            )
        )
    return out


def functions(robot: Robot, contacts: tuple = (), *, friction: bool = True) -> dict:
    """{name: casadi.Function} with the signatures of symdyn's generated ones: tau(q, v, a),
    frame_pose(q) (4m × 4), frame_jacobian_aligned(q) (6m × nv), frame_drift(q, v) (m × 6) for the
    robot's frames, and with `contacts` (frame names, point contacts) contact_impulse(q, v_before)
    → (v_after, impulse).

    Raises:
        NotImplementedError: a base that is not free.
    """
    if robot.base_joint != "free":
        raise NotImplementedError(
            f"the plain legged baseline needs a free base; robot {robot.name!r} has {robot.base_joint}"
        )
    nq, nv = robot.nq, robot.nv
    q, v, a = ca.SX.sym("q", nq), ca.SX.sym("v", nv), ca.SX.sym("a", nv)
    zero = ca.SX.zeros(nv)
    moving = _feet(robot, _forward(robot, q, v, zero, gravity=False))
    pose = ca.vertcat(*(ca.vertcat(ca.horzcat(R, p), ca.DM([[0, 0, 0, 1]])) for (R, p), *_ in moving))
    velocity = ca.vertcat(*(ca.vertcat(lin, ang) for _, lin, ang, _, _ in moving))
    J = ca.jacobian(velocity, v)
    drift = ca.vertcat(*(ca.horzcat(lin.T, ang.T) for *_, lin, ang in moving))
    tau = _tau(robot, q, v, a, friction)
    out = {
        "tau": ca.Function("tau", [q, v, a], [tau], ["q", "v", "a"], ["tau"]),
        "frame_pose": ca.Function("frame_pose", [q], [pose], ["q"], ["pose"]),
        "frame_jacobian_aligned": ca.Function("frame_jacobian_aligned", [q], [J], ["q"], ["J"]),
        "frame_drift": ca.Function("frame_drift", [q, v], [drift], ["q", "v"], ["drift"]),
    }
    if contacts:
        names = [f.name for f in robot.task_frames]
        Jc = ca.vertcat(*(J[6 * names.index(c) : 6 * names.index(c) + 3, :] for c in contacts))
        M = ca.jacobian(_tau(robot, q, zero, a, friction=False), a)
        X = ca.solve(M, Jc.T)
        impulse = -ca.solve(ca.mtimes(Jc, X), ca.mtimes(Jc, v))
        out["contact_impulse"] = ca.Function(
            "contact_impulse", [q, v], [v + ca.mtimes(X, impulse), impulse], ["q", "v_before"], ["v_after", "impulse"]
        )
    return out
