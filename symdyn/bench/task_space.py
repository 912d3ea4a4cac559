"""Pinocchio's task space, the yardstick of the generated frame and centroidal functions.

For any numeric `Robot`, `peer_model` builds Pinocchio's model (`peers.pinocchio_model`) and adds
a frame for each of the robot's task frames at the same placement; for a robot read from a
URDF, `file_model` gives Pinocchio's own reading of the file (`reduced.reduced_model`), whose
frames carry the file's link names: an independent reading of where each frame is.
`evaluate` returns, at states in symdyn's coordinates, what `getFrameJacobian`,
`getFrameClassicalAcceleration`, `jacobianCenterOfMass`, `computeCentroidalMap` and
`computeCentroidalMomentumTimeVariation` give, in symdyn's world (Pinocchio's world is
symdyn's frame {0}: `robot.base` is applied here).
"""

from __future__ import annotations

import numpy as np

from ..model import Robot
from .peers import pinocchio_model
from .reduced import link_frame, pin_configuration, reduced_model

__all__ = ["peer_model", "file_model", "evaluate", "FUNCTIONS"]

#: The task-space functions `evaluate` gives, by symdyn's names.
FUNCTIONS = (
    "frame_pose",
    "frame_jacobian",
    "frame_jacobian_aligned",
    "frame_velocity",
    "frame_acceleration",
    "frame_drift",
    "com",
    "com_jacobian",
    "com_drift",
    "centroidal_map",
    "centroidal_drift",
)


def peer_model(robot: Robot):
    """(Pinocchio model, frame ids) of `robot` with a frame added for each of its task frames."""
    import pinocchio as pin

    model = pinocchio_model(robot)
    ids = []
    for k, frame in enumerate(robot.task_frames):
        placement = pin.SE3(np.array(frame.placement, dtype=float))
        if frame.link < 0:
            joint, on = (1 if robot.base_joint else 0), pin.SE3.Identity()
        else:
            body = model.frames[model.getFrameId(f"L{frame.link + 1}")]
            joint, on = body.parentJoint, body.placement
        ids.append(model.addFrame(pin.Frame(f"task{k}", joint, 0, on * placement, pin.FrameType.OP_FRAME)))
    return model, ids


def file_model(robot: Robot, path):
    """(Pinocchio's reduced model of the URDF at `path`, the ids of the robot's task frames by
    their names in the file)."""
    model = reduced_model(path, robot)
    ids = []
    for frame in robot.task_frames:
        if not model.existFrame(frame.name):
            raise ValueError(f"Pinocchio's model of {path} has no frame {frame.name!r}")
        ids.append(link_frame(model, frame.name))
    return model, ids


def evaluate(robot: Robot, model, ids, q, v, a) -> dict:
    """Pinocchio's task-space quantities at states q (N, nq), v and a (N, nv) in symdyn's
    coordinates and world, by the names of `FUNCTIONS`."""
    import pinocchio as pin

    data = model.createData()
    x = pin_configuration(model, np.atleast_2d(q))
    B = np.array(robot.base, dtype=float)
    R6 = np.kron(np.eye(2), B[:3, :3])
    out: dict = {name: [] for name in FUNCTIONS}
    LWA, LOCAL = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED, pin.ReferenceFrame.LOCAL
    for xi, vi, ai in zip(x, np.atleast_2d(v), np.atleast_2d(a)):
        pin.forwardKinematics(model, data, xi, vi, ai)
        pin.computeJointJacobians(model, data, xi)
        pin.updateFramePlacements(model, data)
        out["frame_pose"].append([B @ data.oMf[f].homogeneous for f in ids])
        out["frame_jacobian"].append([pin.getFrameJacobian(model, data, f, LOCAL) for f in ids])
        out["frame_jacobian_aligned"].append([R6 @ pin.getFrameJacobian(model, data, f, LWA) for f in ids])
        out["frame_velocity"].append([pin.getFrameVelocity(model, data, f, LOCAL).vector for f in ids])
        out["frame_acceleration"].append(
            [R6 @ pin.getFrameClassicalAcceleration(model, data, f, LWA).vector for f in ids]
        )
        out["com"].append(B[:3, :3] @ pin.centerOfMass(model, data, xi) + B[:3, 3])
        out["com_jacobian"].append(B[:3, :3] @ pin.jacobianCenterOfMass(model, data, xi))
        out["centroidal_map"].append(R6 @ pin.computeCentroidalMap(model, data, xi))
        pin.computeCentroidalMomentumTimeVariation(model, data, xi, vi, np.zeros_like(vi))
        out["centroidal_drift"].append(R6 @ data.dhg.vector)
        pin.forwardKinematics(model, data, xi, vi, np.zeros_like(vi))
        pin.updateFramePlacements(model, data)
        out["frame_drift"].append([R6 @ pin.getFrameClassicalAcceleration(model, data, f, LWA).vector for f in ids])
        pin.centerOfMass(model, data, xi, vi, np.zeros_like(vi))
        out["com_drift"].append(B[:3, :3] @ data.acom[0])
    return {name: np.array(values) for name, values in out.items()}
