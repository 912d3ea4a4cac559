"""What symdyn reads of MuJoCo's compiled model (`Compiled`): names, the body tree, each body's
placement, each joint's axis, anchor and motion, inertials (snapped and merged exactly, as URDF
branches are), actuator efforts, where locked joints are held, and the physics symdyn does not
model (`unmodelled`, warned by `from_mjcf`).
"""

from __future__ import annotations

import math
from typing import Iterable

import numpy as np
import sympy as sp

from ..placement import compose, exact, joint_motion, link_number, rational_rotation, rpy_rotation
from ..robot import IDENTITY, Link
from ..rotations import quaternion_matrix
from ..snapping import ANGLE_TOLERANCE, snap_angle, snap_axis
from ..urdf.bodies import Body
from ..urdf.record import Locked, Snap
from .compile import MJCFError, describe_equality

__all__ = ["Compiled", "KIND", "translation", "effort_of", "lock_values", "unmodelled"]

#: MJCF joint types symdyn moves, and the kind of link each becomes.
KIND = {"hinge": "revolute", "slide": "prismatic"}


def translation(p) -> tuple:
    return tuple(tuple(int(i == j) for j in range(3)) + (exact(p[i]),) for i in range(3)) + ((0, 0, 0, 1),)


class Compiled:
    """One reading of one compiled model: names, the snapping rule, locks, what was noted."""

    def __init__(self, mujoco, compiled, snap: bool):
        self.mj, self.m, self.spec = mujoco, compiled.model, compiled.spec
        self.file, self.snap = compiled.file, snap
        self.snaps: list[Snap] = []
        self.locked: list[Locked] = []
        self.left_out: list[str] = []
        self.values: dict[int, tuple[float, str]] = {}
        self.frames: dict[int, tuple[int, tuple]] = {}  # body → (the robot link it rides on, its frame there)
        self.vanished = compiled.vanished  # equality constraints gone with the excluded bodies
        m = self.m
        self.children: dict[int, list[int]] = {}
        for b in range(1, m.nbody):
            self.children.setdefault(int(m.body_parentid[b]), []).append(b)

    # ---- names and places
    def body(self, b: int) -> str:
        return self.m.body(b).name or f"#{b}"

    def joint(self, j: int) -> str:
        return self.m.joint(j).name or f"#{j} (unnamed, in body {self.body(int(self.m.jnt_bodyid[j]))!r})"

    def where(self, kind: str, name: str) -> str:
        element = getattr(self.spec, kind)(name) if name and not name.startswith("#") else None
        info = element.info if element is not None else ""
        return f"{self.file} ({info})" if info else self.file

    def joint_type(self, j: int) -> str:
        return {0: "free", 1: "ball", 2: "slide", 3: "hinge"}[int(self.m.jnt_type[j])]

    def joints_of(self, b: int) -> range:
        start = int(self.m.body_jntadr[b])
        return range(start, start + int(self.m.body_jntnum[b])) if start >= 0 else range(0)

    def below(self, b: int) -> set[int]:
        out, todo = set(), [b]
        while todo:
            x = todo.pop()
            out.add(x)
            todo += self.children.get(x, [])
        return out

    # ---- numbers, snapped by the one rule
    def orientation(self, quat, what: str) -> list:
        """The exact rotation of a compiled unit quaternion: a signed permutation when every entry
        is within the snapping tolerance of 0 or ±1; else roll, pitch, yaw (URDF's order), each
        snapped by the rule; else (snap=False, or a pitch of ±π/2) the nearest rational rotation."""
        R = quaternion_matrix(quat, order="wxyz")
        near = np.round(R)
        change = float(np.abs(R - near).max())
        if change <= ANGLE_TOLERANCE and abs(np.linalg.det(near) - 1) < 0.5 and (self.snap or change == 0):
            if change > 0:
                quat_text = " ".join(repr(float(x)) for x in quat)
                self.snaps.append(Snap(f"{what} rotation (quat)", quat_text, "quarter turns", change))
            return [[sp.Integer(int(x)) for x in row] for row in near]
        if not self.snap:
            return rational_rotation(R)
        pitch = math.asin(max(-1.0, min(1.0, -R[2, 0])))
        roll, yaw = math.atan2(R[2, 1], R[2, 2]), math.atan2(R[1, 0], R[0, 0])
        angles, snaps = [], []
        for label, value in zip(("roll", "pitch", "yaw"), (roll, pitch, yaw)):
            snapped = snap_angle(value)
            if snapped is not None:
                snaps.append(Snap(f"{what} {label} (as rpy)", repr(value), snapped.label, snapped.change))
                value = snapped.value
            angles.append(value)
        E = rpy_rotation(angles)
        if float(np.abs(np.array(E, dtype=float) - R).max()) > 2 * ANGLE_TOLERANCE:  # gimbal lock: rpy is ill-posed
            return rational_rotation(R)
        self.snaps += snaps
        return E

    def placement(self, b: int) -> tuple:
        """The exact 4×4 transform of body b in its parent's frame (pos, quat as compiled)."""
        R = self.orientation(self.m.body_quat[b], f"body {self.body(b)!r}")
        p = [exact(float(x)) for x in self.m.body_pos[b]]
        return tuple(tuple(R[i]) + (p[i],) for i in range(3)) + ((0, 0, 0, 1),)

    def axis(self, j: int) -> tuple:
        axis = tuple(float(a) for a in self.m.jnt_axis[j])
        snapped = snap_axis(axis) if self.snap else None
        if snapped is None:
            return axis
        self.snaps.append(
            Snap(f"joint {self.joint(j)!r} axis", " ".join(map(repr, axis)), snapped.label, snapped.change)
        )
        return snapped.value

    def motion(self, j: int, value: float) -> tuple:
        """Body frame before joint j → after it, the joint at `value` (moved by value − qpos0)."""
        kind = KIND[self.joint_type(j)]
        moved = joint_motion(kind, self.axis(j), value - float(self.m.qpos0[self.m.jnt_qposadr[j]]))
        if kind == "prismatic" or moved is IDENTITY:
            return moved
        p = self.m.jnt_pos[j]
        return compose(compose(translation(p), moved), translation(-p))

    # ---- bodies
    def inertial(self, b: int) -> Body:
        """Body b's own mass, COM and inertia about the COM in its frame, as MuJoCo compiled them."""
        m = self.m
        R = quaternion_matrix(m.body_iquat[b], order="wxyz")
        I = R @ np.diag(m.body_inertia[b]) @ R.T
        upper = {(i, j): exact(float(I[i, j])) for i in range(3) for j in range(i, 3)}
        return Body(
            exact(float(m.body_mass[b])),
            tuple(exact(float(x)) for x in m.body_ipos[b]),
            tuple(tuple(upper[min(i, j), max(i, j)] for j in range(3)) for i in range(3)),
        )

    def left_out_free(self, b: int, into: str, moves: bool, rides: str, way: str = "") -> bool:
        """Whether body b hangs by a ball or free joint, and is then left out with its subtree
        (recorded); refused where it rides on a body that moves.

        Raises:
            MJCFError: a ball or free joint riding on a moving body (`rides` `into`), naming `way` out.
        """
        free = [j for j in self.joints_of(b) if self.joint_type(j) in ("ball", "free")]
        if not free:
            return False
        what = f"{self.joint_type(free[0])} joint {self.joint(free[0])!r} on body {self.body(b)!r}"
        if moves:
            raise MJCFError(
                f"{self.where('joint', self.m.joint(free[0]).name)}: {what} is not supported yet (it rides on "
                f"{rides} {into!r}): exclude= the body ({self.body(b)!r}){way}"
            )
        self.left_out.append(f"{self.body(b)!r} and its subtree ({what})")
        return True

    def subtree(self, b: int, skip: set, into: str, moves: bool, seg: int = -1, at: tuple = IDENTITY) -> Body:
        """Body b with everything hanging off it except the bodies in `skip` (the chain), in b's
        frame; joints met are locked and recorded as merged into `into`, and each body's frame as
        riding on robot link `seg` (-1: the base) at `at` (b's frame in it)."""
        self.frames[b] = (seg, at)
        body = self.inertial(b)
        for child in self.children.get(b, []):
            if child in skip:
                continue
            T = self.placement(child)
            if self.left_out_free(child, into, moves, "the chain, on body", " or end the chain before it"):
                continue
            for j in self.joints_of(child):
                value, why = self.values[j]
                self.locked.append(Locked(self.joint(j), value, into, why, moves))
                T = compose(T, self.motion(j, value))
            body = body + self.subtree(child, skip, into, moves, seg, compose(at, T)).moved(T)
        return body

    # ---- the chain's links
    def link(self, j: int, origin: tuple, body: Body, effort: float | None) -> Link:
        m = self.m
        dof = int(m.jnt_dofadr[j])
        friction = float(m.dof_frictionloss[dof])
        qlim = tuple(float(x) for x in m.jnt_range[j]) if m.jnt_limited[j] else None
        try:
            return Link(
                joint=KIND[self.joint_type(j)],
                origin=tuple(tuple(link_number(x) for x in row) for row in origin),
                axis=self.axis(j),
                offset=-float(m.qpos0[m.jnt_qposadr[j]]) + 0.0,
                qlim=qlim,
                m=link_number(body.m),
                r=tuple(link_number(x) for x in body.r),
                I=tuple(tuple(link_number(x) for x in row) for row in body.I),
                Jm=float(m.dof_armature[dof]),
                B=float(m.dof_damping[dof]),
                Tc=(friction, -friction + 0.0),
                effort_limit=effort,
            )
        except ValueError as exc:
            raise MJCFError(f"{self.where('joint', m.joint(j).name)}: joint {self.joint(j)!r}: {exc}") from None


def effort_of(reader: Compiled, j: int) -> tuple[float | None, list[str]]:
    """The effort limit of joint j from the actuators that drive it (|gear| × force range, or
    |gear| × |gain| × control range for a plain motor, summed) and its actuatorfrcrange."""
    mj, m = reader.mj, reader.m
    total, notes, unbounded = 0.0, [], []
    for a in range(m.nu):
        if int(m.actuator_trntype[a]) not in (mj.mjtTrn.mjTRN_JOINT, mj.mjtTrn.mjTRN_JOINTINPARENT):
            continue
        if int(m.actuator_trnid[a, 0]) != j:
            continue
        name, gear = m.actuator(a).name or f"#{a}", float(m.actuator_gear[a, 0])
        plain = (
            int(m.actuator_gaintype[a]) == mj.mjtGain.mjGAIN_FIXED
            and int(m.actuator_biastype[a]) == mj.mjtBias.mjBIAS_NONE
            and int(m.actuator_dyntype[a]) == mj.mjtDyn.mjDYN_NONE
        )
        if m.actuator_forcelimited[a]:
            lo, hi = (float(x) for x in m.actuator_forcerange[a])
            limit = abs(gear) * max(abs(lo), abs(hi))
            notes.append(f"actuator {name!r}: |gear {gear!r}| x forcerange [{lo!r}, {hi!r}] = {limit!r}")
        elif plain and m.actuator_ctrllimited[a]:
            lo, hi = (float(x) for x in m.actuator_ctrlrange[a])
            gain = float(m.actuator_gainprm[a, 0])
            limit = abs(gear) * abs(gain) * max(abs(lo), abs(hi))
            notes.append(
                f"actuator {name!r}: |gear {gear!r}| x |gain {gain!r}| x ctrlrange [{lo!r}, {hi!r}] = {limit!r}"
            )
        else:
            unbounded.append(name)
            continue
        total += limit
    if unbounded:
        notes.append(f"actuator(s) {', '.join(map(repr, unbounded))} without a force range: no effort limit from them")
    limit = total if total > 0 and not unbounded else None
    if m.jnt_actfrclimited[j]:
        lo, hi = (float(x) for x in m.jnt_actfrcrange[j])
        bound = max(abs(lo), abs(hi))
        if bound > 0 and (limit is None or bound < limit):
            limit = bound
            notes.append(f"actuatorfrcrange [{lo!r}, {hi!r}] bounds the joint's actuator force: {bound!r}")
    return limit, notes


def lock_values(reader: Compiled, joints: Iterable[int], given: dict[int, float]) -> dict:
    """{joint: (value, why)}: given values (checked against the range), else qpos0, or the
    limit nearest it when qpos0 lies outside the joint's range."""
    m, out = reader.m, {}
    for j in joints:
        lo, hi = (float(x) for x in m.jnt_range[j])
        limited = bool(m.jnt_limited[j])
        if j in given:
            value = given[j]
            if limited and not lo <= value <= hi:
                raise MJCFError(
                    f"{reader.where('joint', m.joint(j).name)}: locked value {value!r} of joint {reader.joint(j)!r} "
                    f"is outside its range [{lo!r}, {hi!r}]"
                )
            out[j] = (value, "given")
        else:
            value = float(m.qpos0[m.jnt_qposadr[j]])
            out[j] = (min(max(value, lo), hi) if limited else value, "default")
    return out


def unmodelled(reader: Compiled, chain_joints: list[int], moving_bodies: set[int]) -> list[str]:
    """What MuJoCo would add to τ that symdyn does not model, on the part that moves."""
    m, out = reader.m, []
    for j in chain_joints:
        dof = int(m.jnt_dofadr[j])
        if m.jnt_stiffness[j] != 0:
            out.append(
                f"joint {reader.joint(j)!r} has a spring (stiffness {float(m.jnt_stiffness[j])!r}): not modelled"
            )
        for field, what in (("jnt_stiffnesspoly", j), ("dof_dampingpoly", dof)):
            values = getattr(m, field, None)
            if values is not None and np.any(values[what] != 0):
                out.append(f"joint {reader.joint(j)!r} has nonlinear {field.split('_')[1]}: not modelled")
    for a in range(m.nu):
        for field in ("actuator_armature", "actuator_damping"):
            values = getattr(m, field, None)
            if values is not None and np.any(values[a] != 0):
                out.append(f"actuator {m.actuator(a).name or a!r} has {field.split('_')[1]}: not modelled")
    for b in sorted(moving_bodies):
        if m.body_gravcomp[b] != 0:
            out.append(f"body {reader.body(b)!r} has gravcomp {float(m.body_gravcomp[b])!r}: not modelled")
    if m.neq:
        names = [
            describe_equality(
                reader.mj.mjtEq(int(m.eq_type[e])),
                m.equality(e).name,
                *(
                    _object_name(
                        reader, int(m.eq_objtype[e]) if hasattr(m, "eq_objtype") else None, int(i), int(m.eq_type[e])
                    )
                    for i in (m.eq_obj1id[e], m.eq_obj2id[e])
                ),
            )
            for e in range(m.neq)
        ]
        out.append(f"{m.neq} equality constraint(s) not modelled: {', '.join(names)}")
    vanished = getattr(reader, "vanished", ())
    if vanished:
        out.append(f"equality constraint(s) gone with the excluded bodies: {', '.join(vanished)}")
    if m.opt.density or m.opt.viscosity:
        out.append("fluid forces (<option density viscosity>) not modelled")
    return out


def _object_name(reader: Compiled, objtype: int | None, i: int, eqtype: int) -> str:
    """The name of an equality constraint's object i (a body, joint, tendon, site …; '' for none)."""
    if i < 0:
        return ""
    mj, m = reader.mj, reader.m
    if not objtype:  # not recorded (older MuJoCo, joint and tendon equalities): the constraint's type says it
        kinds = {0: "BODY", 1: "BODY", 2: "JOINT", 3: "TENDON", 4: "FLEX"}
        objtype = int(getattr(mj.mjtObj, f"mjOBJ_{kinds.get(eqtype, 'BODY')}"))
    return mj.mj_id2name(m, objtype, i) or f"#{i}"
