"""Whole-body inverse dynamics under contacts: the joint torques and contact forces that realise a
desired acceleration with the base unactuated — what a torque-controlled legged robot's
controller calls each step.

With τ_id = τ(q, v, a) the free inverse dynamics, J the contact rows (world-aligned, 3 per point,
6 per surface, as `contact_fdyn`'s) and nb the base's velocities (6 free, 3 planar, 0 fixed), the
equations of motion M a + b = Sᵀτ + Jᵀf hold with S's first nb columns zero exactly when

    J_bᵀ f = τ_id[:nb]         (the contacts alone carry the base),
    τ = τ_id − Jᵀ f            (τ[:nb] = 0).

The first has many solutions when the contacts give more rows than the base has freedoms (Solo
on four feet: 12 forces, 6 equations): the one taken minimises fᵀ W f, W = diag(weights)
(default: the identity, the least-norm forces; a larger weight loads that row less):
f = W⁻¹J_b (J_bᵀW⁻¹J_b)⁻¹ τ_id[:nb].  A set that cannot carry the base (one point on a free
base: 3 forces for 6 equations) is refused.  The desired a must respect the contacts
(J a + γ = 0: what a whole-body controller's task solve gives); then `contact_fdyn(q, v, τ)`
returns a and f again (`tests/test_contact_control.py`).  Friction cones and unilateral normals
are not imposed: that is the OCP's or a QP's work.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..model import Robot
from ..model.frames import CONTACT_KINDS

__all__ = ["WholeBodyInverseDynamics"]


class WholeBodyInverseDynamics:
    """`wbid(q, v, a)` → (τ (nv,), f (nc,)) for a robot with a contact set, on the generated τ and
    world-aligned frame Jacobians of the contact frames (`target`: "c" by default, or "numpy");
    `weights` (nc,): positive weights of fᵀWf (default ones).  Batches (N, ·) in, (N, ·) out."""

    def __init__(self, robot: Robot, target: str = "c", weights=None) -> None:
        from ..codegen.entry import load

        if not robot.contacts:
            raise ValueError(f"{robot.name} has no contact set: give one with robot.with_contacts({{frame: kind}})")
        self.robot = robot
        self.rows = [CONTACT_KINDS[kind] for _, kind in robot.contacts]
        nc = sum(self.rows)
        w = np.ones(nc) if weights is None else np.asarray(weights, dtype=float)
        if w.shape != (nc,) or not np.all(np.isfinite(w)) or np.any(w <= 0):
            raise ValueError(f"weights must be {nc} positive numbers (one per contact force row), got {w.shape}")
        self.weights = w
        self.nb = robot.nv - robot.n
        # τ and the contact frames' Jacobians only: the same robot without its contact functions
        plain = dataclasses.replace(robot, contacts=(), baumgarte=(0.0, 0.0)).with_frames(
            [name for name, _ in robot.contacts]
        )
        self.model = load(plain, target)

    def contact_rows(self, q) -> np.ndarray:
        """J (…, nc, nv): each contact's world-aligned rows (a point's linear three, a surface's six)."""
        J = self.model.frame_jacobian_aligned(q)
        return np.concatenate([J[..., k, :count, :] for k, count in enumerate(self.rows)], axis=-2)

    def __call__(self, q, v, a) -> tuple[np.ndarray, np.ndarray]:
        tau = np.asarray(self.model.tau(q, v, a), dtype=float)
        J = self.contact_rows(q)
        J, tau = np.broadcast_to(J, tau.shape[:-1] + J.shape[-2:]), tau
        nb = self.nb
        if nb == 0:  # a fixed base carries itself: no force is needed, the least-norm ones are zero
            return tau, np.zeros(tau.shape[:-1] + (J.shape[-2],))
        Jb = J[..., :nb]  # (…, nc, nb)
        Winv_Jb = Jb / self.weights[:, None]
        G = np.swapaxes(Jb, -1, -2) @ Winv_Jb  # (…, nb, nb)
        rank = np.linalg.matrix_rank(G, tol=1e-10 * max(1.0, float(np.abs(G).max())))
        if np.any(rank < nb):
            raise ValueError(
                f"the contact set of {self.robot.name} ({', '.join(f'{f} ({k})' for f, k in self.robot.contacts)}) "
                f"cannot carry its base: its forces span {int(np.min(rank))} of the base's {nb} equations"
            )
        force = (Winv_Jb @ np.linalg.solve(G, tau[..., :nb, None]))[..., 0]
        out = tau - (np.swapaxes(J, -1, -2) @ force[..., None])[..., 0]
        out[..., :nb] = 0.0
        return out, force
