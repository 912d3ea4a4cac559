"""The same arm in the peers: Pinocchio (the independent peer the reference is
tested against), the Robotics Toolbox, and a plain CasADi RNEA in C (a baseline).

`pinocchio_model(robot)` builds a `pinocchio.Model` from a numeric robot
(standard or modified DH or general joints, revolute or prismatic, offsets,
rotor inertia G²·Jm as armature); the C++ peer benchmark is fed the same
model (`pin_peer.arm_joints`).
Pinocchio's universe is the robot's frame {0}: gravity is rotated into it,
so world poses are `robot.base · data.oMf[...]`.  Friction is not modelled
(Pinocchio's `rnea` has none): compare with `robot.nofriction(all=True)`.
`toolbox_robot` gives a standard-DH arm as a Toolbox `DHRobot` (base and tool
included); `casadi_rnea_c` writes CasADi's C code of the plain SX RNEA.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..model import Robot

__all__ = ["pinocchio_model", "toolbox_robot", "casadi_rnea_c"]


def _pin():
    try:
        import pinocchio
    except ImportError as exc:
        raise ImportError("symdyn.bench.peers needs Pinocchio: pip install symdyn[test] (or pip install pin)") from exc
    return pinocchio


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    if axis == "x":
        return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def _gravity0(robot: Robot) -> np.ndarray:
    """Gravity itself (downward acceleration) in frame {0}: −R_baseᵀ·robot.gravity."""
    Rb = np.array(robot.base, dtype=float)[:3, :3]
    return -Rb.T @ np.array(robot.gravity, dtype=float)


def _general_joint(pin, link):
    """Pinocchio's joint about (along) a link's axis: RX…PZ when it is +x, +y or
    +z, else the unaligned joint."""
    axis = np.array(link.axis, dtype=float)
    for k, name in enumerate("XYZ"):
        if np.array_equal(axis, np.eye(3)[k]):
            return getattr(pin, f"JointModel{'R' if link.is_revolute else 'P'}{name}")()
    return pin.JointModelRevoluteUnaligned(axis) if link.is_revolute else pin.JointModelPrismaticUnaligned(axis)


def pinocchio_model(robot: Robot):
    """A `pinocchio.Model` of the numeric `robot`, without friction.

    Joint i is a Pinocchio RZ (revolute) or PZ (prismatic) joint placed at
    DH frame {i−1} (standard) or at {i−1}·Rx(α)Tx(a) (modified); the body
    frame {i} is the joint frame moved by the constant part of Rz(θ)Tz(d)
    (and Tx(a)Rx(α) for standard DH).  A general joint is placed by its
    origin and moves about (along) its axis; its body frame is the joint's,
    turned (shifted) by the offset.  Frames "L1".."Ln" are the DH frames
    {i} and "tool" the tool point, all relative to frame {0}.  A tree: each
    joint hangs on its parent link's joint (`robot.parents`).  A floating base:
    a FreeFlyer (or Planar) root joint carrying `robot.base_body`, Pinocchio's
    world being symdyn's frame `robot.base` (a planar q is then [x, y, cos, sin]).
    """
    pin = _pin()
    robot.require_numeric("pinocchio_model")
    model = pin.Model()
    model.name = robot.name
    root, frame = 0, 0
    if robot.base_joint is not None:
        kind = pin.JointModelFreeFlyer() if robot.base_joint == "free" else pin.JointModelPlanar()
        root = model.addJoint(0, kind, pin.SE3.Identity(), "root_joint")
        if robot.base_body is not None:
            b = robot.base_body
            model.appendBodyToJoint(
                root,
                pin.Inertia(float(b.m), np.array(b.r, dtype=float), np.array(b.I, dtype=float)),
                pin.SE3.Identity(),
            )
    joints, bodies = [], []  # each link's Pinocchio joint and its body frame in that joint
    parent, prev = root, pin.SE3.Identity()  # the tool's, on the base body when there is no link
    for i, link in enumerate(robot.links, start=1):
        up = robot.parents[i - 1]
        parent, prev = (joints[up], bodies[up]) if up >= 0 else (root, pin.SE3.Identity())
        if robot.convention == "general":
            place = prev * pin.SE3(np.array(link.origin or np.eye(4), dtype=float))
            j = model.addJoint(parent, _general_joint(pin, link), place, f"j{i}")
            axis, zero = np.array(link.axis, dtype=float), np.zeros(3)
            # q + offset: the body is the joint frame moved by the offset
            twist = pin.Motion(zero, axis) if link.is_revolute else pin.Motion(axis, zero)
            body = pin.exp6(twist * float(link.offset))
            inertia = pin.Inertia(float(link.m), np.array(link.r, dtype=float), np.array(link.I, dtype=float))
            model.appendBodyToJoint(j, body.act(inertia), pin.SE3.Identity())
            frame = model.addBodyFrame(f"L{i}", j, body, frame)
            parent, prev = j, body
            joints.append(j)
            bodies.append(body)
            continue
        a, alpha, offset = float(link.a), float(link.alpha), float(link.offset)
        dh_x = pin.SE3(_rot("x", alpha), np.array([a, 0.0, 0.0]))  # Tx(a)Rx(α) = Rx(α)Tx(a)
        place = prev if robot.convention == "standard" else prev * dh_x
        joint = pin.JointModelRZ() if link.is_revolute else pin.JointModelPZ()
        j = model.addJoint(parent, joint, place, f"j{i}")
        if link.is_revolute:
            body = pin.SE3(_rot("z", offset), np.array([0.0, 0.0, float(link.d)]))
        else:
            body = pin.SE3(_rot("z", float(link.theta)), np.array([0.0, 0.0, offset]))
        if robot.convention == "standard":
            body = body * dh_x
        inertia = pin.Inertia(float(link.m), np.array(link.r, dtype=float), np.array(link.I, dtype=float))
        model.appendBodyToJoint(j, body.act(inertia), pin.SE3.Identity())
        frame = model.addBodyFrame(f"L{i}", j, body, frame)
        parent, prev = j, body
        joints.append(j)
        bodies.append(body)
    tool = pin.SE3(np.array(robot.tool, dtype=float))
    model.addFrame(pin.Frame("tool", parent, frame, prev * tool, pin.FrameType.OP_FRAME))
    rotors = [float(l.G) ** 2 * float(l.Jm) for l in robot.links]
    model.armature = np.array([0.0] * (robot.nv - robot.n) + rotors)
    model.gravity = pin.Motion(_gravity0(robot), np.zeros(3))
    return model


def casadi_rnea_c(robot, folder: Path) -> Path:
    """CasADi's C code of the plain SX RNEA (symdyn.numeric.casadi_rnea, no friction) as casadi_rnea.c/.h."""
    import casadi as ca

    from ..numeric.casadi_rnea import rnea_function

    f = rnea_function(robot.nofriction(all=True), friction=False)
    x = f.sx_in()
    g = ca.Function("casadi_rnea", x, f.call(x), f.name_in(), f.name_out())
    folder.mkdir(parents=True, exist_ok=True)
    cg = ca.CodeGenerator("casadi_rnea.c", {"with_header": True})
    cg.add(g)
    return Path(cg.generate(str(folder) + os.sep))


def toolbox_robot(robot):
    """The robot as a Robotics Toolbox DHRobot (standard DH, revolute), or None if not installed."""
    try:
        import roboticstoolbox as rtb
    except ImportError:
        return None
    links = [
        rtb.RevoluteDH(
            d=float(l.d),
            a=float(l.a),
            alpha=float(l.alpha),
            offset=float(l.offset),
            m=float(l.m),
            r=np.array(l.r, float),
            I=np.array(l.I, float),
            Jm=float(l.Jm),
            G=float(l.G),
            B=float(l.B),
            Tc=np.array(l.Tc, float),
        )
        for l in robot.links
    ]
    from spatialmath import SE3

    return rtb.DHRobot(
        links,
        name=robot.name,
        gravity=-np.array(robot.gravity, float),
        base=SE3(np.array(robot.base, float), check=False),
        tool=SE3(np.array(robot.tool, float), check=False),
    )
