"""The Puma on an air puck (the chapter's exercise 9): a 9-joint arm whose base
slides and spins freely on a frictionless horizontal table.

The base is two prismatic joints (world x, then y) and a revolute joint
(yaw about world z) ahead of the Puma's six, all in standard DH; they are
unactuated, so their torque is zero and the system's momentum in x, y and
its angular momentum about the world z-axis are conserved.  Moving the arm
moves the base; an arm motion planned on the zero-momentum constraint moves
the base from one pose to another and stops it.

Where it sits: a model built from `symdyn.model` and run through generated
code (`symdyn.numeric.backend.model(robot, "c")`, derived and compiled once into the
cache), with controllers for `symdyn.apps.control.simulate`.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from scipy.optimize import least_squares

from ..model import Link, Robot, arms
from ..model.robot import roty
from ..numeric import reference as ref
from ..numeric.backend import Model
from .control import quintic

__all__ = [
    "BASE_JOINTS",
    "puck_robot",
    "momentum",
    "centre_of_mass",
    "PassiveBase",
    "base_rate",
    "ShapeLoop",
    "plan",
    "timed",
]

BASE_JOINTS = 3


def puck_robot(mass: float = 20.0, radius: float = 0.25, *, planar: bool = False) -> Robot:
    """The Puma 560 (Coulomb friction removed, viscous kept) on a puck: a thin disc of `mass` (kg)
    and `radius` (m) under it, free in x, y and yaw.  Joints 1, 2 slide along world x and y
    (massless carriages: frame 0 is Ry(π/2), so z0 is world x), joint 3 turns about world z
    and carries the disc; frame 3 is the Puma's base frame (identity at q = 0).

    planar=True: the same system on a true planar base (`base_joint="planar"`, the disc its
    body): q = [x, y, yaw, arm…] as before, but the base's velocities v = [vx, vy, ω] are in
    the disc's frame (q̇ = [R(yaw)·(vx, vy), ω, …]), nq = nv = 9."""
    disc = mass * radius**2 / 4
    body = Link(m=mass, I=((disc, 0, 0), (0, disc, 0), (0, 0, 2 * disc)))
    puma = arms.load("puma560").nofriction()
    if planar:
        return Robot(
            "puma560_planar_puck",
            puma.links,
            gravity=puma.gravity,
            base_joint="planar",
            base_body=body,
            source=f"{puma.source}; planar base: {mass} kg disc of radius {radius} m on an air table",
        )
    base = (
        Link(joint="prismatic", alpha=-math.pi / 2),
        Link(joint="prismatic", theta=-math.pi / 2, alpha=math.pi / 2),
        body,
    )
    return Robot(
        "puma560_puck",
        base + puma.links,
        base=roty(math.pi / 2),
        gravity=puma.gravity,
        source=f"{puma.source}; base: {mass} kg disc of radius {radius} m on an air table",
    )


def momentum(M: np.ndarray, q, qd) -> np.ndarray:
    """[p_x, p_y, L_z] (..., 3): linear momentum (kg·m/s) along world x, y and angular momentum
    (kg·m²/s) about the world z-axis through the origin.  The generalised momenta M·q̇ of the
    base joints are p_x, p_y and L_z about the puck's moving axis; L_z(origin) = that + x·p_y − y·p_x."""
    q, qd = np.asarray(q, float), np.asarray(qd, float)
    p = np.einsum("...ij,...j->...i", np.asarray(M)[..., :BASE_JOINTS, :], qd)
    L = p[..., 2] + q[..., 0] * p[..., 1] - q[..., 1] * p[..., 0]
    return np.stack([p[..., 0], p[..., 1], L], axis=-1)


def centre_of_mass(robot: Robot, q) -> np.ndarray:
    """Centre of mass (..., 3) of the whole robot in the world (m), from each link's frame
    (`reference.fkine` of the chain up to it) and its COM r."""
    q = np.asarray(q, float)
    total, weighted = 0.0, 0.0
    for i, link in enumerate(robot.links):
        if float(link.m) == 0:
            continue
        sub = Robot("prefix", robot.links[: i + 1], base=robot.base, gravity=robot.gravity)
        T = ref.fkine(sub, q[..., : i + 1])
        weighted = weighted + float(link.m) * (T[..., :3, :3] @ np.array(link.r, float) + T[..., :3, 3])
        total += float(link.m)
    return weighted / total


class PassiveBase:
    """Computed torque on the arm with the base passive (collocated partial feedback
    linearisation): arm acceleration a = q̈*_a + Kv·ė + Kp·e, the base acceleration that
    zero base torque implies, q̈_b = −M_bb⁻¹(M_ba·a + h_b), and τ = [0; τ_a] from one
    inverse-dynamics call.  trajectory(t) → (q*, q̇*, q̈*) of the arm (6,).  Stateless."""

    def __init__(self, model: Model, trajectory: Callable, Kp: float = 100.0, Kv: float = 20.0):
        self.model, self.trajectory, self.Kp, self.Kv = model, trajectory, Kp, Kv

    def __call__(self, t, q, qd):
        b = BASE_JOINTS
        qs, qds, qdds = self.trajectory(t)
        a = qdds + self.Kv * (qds - qd[b:]) + self.Kp * (qs - q[b:])
        M = self.model.M(q)
        h = self.model.tau(q, qd, np.zeros_like(q))
        base = np.linalg.solve(M[:b, :b], -(h[:b] + M[:b, b:] @ a))
        tau = self.model.tau(q, qd, np.concatenate([base, a]))
        tau[:b] = 0.0
        return tau


def base_rate(model: Model, q, qd_arm) -> np.ndarray:
    """Base velocity (..., 3) from the arm's, at zero momentum: q̇_b = −M_bb⁻¹ M_ba q̇_a."""
    M = model.M(q)
    b = BASE_JOINTS
    return -np.linalg.solve(M[..., :b, :b], (M[..., :b, b:] @ np.asarray(qd_arm, float)[..., None]))[..., 0]


class ShapeLoop:
    """An arm path from pose `start` (6,) over s ∈ [0, 1]: the waist swings ±`swing` rad
    (sin 2πs) while the elbow bends by `bend`·(1 − cos 2πs)/2 — a loop in shape space that
    turns the base — plus end offsets δ of waist and shoulder reached along s."""

    def __init__(self, start, swing: float = 0.8):
        self.start, self.swing = np.asarray(start, float), swing

    def __call__(self, params, s) -> tuple[np.ndarray, np.ndarray]:
        """Arm angles and their s-derivatives (..., 6) at s, for params (bend, δ1, δ2)."""
        bend, *end = params
        s = np.asarray(s, float)[..., None]
        w = 2 * np.pi
        shape = np.zeros(6)
        shape[[0, 1]] = end
        loop = np.zeros((2, 6))
        loop[0, 0], loop[1, 2] = self.swing, bend
        q = self.start + shape * s + loop[0] * np.sin(w * s) + loop[1] * (1 - np.cos(w * s)) / 2
        dq = shape + loop[0] * w * np.cos(w * s) + loop[1] * w * np.sin(w * s) / 2
        return q, dq


def _base_along(model: Model, path: ShapeLoop, params, steps: int) -> np.ndarray:
    """Base pose (3,) after the arm runs `path` from a base at the origin, at zero momentum:
    RK4 in s of dq_b/ds = −M_bb⁻¹ M_ba dq_a/ds."""
    qb, h = np.zeros(BASE_JOINTS), 1.0 / steps

    def rate(s, qb):
        qa, dqa = path(params, s)
        return base_rate(model, np.concatenate([qb, qa]), dqa)

    for k in range(steps):
        s = k * h
        k1 = rate(s, qb)
        k2 = rate(s + h / 2, qb + h / 2 * k1)
        k3 = rate(s + h / 2, qb + h / 2 * k2)
        k4 = rate(s + h, qb + h * k3)
        qb = qb + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return qb


def plan(model: Model, start, goal, *, steps: int = 100, swing: float = 1.0):
    """Find a `ShapeLoop` from arm pose `start` that takes the base from the origin to `goal`
    = (x, y, yaw) (m, m, rad) and stops it: three equations in (bend, δ1, δ2), solved by
    least squares.  Returns (path, params, reached base pose)."""
    path = ShapeLoop(start, swing)
    goal = np.asarray(goal, float)
    residual = lambda x: _base_along(model, path, x, steps) - goal  # noqa: E731
    fit = least_squares(residual, np.array([0.5, 0.0, 0.0]), xtol=1e-12, ftol=1e-12)
    return path, fit.x, _base_along(model, path, fit.x, steps)


def timed(path: ShapeLoop, params, T: float) -> Callable:
    """The path in time, s = quintic(0 → 1 in T s): trajectory(t) → (q*, q̇*, q̈*) of the arm (6,),
    q̈* by a central difference (1e-5 s)."""

    def at(t):
        s, sd, _ = (x[0] for x in quintic(0.0, 1.0, T, t))
        q, dq = path(params, s)
        return q, dq * sd

    def trajectory(t):
        q, qd = at(t)
        h = 1e-5
        return q, qd, (at(t + h)[1] - at(t - h)[1]) / (2 * h)

    return trajectory
