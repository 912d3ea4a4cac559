"""Pinocchio's reduced model of a URDF robot: the yardstick for locked branches.

`from_urdf` locks every joint off the chain and merges the bodies it carries;
Pinocchio reads the whole file (`buildModelFromUrdf`, mimic joints as plain
joints) and `buildReducedModel` locks the same joints at the same values
(`robot.urdf.locked`), independently.  `compare` evaluates both on random
states within the limits: symdyn's reference (τ, M, G, C·q̇, Christoffel
symbols, forward dynamics, tool pose) and, given generated functions, their
derivatives — each as a relative error.  Excluded subtrees are cut from the
file Pinocchio reads and, where symdyn snapped numbers, Pinocchio reads them
snapped by the same rule; the base must be the file's root (Pinocchio's world).
"""

from __future__ import annotations

import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..model import Robot
from ..model.snapping import snap_angle, snap_axis
from ..numeric import reference as ref
from .differential import friction_law, pinocchio_at, pinocchio_derivatives, relative_error, states

__all__ = ["reduced_model", "pin_configuration", "compare", "compare_whole"]


def _without(path: Path, links: tuple, folder: Path) -> Path:
    """The URDF at `path` with the subtrees of `links` cut out, written into `folder`."""
    tree = ET.parse(path)
    root = tree.getroot()
    joints = root.findall("joint")
    below = {j.find("parent").get("link"): [] for j in joints}
    for j in joints:
        below[j.find("parent").get("link")].append(j.find("child").get("link"))
    gone, todo = set(), list(links)
    while todo:
        name = todo.pop()
        gone.add(name)
        todo += below.get(name, [])
    for element in list(root):
        if (element.tag == "link" and element.get("name") in gone) or (
            element.tag == "joint" and element.find("child").get("link") in gone
        ):
            root.remove(element)
    out = folder / Path(path).name
    tree.write(out)
    return out


def _snapped(path: Path, folder: Path) -> Path:
    """The URDF at `path` with every origin rpy and joint axis snapped by symdyn's rule, so that
    Pinocchio reads the model symdyn builds (its numbers differ from the file's by ≤ 1e-9: in forward
    dynamics enough to hide a real disagreement of 1e-10 or to fake one)."""
    tree = ET.parse(path)
    for element in tree.getroot().iter():
        if element.tag == "origin" and element.get("rpy"):
            rpy = [float(x) for x in element.get("rpy").split()]
            element.set("rpy", " ".join(repr(s.value if (s := snap_angle(a)) else a) for a in rpy))
        elif element.tag == "axis" and element.get("xyz"):
            axis = np.array([float(x) for x in element.get("xyz").split()])
            unit = axis / np.linalg.norm(axis) if np.linalg.norm(axis) else axis
            snapped = snap_axis(unit)
            if snapped:
                element.set("xyz", " ".join(str(x) for x in snapped.value))
    out = folder / f"snapped_{Path(path).name}"
    tree.write(out)
    return out


def _balanced(path: Path, links: set, folder: Path) -> Path:
    """The URDF at `path` with the inertias of `links` made physical as `inertia="balance"` makes
    them (`bodies.balanced`), so that Pinocchio reads the bodies symdyn repaired."""
    from ..model.urdf.bodies import balanced

    names = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    index = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
    tree = ET.parse(path)
    for link in tree.getroot().iter("link"):
        tensor = link.find("inertial/inertia")
        if link.get("name") in links and tensor is not None:
            values = {k: float(tensor.get(k, 0)) for k in names}
            I = [[values[names[index.index((min(i, j), max(i, j)))]] for j in range(3)] for i in range(3)]
            J = balanced(I)[0]
            for k, (i, j) in zip(names, index):
                tensor.set(k, repr(float(J[i][j])))
    out = folder / f"balanced_{Path(path).name}"
    tree.write(out)
    return out


def reduced_model(path, robot: Robot):
    """Pinocchio's model of the URDF at `path` with every joint that `robot` does not move
    locked where `robot.urdf` says (joints it does not record at their neutral value); a
    robot on a free or planar base gets Pinocchio's FreeFlyer or Planar root joint."""
    import pinocchio as pin

    record = robot.urdf
    if record is None:
        raise ValueError(f"robot {robot.name!r} was not read from a URDF: it has no record of what was locked")
    roots = {None: (), "free": (pin.JointModelFreeFlyer(),), "planar": (pin.JointModelPlanar(),)}
    with tempfile.TemporaryDirectory() as folder:
        file = _without(Path(path), record.excluded, Path(folder)) if record.excluded else Path(path)
        file = _snapped(file, Path(folder)) if record.snaps else file
        repaired = {r.link for r in getattr(record, "repairs", ())}
        file = _balanced(file, repaired, Path(folder)) if repaired else file
        full = pin.buildModelFromUrdf(str(file), *roots[robot.base_joint])
    first = 1 if robot.base_joint is None else 2  # Pinocchio's first joint that is one of the file's
    if full.frames[link_frame(full, record.base_link)].parentJoint != first - 1:
        raise ValueError(f"base_link {record.base_link!r} is not fixed to Pinocchio's world")
    q0 = pin.neutral(full)
    values = {lock.joint: lock.value for lock in record.locked}
    lock = []
    for jid in range(first, full.njoints):
        name, joint = full.names[jid], full.joints[jid]
        if name in record.joints:
            continue
        lock.append(jid)
        value = values.get(name, 0.0)
        if joint.nq == 2:
            q0[joint.idx_q : joint.idx_q + 2] = np.cos(value), np.sin(value)
        elif joint.nq == 1:
            q0[joint.idx_q] = value
    reduced = pin.buildReducedModel(full, lock, q0) if lock else full
    names = [reduced.names[j] for j in range(first, reduced.njoints)]
    if names != list(record.joints):
        raise AssertionError(f"Pinocchio's reduced model moves {names}, symdyn {list(record.joints)}")
    return reduced


def link_frame(model, name: str) -> int:
    """The id of the frame of the URDF link `name` in Pinocchio's `model`: its BODY frame, where a
    joint or another frame has the same name too (the Unitree Z1's `gripperStator` is a link and a
    joint, and `getFrameId` alone refuses the name)."""
    import pinocchio as pin

    if model.existFrame(name, pin.FrameType.BODY):
        return model.getFrameId(name, pin.FrameType.BODY)
    if not model.existFrame(name):
        raise ValueError(f"Pinocchio's model has no frame {name!r}")
    return model.getFrameId(name)


def pin_configuration(model, q: np.ndarray) -> np.ndarray:
    """Pinocchio's configurations (count, nq) of symdyn's q (count, nq): (cos, sin) for continuous
    joints and for a planar base's yaw, a free base's seven coordinates as they are."""
    columns, k = [], 0
    for joint in model.joints[1:]:
        kind = joint.shortname()
        if kind == "JointModelFreeFlyer":
            columns += [q[:, k + i] for i in range(7)]
            k += 7
        elif kind == "JointModelPlanar":
            columns += [q[:, k], q[:, k + 1], np.cos(q[:, k + 2]), np.sin(q[:, k + 2])]
            k += 3
        else:
            columns += [np.cos(q[:, k]), np.sin(q[:, k])] if joint.nq == 2 else [q[:, k]]
            k += 1
    return np.stack(columns, axis=1)


def compare_whole(robot: Robot, path, *, count: int = 200, seed: int = 0, functions=None) -> dict:
    """Relative errors of symdyn's reference against Pinocchio's reduced model of a tree, on a
    fixed or floating base, at `count` states: τ, M, G, C·v and forward dynamics (no
    Christoffel symbols: n² Coriolis matrices of a 100-joint robot take minutes); with
    `functions` (the robot's loaded generated model) its τ, M, C (computeCoriolisMatrix's), G,
    C·v, q̈, M⁻¹ and ∂τ/∂(q, v) in the tangent space too, its own friction F(v) taken off
    (Pinocchio has none)."""

    model = reduced_model(path, robot)
    bare = robot.nofriction(all=True)
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    q = robot.neutral() + np.zeros((count, 1))
    q[:, robot.nq - robot.n :] = rng.uniform(lo, hi, (count, robot.n))
    if robot.base_joint is not None:  # a random base pose: move the neutral base along a random twist
        twist = np.zeros((count, robot.nv))
        twist[:, : robot.nv - robot.n] = rng.normal(size=(count, robot.nv - robot.n)) * 2
        q = robot.integrate(q, twist)
    v, a, tau = (rng.uniform(-s, s, (count, robot.nv)) for s in (2, 5, 20))
    peer = pinocchio_at(model, pin_configuration(model, q), v, a, tau, christoffel=False)
    scale = max(np.abs(peer["M"]).max(), np.abs(peer["tau"]).max(), 1e-6)
    zero = np.zeros_like(v)
    errors = {
        "tau": relative_error(ref.rne(bare, q, v, a), peer["tau"], scale),
        "M": relative_error(ref.inertia(bare, q), peer["M"], scale),
        "G": relative_error(ref.gravload(bare, q), peer["G"], scale),
        "C v": relative_error(ref.rne(bare, q, v, zero, gravity=(0, 0, 0)), peer["Cqd"], scale),
        "fdyn": relative_error(ref.accel(bare, q, v, tau), peer["ddq"]),
    }
    if functions is not None:
        errors.update(_generated_whole(functions, robot, model, q, v, a, tau, peer, scale))
    return errors


def _generated_whole(functions, robot: Robot, model, q, v, a, tau, peer: dict, scale: float) -> dict:
    """The generated model's errors against Pinocchio (`compare_whole`): its friction F(v),
    checked against the reference's, is taken off τ and added to the τ fdyn is given.  State
    by state: the scalar code, no SIMD kernel to compile."""
    import pinocchio as pin

    def each(function, *args):
        return np.array([functions.functions[function](*state) for state in zip(*args)])

    F = each("F", v)
    B = np.zeros(robot.nv)  # ∂F/∂v: G²·B on the joints (Coulomb's derivative taken as 0)
    B[robot.nv - robot.n :] = [float(link.G) ** 2 * float(link.B) for link in robot.links]
    data, x = model.createData(), pin_configuration(model, q)
    dq, dv = [], []
    for xi, vi, ai in zip(x, v, a):
        pin.computeRNEADerivatives(model, data, xi, vi, ai)
        dq.append(data.dtau_dq.copy())
        dv.append(data.dtau_dv.copy())
    derivatives = [functions.functions["tau_derivatives"](*state) for state in zip(q, v, a)]
    gq, gv = (np.array([d[k] for d in derivatives]) for k in (1, 2))
    minv = np.linalg.inv(peer["M"])
    C = np.array([pin.computeCoriolisMatrix(model, data, xi, vi).copy() for xi, vi in zip(x, v)])
    return {
        "generated F": relative_error(F, ref.friction(robot, v), scale),
        "generated tau": relative_error(each("tau", q, v, a) - F, peer["tau"], scale),
        "generated M": relative_error(each("M", q), peer["M"], scale),
        "generated G": relative_error(each("G", q), peer["G"], scale),
        "generated C": relative_error(each("C", q, v), C, scale),
        "generated C v": relative_error(each("Cqd", q, v), peer["Cqd"], scale),
        "generated fdyn": relative_error(each("fdyn", q, v, tau + F), peer["ddq"]),
        "generated Minv": relative_error(each("Minv", q), minv, max(1.0, np.abs(minv).max())),
        "generated dtau/dq": relative_error(gq, np.array(dq), scale),
        "generated dtau/dv": relative_error(gv - np.diag(B), np.array(dv), scale),
    }


def compare(robot: Robot, path, *, count: int = 200, seed: int = 0, functions=None) -> dict:
    """Relative errors of symdyn against Pinocchio's reduced model at `count` states:
    the reference's τ, M, G, C·q̇, Christoffel symbols, forward dynamics and tool pose,
    and with `functions` (a loaded generated model) its τ, M, fdyn and derivatives."""
    import pinocchio as pin

    model = reduced_model(path, robot)
    q, qd, qdd, tau = states(robot, count, seed)
    x = pin_configuration(model, q)
    peer = pinocchio_at(model, x, qd, qdd, tau)
    bare = robot.nofriction(all=True)
    scale = max(np.abs(peer["M"]).max(), np.abs(peer["tau"]).max(), 1e-6)
    errors = {
        "tau": relative_error(ref.rne(robot, q, qd, qdd), peer["tau"] + friction_law(robot, qd), scale),
        "M": relative_error(ref.inertia(robot, q), peer["M"], scale),
        "G": relative_error(ref.gravload(robot, q), peer["G"], scale),
        "C qd": relative_error(np.einsum("skj,sj->sk", ref.coriolis(robot, q, qd), qd), peer["Cqd"], scale),
        "Christoffel": relative_error(ref.christoffel(robot, q), peer["Gamma"], scale),
        "fdyn": relative_error(ref.accel(bare, q, qd, tau), peer["ddq"]),
    }
    data, frame = model.createData(), link_frame(model, robot.urdf.tip_link)
    poses = []
    for xi in x:
        pin.framesForwardKinematics(model, data, xi)
        poses.append(data.oMf[frame].homogeneous.copy())
    errors["tool pose"] = relative_error(ref.fkine(robot, q), np.array(poses), 1.0)
    if functions is not None:
        d = pinocchio_derivatives(model, robot, x, qd, qdd, tau)
        t, dq, dqd = functions.tau_derivatives(q, qd, qdd)
        errors["generated tau"] = relative_error(t, peer["tau"] + friction_law(robot, qd), scale)
        errors["generated M"] = relative_error(functions.M(q), peer["M"], scale)
        errors["generated dtau/dq"] = relative_error(dq, d["dtau_dq"], scale)
        errors["generated dtau/dqd"] = relative_error(dqd, d["dtau_dqd"], scale)
        a, aq, aqd, Minv = functions.fdyn_derivatives(q, qd, tau)
        errors["generated fdyn"] = relative_error(a, d["qdd"])
        errors["generated dqdd/dq"] = relative_error(aq, d["dqdd_dq"], max(1.0, np.abs(d["dqdd_dq"]).max()))
        errors["generated dqdd/dqd"] = relative_error(aqd, d["dqdd_dqd"], max(1.0, np.abs(d["dqdd_dqd"]).max()))
        errors["generated Minv"] = relative_error(Minv, d["Minv"], max(1.0, np.abs(d["Minv"]).max()))
    return errors
