"""A plain recursive Newton–Euler built directly in CasADi SX: the baseline.

No symbolic simplification: the recursion of `symdyn.reference` (Featherstone's
RNEA in body coordinates, rotor inertia G²·Jm, friction G²·B·q̇ + |G|·Tc) is
written once over CasADi SX, exactly as a user would write it by hand (on a
fixed-base tree each link moves with its parent and hands its force to it).  Only
CasADi's own constant folding (x·0 → 0, x·1 → x) applies.  The optimal-control
comparison (`symdyn.apps.studies.ocp`) sets symdyn's simplified functions against
these.
"""

from __future__ import annotations

from types import SimpleNamespace

import casadi as ca
import numpy as np

from ..model import Robot, exact_cos_sin
from .chain import rotation_z_to

__all__ = ["rnea_function", "mass_function", "fdyn_function", "functions"]


def _rx(alpha) -> np.ndarray:
    c, s = exact_cos_sin(alpha)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=float)


def _rz(c, s) -> ca.SX:
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def _constants(robot: Robot) -> list[dict]:
    """Per link: pre/post rotation and offset, joint axis S (ω; v) in body coordinates,
    mass, first moment m·r and inertia about the body origin, all as floats."""
    if robot.base_joint is not None:
        raise NotImplementedError(
            f"the plain CasADi RNEA reads robots on a fixed base (chains and trees); robot {robot.name!r} "
            f"has a {robot.base_joint} base joint (a free base: symdyn.numeric.casadi_legged)"
        )
    return link_constants(robot)


def link_constants(robot: Robot) -> list[dict]:
    """`_constants` for any base (the free base's own body is the caller's)."""
    robot.require_numeric("the plain CasADi RNEA")
    out = []
    for link in robot.links:
        Rx = _rx(link.alpha)
        ax = np.array([float(link.a), 0.0, 0.0])
        if robot.convention == "general":  # origin · Rot(axis): pre = origin·R_a, post = R_aᵀ
            T, Ra = np.array(link.origin or np.eye(4), dtype=float), rotation_z_to(np.array(link.axis, dtype=float))
            pre_R, pre_p, post_R, post_p = T[:3, :3] @ Ra, T[:3, 3], Ra.T, np.zeros(3)
        elif robot.convention == "standard":
            pre_R, pre_p, post_R, post_p = np.eye(3), np.zeros(3), Rx, ax
        else:
            pre_R, pre_p, post_R, post_p = Rx, ax, np.eye(3), np.zeros(3)
        z = np.array([0.0, 0.0, 1.0])
        if link.is_revolute:
            S = np.concatenate([post_R.T @ z, post_R.T @ np.cross(z, post_p)])
        else:
            S = np.concatenate([np.zeros(3), post_R.T @ z])
        m = float(link.m)
        r = np.array(link.r, dtype=float)
        Ic = np.array(link.I, dtype=float)
        out.append(
            dict(
                pre_R=pre_R,
                pre_p=pre_p,
                post_R=post_R,
                post_p=post_p,
                S=S,
                m=m,
                h=m * r,
                Io=Ic + m * (r @ r * np.eye(3) - np.outer(r, r)),
                armature=float(link.G) ** 2 * float(link.Jm),
                G=float(link.G),
                B=float(link.B),
                Tc=tuple(float(x) for x in link.Tc),
                revolute=link.is_revolute,
                theta=float(link.theta),
                d=float(link.d),
                offset=float(link.offset),
            )
        )
    return out


def body_force(k: dict, w, v, dw, dv) -> list:
    """[moment, force] a body with k's mass m, first moment h and inertia Io about its origin needs
    for the motion (ω, v) and its derivative (dω, dv), body coordinates (Newton–Euler)."""
    Io, h = ca.DM(k["Io"]), ca.DM(k["h"])
    L = ca.mtimes(Io, w) + ca.cross(h, v)
    P = k["m"] * v + ca.cross(w, h)
    return [
        ca.mtimes(Io, dw) + ca.cross(h, dv) + ca.cross(w, L) + ca.cross(v, P),
        k["m"] * dv + ca.cross(dw, h) + ca.cross(w, P),
    ]


def joint_friction(k: dict, qdi) -> ca.SX:
    """G²·B·q̇ + |G|·(Tc⁺ if q̇ > 0, Tc⁻ if q̇ < 0, 0 at rest); no Coulomb node when Tc = 0."""
    out = k["G"] ** 2 * k["B"] * qdi
    tp, tn = k["Tc"]
    if tp or tn:
        out += abs(k["G"]) * ca.if_else(qdi > 0, tp, ca.if_else(qdi < 0, tn, 0))
    return out


def transform(k: dict, qi) -> tuple[ca.SX, ca.SX]:
    """Rotation and origin of a body in its parent: pre · Rz(θ)Tz(d) · post."""
    theta = qi + k["offset"] if k["revolute"] else k["theta"]
    d = k["d"] if k["revolute"] else qi + k["offset"]
    Rj = _rz(ca.cos(theta), ca.sin(theta))
    R = ca.mtimes([ca.DM(k["pre_R"]), Rj, ca.DM(k["post_R"])])
    p = ca.DM(k["pre_p"]) + ca.mtimes(ca.DM(k["pre_R"]), ca.mtimes(Rj, ca.DM(k["post_p"])) + ca.vertcat(0, 0, d))
    return R, p


def _rnea(robot: Robot, q, qd, qdd, gravity: bool, friction: bool) -> ca.SX:
    """τ (n×1 SX) by the body-coordinate RNEA of `symdyn.numeric.chain._recursion`."""
    links = _constants(robot)
    base_R = np.array(robot.base, dtype=float)[:3, :3]
    g = np.array(robot.gravity, dtype=float) if gravity else np.zeros(3)
    at_rest = (ca.SX.zeros(3), ca.SX.zeros(3), ca.SX.zeros(3), ca.SX(ca.DM(base_R.T @ g)))
    parents = robot.parents  # a tree's link moves with its parent and hands its force to it
    frames, forces, motions = [], [], []
    for i, k in enumerate(links):
        w, v, dw, dv = at_rest if parents[i] < 0 else motions[parents[i]]
        R, p = transform(k, q[i])
        Rt = R.T
        sw, sv = ca.DM(k["S"][:3]), ca.DM(k["S"][3:])
        w_new, v_new = ca.mtimes(Rt, w), ca.mtimes(Rt, v + ca.cross(w, p))
        dw_new, dv_new = ca.mtimes(Rt, dw), ca.mtimes(Rt, dv + ca.cross(dw, p))
        w, v = w_new + sw * qd[i], v_new + sv * qd[i]
        dw = dw_new + sw * qdd[i] + ca.cross(w, sw * qd[i])
        dv = dv_new + sv * qdd[i] + ca.cross(w, sv * qd[i]) + ca.cross(v, sw * qd[i])
        forces.append(body_force(k, w, v, dw, dv))
        frames.append((R, p))
        motions.append((w, v, dw, dv))
    tau = [None] * robot.n
    for i in range(robot.n - 1, -1, -1):
        k = links[i]
        n_, f_ = forces[i]
        tau[i] = ca.dot(n_, ca.DM(k["S"][:3])) + ca.dot(f_, ca.DM(k["S"][3:])) + k["armature"] * qdd[i]
        if friction:
            tau[i] += joint_friction(k, qd[i])
        if parents[i] >= 0:
            R, p = frames[i]
            fp = ca.mtimes(R, f_)
            forces[parents[i]][1] = forces[parents[i]][1] + fp
            forces[parents[i]][0] = forces[parents[i]][0] + ca.mtimes(R, n_) + ca.cross(p, fp)
    return ca.vertcat(*tau)


def _symbols(n: int, *names: str) -> list[ca.SX]:
    return [ca.SX.sym(name, n) for name in names]


def rnea_function(robot: Robot, *, friction: bool = True) -> ca.Function:
    """`tau(q, qd, qdd) -> tau` (SX, n-vectors, N·m or N): τ = M q̈ + C q̇ + F + G.

    friction=True adds the robot's friction G²·B·q̇ + |G|·Tc(sgn q̇) (use
    `robot.nofriction()` to drop the non-smooth Coulomb part for optimisation).
    """
    q, qd, qdd = _symbols(robot.n, "q", "qd", "qdd")
    tau = _rnea(robot, q, qd, qdd, gravity=True, friction=friction)
    return ca.Function("tau", [q, qd, qdd], [tau], ["q", "qd", "qdd"], ["tau"])


def _mass(robot: Robot, q: ca.SX) -> ca.SX:
    """M(q) (n×n SX), column j from the RNEA with q̈ = e_j, q̇ = 0, no gravity or friction."""
    zero = ca.SX.zeros(robot.n)
    cols = [
        _rnea(robot, q, zero, ca.SX(ca.DM(np.eye(robot.n)[j])), gravity=False, friction=False) for j in range(robot.n)
    ]
    return ca.horzcat(*cols)


def mass_function(robot: Robot) -> ca.Function:
    """`M(q) -> M` (SX, n×n joint-space inertia, rotor inertia G²·Jm included)."""
    (q,) = _symbols(robot.n, "q")
    return ca.Function("M", [q], [_mass(robot, q)], ["q"], ["M"])


def fdyn_function(robot: Robot, *, friction: bool = True) -> ca.Function:
    """`fdyn(q, qd, tau) -> qdd` (SX): q̈ = M⁻¹(τ − τ(q, q̇, 0)) with `casadi.solve`."""
    q, qd, tau = _symbols(robot.n, "q", "qd", "tau")
    bias = _rnea(robot, q, qd, ca.SX.zeros(robot.n), gravity=True, friction=friction)
    qdd = ca.solve(_mass(robot, q), tau - bias)
    return ca.Function("fdyn", [q, qd, tau], [qdd], ["q", "qd", "tau"], ["qdd"])


def functions(robot: Robot, *, friction: bool = True) -> SimpleNamespace:
    """The plain baseline as an object like `symdyn.load(robot, target="casadi")`:
    attributes tau(q, qd, qdd), M(q), G(q), Cqd(q, qd), F(qd), fdyn(q, qd, tau)."""
    n = robot.n
    q, qd = _symbols(n, "q", "qd")
    zero = ca.SX.zeros(n)
    G = _rnea(robot, q, zero, zero, gravity=True, friction=False)
    Cqd = _rnea(robot, q, qd, zero, gravity=False, friction=False)
    F = ca.vertcat(*(joint_friction(k, qd[i]) if friction else ca.SX(0) for i, k in enumerate(_constants(robot))))
    return SimpleNamespace(
        tau=rnea_function(robot, friction=friction),
        M=mass_function(robot),
        G=ca.Function("G", [q], [G], ["q"], ["G"]),
        Cqd=ca.Function("Cqd", [q, qd], [Cqd], ["q", "qd"], ["Cqd"]),
        F=ca.Function("F", [qd], [F], ["qd"], ["F"]),
        fdyn=fdyn_function(robot, friction=friction),
    )
