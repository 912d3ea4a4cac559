"""Pinocchio's contact dynamics, the yardstick of the generated contact functions.

A robot's contact set becomes Pinocchio's rigid constraints (`RigidConstraintModel`, CONTACT_3D
for a point, CONTACT_6D for a surface, LOCAL_WORLD_ALIGNED) on a Pinocchio model of the robot:
symdyn's own (`task_space.peer_model`) or Pinocchio's reading of the URDF (`task_space.file_model`,
whose frames carry the file's names).  `contacts` and `derivatives` give, at one state in symdyn's
coordinates, `constraintDynamics`, `impulseDynamics` and their derivatives with an exact proximal
solve, the forces turned into the robot's world: Pinocchio's model starts at the robot's base
frame, so its world-aligned forces are in that frame's axes (`world_axes`).
"""

from __future__ import annotations

import numpy as np

from ..model import Robot
from .reduced import pin_configuration

__all__ = ["setup", "world_axes", "contacts", "derivatives"]


def setup(robot: Robot, model, ids) -> tuple:
    """(model, data, constraint models, their datas, proximal settings) for the robot's contact set on
    a Pinocchio `model` whose frames `ids` are the contact frames, in the set's order."""
    import pinocchio as pin

    data = model.createData()
    models, datas = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for k, (_, kind) in enumerate(robot.contacts):
        frame = model.frames[ids[k]]
        contact = pin.ContactType.CONTACT_3D if kind == "point" else pin.ContactType.CONTACT_6D
        cm = pin.RigidConstraintModel(
            contact, model, frame.parentJoint, frame.placement, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )
        models.append(cm)
        datas.append(cm.createData())
    pin.initConstraintDynamics(model, data, models, datas)
    return model, data, models, datas, pin.ProximalSettings(1e-14, 0.0, 1)


def world_axes(robot: Robot) -> np.ndarray:
    """The rotation that takes the contact forces from Pinocchio's world (the robot's base frame) to
    the robot's world: the base's rotation on each 3-row block (a point's force; a surface's force
    and moment)."""
    rows = sum(3 if kind == "point" else 6 for _, kind in robot.contacts)
    return np.kron(np.eye(rows // 3), np.array(robot.base, dtype=float)[:3, :3])


def contacts(robot: Robot, q, v, tau, peer: tuple) -> tuple:
    """Pinocchio's (a, λ, v⁺, Λ) at one state (`peer` from `setup`)."""
    import pinocchio as pin

    model, data, models, datas, prox = peer
    W = world_axes(robot)
    x = pin_configuration(model, np.atleast_2d(q))[0]
    a = pin.constraintDynamics(model, data, x, v, tau, models, datas, prox).copy()
    force = W @ data.lambda_c
    v_after = pin.impulseDynamics(model, data, x, v, models, datas, 0.0, prox).copy()
    return a, force, v_after, W @ data.impulse_c


def derivatives(robot: Robot, q, v, tau, peer: tuple) -> tuple[list, list]:
    """Pinocchio's computeConstraintDynamicsDerivatives and computeImpulseDynamicsDerivatives at one
    state, in the order of contact_fdyn_derivatives and contact_impulse_derivatives (Pinocchio's
    impulse ddq_dv is d(v⁺ − v⁻)/dv⁻: the identity added here), the forces' rows in the robot's
    world."""
    import pinocchio as pin

    model, data, models, datas, prox = peer
    W = world_axes(robot)
    x = pin_configuration(model, np.atleast_2d(q))[0]
    a = pin.constraintDynamics(model, data, x, v, tau, models, datas, prox).copy()
    pin.computeConstraintDynamicsDerivatives(model, data, models, datas)
    fdyn = [a, W @ data.lambda_c, data.ddq_dq.copy(), data.ddq_dv.copy(), data.ddq_dtau.copy()]
    fdyn += [W @ data.dlambda_dq, W @ data.dlambda_dv, W @ data.dlambda_dtau]
    v_after = pin.impulseDynamics(model, data, x, v, models, datas, 0.0, prox).copy()
    pin.computeImpulseDynamicsDerivatives(model, data, models, datas, 0.0, prox)
    dv = data.ddq_dv + np.eye(model.nv)
    impulse = [v_after, W @ data.impulse_c, data.ddq_dq.copy(), dv, W @ data.dlambda_dq, W @ data.dlambda_dv]
    return fdyn, impulse
