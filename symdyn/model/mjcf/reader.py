"""`from_mjcf`: the chain from `base_body` to `tip_body` of an MJCF file as a general-convention `Robot`.

MuJoCo compiles the file (`compile`), so its conventions hold as MuJoCo reads
them; this module maps the compiled model onto links.  A body's frame is its
parent's · (pos, quat); each hinge turns about its axis through its anchor
`pos` (exactly: the link frame sits at the anchor, and the offset back to the
body frame moves into what follows), each slide moves along its axis; both
move by q − qpos0 (a joint's `ref`), which is the link's `offset`.  Several
joints in one body become consecutive links, the inner ones massless.
Bodies without joints are welded to their parent and merged into the moving
body they ride on; so are branches off the chain, their joints locked (at
qpos0, or the limit nearest it) — mass, centre of mass and inertia combined
exactly by `symdyn.model.urdf.bodies`, as URDF branches are.  armature → Jm
(G = 1, so G²·Jm is MuJoCo's armature), damping → B, frictionloss → Tc =
(f, −f), range → qlim, actuator gear × forcerange (or × gain × ctrlrange for
a plain motor) → effort_limit, −`<option gravity>` → the robot's gravity
(Corke's sign).  What was read, locked, snapped and stripped is `robot.mjcf`.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from pathlib import Path
from typing import Iterable

import numpy as np

from ..frames import Frame, served
from ..placement import compose, exact, link_number
from ..robot import BASE_JOINTS, IDENTITY, Link, Robot
from ..snapping import Snapping
from ..urdf.bodies import Body
from ..urdf.record import Locked
from .compile import MJCFError, MJCFWarning, compile_mjcf, mujoco_module
from .compiled import KIND, Compiled, effort_of, lock_values, translation, unmodelled
from .record import MjcfRecord

__all__ = ["from_mjcf"]


def from_mjcf(
    path: str | os.PathLike[str],
    *,
    base_body: str | None = None,
    tip_body: str | None = None,
    tips: str | Iterable[str] | None = None,
    base_joint: str | None = None,
    locked: dict | None = None,
    exclude: str | Iterable[str] = (),
    snap: bool = True,
    name: str | None = None,
    frames: Iterable[str] | None = None,
) -> Robot:
    """A `Robot` (general convention) of the chain from `base_body` (default: the world) to
    `tip_body` (default: the only leaf) of an MJCF file (or its text), compiled by MuJoCo.

    locked: {joint: value} for joints off the chain (default: qpos0, the joint's `ref`, or
    the limit nearest it) or on it (made fixed at that value).  exclude: bodies deleted with
    their subtrees before compiling.  snap: orientations and axes near exact values become
    exact (`symdyn.model.snapping`); False keeps MuJoCo's compiled numbers.  name: default
    the file's name without .xml, as on the command line (text: its `<mujoco model>`).
    The robot's `mjcf` records all of it.  frames: the frames its task-space functions serve,
    in order (`Robot.with_frames`: any body or site of the file); default: the tips when `tips`
    names several, else `Robot.task_frames`'.

    tips: "all" moves every hinge and slide joint below the base (`locked` ones held), a
    list of bodies the joints on the paths from the base to each; the links then come in
    the file's depth-first order (MuJoCo's joint order), each naming its parent
    (`robot.parents`) and joint (`robot.joint_names`).  base_joint: None, "free" or
    "planar": the base body (with what is welded or locked to it) floats
    (`robot.base_body`, Pinocchio's conventions for q and v).  With tips or base_joint, a
    `<freejoint/>` (a free joint) on the world's only child body makes that body the
    floating base (base_joint "free"; MuJoCo's own q order, [x y z qw qx qy qz], and
    velocity, [world linear, body angular], are not Pinocchio's: `robot.from_mujoco_state` and
    `robot.to_mujoco_state` convert them, `symdyn.model.mjcf.state`).  A file whose root body has
    a `<freejoint/>` is read so without tips or base_joint too (the chain to tip_body, or the
    only leaf, on that free base).

    Raises:
        MJCFError: (a `ValueError`) `mujoco` is not installed; a file MuJoCo cannot read or
            compile; a body whose inertia depends on an absent mesh file; base_body,
            tip_body, locked or exclude naming no suitable body or joint, a locked value
            outside its range; several leaves and no tip_body; a ball or free joint on the
            chain or on a body that rides on it; a chain without a moving joint; an
            inertia `Link` refuses; tips with tip_body, tips neither "all" nor body names,
            a tip that is not a body below the base; base_joint not None, "free" or
            "planar", or "planar" for a file whose root body has a free joint; a
            floating base body (not the free joint's) that has joints of its own; a frame the
            file does not have (the closest are named) or given twice.

    Warns:
        MJCFWarning: what MuJoCo adds to the dynamics of the moving part that symdyn does
            not model (joint springs, gravcomp, equality constraints, fluid forces).
    """
    asked = base_joint
    if base_joint not in BASE_JOINTS:
        raise MJCFError(
            f"unknown base_joint {base_joint!r}: expected None (a fixed base), 'free' (6 DOF, Pinocchio's "
            "free-flyer) or 'planar' (x, y, yaw)"
        )
    if tips is not None and tip_body is not None:
        raise MJCFError(
            f"tips={tips!r} and tip_body={tip_body!r} together: tips chooses every moving joint (tips='all') or "
            "the chains to several bodies, tip_body one chain; give one of them"
        )
    if isinstance(tips, str) and tips != "all":
        raise MJCFError(f"tips={tips!r}: expected 'all' or a list of body names (one chain: tip_body={tips!r})")
    if tips is not None and not isinstance(tips, str):  # read once: a generator too, and the file read twice
        try:
            tips = tuple(tips)
        except TypeError:
            raise MJCFError(f"tips must be 'all' or a list of body names, got {tips!r}") from None
    mj = mujoco_module()
    excluded = (exclude,) if isinstance(exclude, str) else tuple(exclude)
    compiled = compile_mjcf(path, excluded, base_body, tip_body)
    m = compiled.model
    reader = Compiled(mj, compiled, snap)
    label = compiled.file

    def body_id(name: str, what: str) -> int:
        b = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, name)
        if b < 0:
            names = [reader.body(i) for i in range(m.nbody)]
            raise MJCFError(f"{label}: {what} {name!r} is not a body of the file; its bodies are {names}")
        return b

    base = body_id(base_body, "base_body") if base_body else 0
    # a <freejoint/> on the world's only body makes it the floating base, whatever else is asked
    tree = tips is not None or base_joint is not None or (base == 0 and _free_root(reader))
    if tree:
        base, free_joint = _floating_base(reader, base, base_joint, label)
        base_joint = "free" if free_joint is not None and base_joint is None else base_joint
        tip_list = _tip_bodies(reader, base, tips, tip_body, body_id, label)
    below_base = reader.below(base)
    given = _given(reader, locked, below_base, base, label)
    if tree:
        on_path = {base}
        for t in () if tip_list == "all" else tip_list:
            while t not in on_path:
                on_path.add(t)
                t = int(m.body_parentid[t])
        for b in sorted(on_path - {base}):
            _refuse_ball(reader, b)
        lockable = [
            j for j in range(m.njnt) if int(m.jnt_bodyid[j]) in below_base - {base} and reader.joint_type(j) in KIND
        ]
        if tip_list == "all":
            moving = [j for j in lockable if j not in given]
        else:
            moving = [j for j in lockable if int(m.jnt_bodyid[j]) in on_path and j not in given]
        reader.values = lock_values(reader, [j for j in lockable if j not in moving], given)
        held = set(given) if tip_list == "all" else {j for j in given if int(m.jnt_bodyid[j]) in on_path}
        carriers, base_mass, reached = _walk(reader, base, set(moving), held, base_joint is not None)
        reader.frames.update(reached)
        if not carriers and base_joint is None:  # on a base joint, the body alone (a drone) moves
            raise MJCFError(f"{label}: no hinge or slide joint moves below {reader.body(base)!r}")
        tip = tip_list[0] if tip_list != "all" and len(tip_list) == 1 else None
        pending = reached[tip][1] if tip is not None else IDENTITY
    else:
        if tip_body:
            tip = body_id(tip_body, "tip_body")
            if tip not in below_base or tip == base:
                raise MJCFError(f"{label}: tip_body {tip_body!r} is not below base_body {reader.body(base)!r}")
        else:
            leaves = sorted(b for b in below_base if b != base and not reader.children.get(b))
            if len(leaves) != 1:
                raise MJCFError(
                    f"{label}: the bodies below {reader.body(base)!r} have "
                    + (f"{len(leaves)} leaves {[reader.body(b) for b in leaves]}" if leaves else "no leaf")
                    + ": choose the chain's end with tip_body=… (--tip on the command line)"
                )
            tip = leaves[0]
        chain, b = [], tip
        while b != base:
            chain.append(b)
            b = int(m.body_parentid[b])
        chain.reverse()
        on_chain = set(chain) | {base}

        for b in chain:
            _refuse_ball(reader, b)
        lockable = [
            j for j in range(m.njnt) if int(m.jnt_bodyid[j]) in below_base - {base} and reader.joint_type(j) in KIND
        ]
        moving = [j for b in chain for j in reader.joints_of(b) if j not in given]
        reader.values = lock_values(reader, [j for j in lockable if j not in moving], given)

        reader.subtree(base, on_chain, reader.body(base), False)  # resting on the base: recorded, left out
        pending, carrier, origin, body = IDENTITY, None, IDENTITY, Body.empty()
        carriers: list[tuple[int, tuple, Body]] = []
        for b in chain:
            T = compose(pending, reader.placement(b))  # body b's frame, from the carrier's link frame (or the base)
            for j in reader.joints_of(b):
                if j in given:
                    value, why = reader.values[j]
                    into = reader.body(int(m.jnt_bodyid[carrier])) if carrier is not None else reader.body(base)
                    reader.locked.append(Locked(reader.joint(j), value, into, why, carrier is not None, on_chain=True))
                    T = compose(T, reader.motion(j, value))
                    continue
                if carrier is not None:
                    carriers.append((carrier, origin, body))
                if reader.joint_type(j) == "hinge":  # the link frame at the anchor; back to the body frame after
                    origin, T = compose(T, translation(m.jnt_pos[j])), translation(-m.jnt_pos[j])
                else:
                    origin, T = T, IDENTITY
                carrier, body = j, Body.empty()
            into = reader.body(int(m.jnt_bodyid[carrier])) if carrier is not None else reader.body(base)
            sub = reader.subtree(
                b, on_chain, into, carrier is not None, len(carriers) if carrier is not None else -1, T
            )
            if carrier is not None:
                body = body + sub.moved(T)
            pending = T
        if carrier is None:
            raise MJCFError(
                f"{label}: the chain from {reader.body(base)!r} to {reader.body(tip)!r} has no moving joint"
            )
        carriers.append((carrier, origin, body))
        carriers = [(j, o, bo, i - 1) for i, (j, o, bo) in enumerate(carriers)]
        base_mass, free_joint, tip_list = None, None, None

    read, links = [], []
    for j, origin, body_j, parent in carriers:
        effort, notes = effort_of(reader, j)
        dof = int(m.jnt_dofadr[j])
        terms = [
            f"{what} {float(v)!r} -> {to}"
            for what, v, to in (
                ("armature", m.dof_armature[dof], "Jm (G = 1)"),
                ("damping", m.dof_damping[dof], "B"),
                ("frictionloss", m.dof_frictionloss[dof], "Tc = (f, -f)"),
            )
            if v != 0
        ]
        if terms or notes:
            read.append(f"joint {reader.joint(j)!r}: " + "; ".join(terms + notes))
        link = reader.link(j, origin, body_j, effort)
        links.append(dataclasses.replace(link, parent=parent, name=m.joint(j).name or None))

    moving_bodies = set().union(*(reader.below(int(m.jnt_bodyid[c[0]])) for c in carriers))
    notes = unmodelled(reader, [c[0] for c in carriers], moving_bodies | (below_base if base_joint else set()))
    gravity = tuple(float(x) for x in m.opt.gravity)
    g = (0.0, 0.0, 0.0)
    if m.opt.disableflags & mj.mjtDisableBit.mjDSBL_GRAVITY:
        notes.append("the file disables gravity (<flag gravity='disable'>): the robot's gravity is 0")
    else:
        g = tuple(-x + 0.0 for x in gravity)
    for flag, what in (("mjDSBL_DAMPER", "damping"), ("mjDSBL_FRICTIONLOSS", "frictionloss")):
        if m.opt.disableflags & getattr(mj.mjtDisableBit, flag) and any(
            getattr(link, "B" if what == "damping" else "Tc") not in (0, (0, 0)) for link in links
        ):
            notes.append(f"the file disables {what}, which symdyn reads into the links nonetheless")

    base_T, above = IDENTITY, []
    b = base
    while b != 0:
        base_T = compose(reader.placement(b), base_T)
        above += [reader.joint(j) for j in reader.joints_of(b)]
        b = int(m.body_parentid[b])
    if free_joint is not None:  # q places the free body in the world: its joint sits at the origin
        base_T, above = IDENTITY, [a for a in above if a != reader.joint(free_joint)]
    if above:
        notes.append(f"the base's pose is taken at qpos0 of the joints above it: {', '.join(above)}")
    floating = None
    if base_joint is not None:
        floating = Link(
            m=link_number(base_mass.m),
            r=tuple(link_number(x) for x in base_mass.r),
            I=tuple(tuple(link_number(x) for x in row) for row in base_mass.I),
            name=reader.body(base),
        )

    robot = Robot(
        name or (Path(label).stem if label != "<string>" else "") or _model_name(m) or "mjcf",
        tuple(links),
        convention="general",
        gravity=g,
        base=tuple(tuple(link_number(x) for x in row) for row in base_T),
        tool=tuple(tuple(link_number(x) for x in row) for row in pending),
        base_joint=base_joint,
        base_body=floating,
        source=f"MJCF {label} (sha256 {compiled.sha256[:16]}…)",
        frame_catalog=_catalog(reader),
    )
    record = MjcfRecord(
        file=label,
        sha256=compiled.sha256,
        base_body=reader.body(base),
        tip_body=reader.body(tip) if tip is not None else "",
        joints=tuple(reader.joint(c[0]) for c in carriers),
        tips=()
        if tip_list is None or (tips is None)
        else ("all",)
        if tip_list == "all"
        else tuple(reader.body(t) for t in tip_list),
        base_joint=base_joint,
        free_joint=reader.joint(free_joint) if free_joint is not None else "",
        parents=tuple(c[3] for c in carriers),
        locked=tuple(reader.locked),
        excluded=excluded,
        snaps=tuple(reader.snaps),
        snap=snap,
        read=tuple(read),
        stripped=compiled.stripped,
        left_out=tuple(reader.left_out),
        gravity=gravity,
        warnings=tuple(notes),
        fingerprint=robot.fingerprint(),
        **_addresses(reader, [c[0] for c in carriers], free_joint),
        **{
            key: tuple(reader.joint(c[0]) for c, link in zip(carriers, links) if read_from(link))
            for key, read_from in (
                ("rotor", lambda link: link.Jm != 0),
                ("viscous", lambda link: link.B != 0),
                ("coulomb", lambda link: link.Tc != (0, 0)),
            )
        },
    )
    if reader.snaps:  # the compiled numbers too: the record states how far the snaps move the dynamics
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # this reading says it all
            literal = from_mjcf(
                path,
                base_body=base_body,
                tip_body=tip_body,
                tips=tips,
                base_joint=asked,
                locked=locked,
                exclude=exclude,
                snap=False,
                name=name,
            )
        record = dataclasses.replace(record, snapping=Snapping(robot, dataclasses.replace(literal, mjcf=None)))
    for message in notes:
        warnings.warn(f"{label}: {message}", MJCFWarning, stacklevel=2)
    return served(dataclasses.replace(robot, mjcf=record), frames, record.tips)


def _given(reader: Compiled, locked: dict | None, below_base: set, base: int, label: str) -> dict[int, float]:
    """{joint id: value} of `locked`, each checked: a hinge or slide joint below the base, a finite value."""
    mj, m = reader.mj, reader.m
    given: dict[int, float] = {}
    for joint, value in dict(locked or {}).items():
        j = mj.mj_name2id(m, mj.mjtObj.mjOBJ_JOINT, joint)
        if j < 0:
            raise MJCFError(f"{label}: locked joint {joint!r} is not a joint of the file")
        if int(m.jnt_bodyid[j]) not in below_base or int(m.jnt_bodyid[j]) == base:
            raise MJCFError(f"{label}: locked joint {joint!r} is not below base_body {reader.body(base)!r}")
        if reader.joint_type(j) not in KIND:
            raise MJCFError(
                f"{label}: locked joint {joint!r} is a {reader.joint_type(j)} joint; hinge and slide joints can be locked"
            )
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise MJCFError(f"{label}: locked value of joint {joint!r} must be a finite number, got {value!r}")
        given[j] = float(value)
    return given


def _refuse_ball(reader: Compiled, b: int) -> None:
    """Refuse a ball or free joint on body b of the chain (or on the way to a tip)."""
    m = reader.m
    for j in reader.joints_of(b):
        if reader.joint_type(j) not in KIND:
            raise MJCFError(
                f"{reader.where('joint', m.joint(j).name)}: {reader.joint_type(j)} joint {reader.joint(j)!r} on body "
                f"{reader.body(b)!r} is not supported yet (hinge and slide joints are): choose a chain without it"
            )


def _floating_base(reader: Compiled, base: int, base_joint: str | None, label: str) -> tuple[int, int | None]:
    """(the base body, the free joint that carries it or None): with the world as base, a free
    joint on the world's only child body (MJCF's `<freejoint/>`) makes that body the floating
    base; else, for a base_joint, the world's only child body (or base_body) floats.

    Raises:
        MJCFError: base_joint "planar" for a root body with a free joint; a floating base asked
            of the world with several bodies on it; a floating body with joints of its own.
    """
    m = reader.m
    if base == 0:
        roots = reader.children.get(0, [])
        if len(roots) == 1:
            free = [j for j in reader.joints_of(roots[0]) if reader.joint_type(j) == "free"]
            if free:
                if base_joint == "planar":
                    raise MJCFError(
                        f"{reader.where('joint', m.joint(free[0]).name)}: body {reader.body(roots[0])!r} floats on the "
                        f"file's free joint {reader.joint(free[0])!r}, which is not base_joint='planar'"
                    )
                if len(reader.joints_of(roots[0])) > 1:
                    raise MJCFError(
                        f"{label}: body {reader.body(roots[0])!r} has a free joint and other joints: not supported"
                    )
                return roots[0], free[0]
        if base_joint is None:
            return base, None
        if len(roots) != 1:
            raise MJCFError(
                f"{label}: base_joint={base_joint!r} floats one body, but the world holds "
                f"{[reader.body(b) for b in roots]}: choose it with base_body=…"
            )
        base = roots[0]
    if base_joint is not None and reader.joints_of(base):
        names = [reader.joint(j) for j in reader.joints_of(base)]
        raise MJCFError(
            f"{label}: the floating body {reader.body(base)!r} has joints of its own {names}: choose the body below "
            "them with base_body=…"
        )
    return base, None


def _free_root(reader: Compiled) -> bool:
    """Whether the world's only child body floats on a free joint (MJCF's `<freejoint/>`)."""
    roots = reader.children.get(0, [])
    return len(roots) == 1 and any(reader.joint_type(j) == "free" for j in reader.joints_of(roots[0]))


def _addresses(reader: Compiled, moving: list[int], free: int | None) -> dict:
    """The record's MuJoCo addresses (`MjcfRecord.qpos_address` …): where each moving joint and the
    free joint sit in qpos and qvel, and the file's qpos with the locked joints at their values."""
    m, mj = reader.m, reader.mj
    qpos = np.array(m.qpos0, dtype=float)
    for lock in reader.locked:
        j = mj.mj_name2id(m, mj.mjtObj.mjOBJ_JOINT, lock.joint)
        if j >= 0 and reader.joint_type(j) in KIND:
            qpos[m.jnt_qposadr[j]] = lock.value
    return {
        "qpos_address": tuple(int(m.jnt_qposadr[j]) for j in moving),
        "qvel_address": tuple(int(m.jnt_dofadr[j]) for j in moving),
        "free_address": (int(m.jnt_qposadr[free]), int(m.jnt_dofadr[free])) if free is not None else (-1, -1),
        "file_nq": int(m.nq),
        "file_nv": int(m.nv),
        "qpos_locked": tuple(float(x) for x in qpos),
    }


def _tip_bodies(reader: Compiled, base: int, tips, tip_body: str | None, body_id, label: str):
    """The tips of a tree: "all", or body ids below the base (tip_body alone: one)."""
    if tips is None:
        if tip_body is not None:
            tips = [tip_body]
        else:
            leaves = sorted(b for b in reader.below(base) if b != base and not reader.children.get(b))
            if len(leaves) != 1:
                raise MJCFError(
                    f"{label}: the bodies below {reader.body(base)!r} have {len(leaves)} leaves "
                    f"{[reader.body(b) for b in leaves]}: choose the chain's end with tip_body=… or tips=…"
                )
            return [leaves[0]]
    if tips == "all":
        return "all"
    try:
        names = list(dict.fromkeys(tips))
    except TypeError:
        raise MJCFError(f"tips must be 'all' or a list of body names, got {tips!r}") from None
    if not names or not all(isinstance(n, str) and n for n in names):
        raise MJCFError(f"tips must be 'all' or a non-empty list of body names, got {tips!r}")
    below = reader.below(base)
    out = []
    for name in names:
        b = body_id(name, "tip")
        if b not in below or b == base:
            raise MJCFError(f"{label}: tip {name!r} is not below base_body {reader.body(base)!r}")
        out.append(b)
    return out


def _walk(reader: Compiled, base: int, moving: set, held: set, base_moves: bool) -> tuple[list, Body, dict]:
    """(carriers, the base's body, frames): depth first from the base in MuJoCo's body order,
    each moving joint a carrier (joint, origin, body, parent carrier or -1); joints off the
    moving set locked (`held`: those that would move), welded bodies merged; each body reached
    → (its carrier, its frame in the carrier's link frame)."""
    m = reader.m
    carriers: list = []
    base_body = Body.empty()
    frames: dict = {}
    todo = [(base, -1, IDENTITY)]
    while todo:
        b, seg, T = todo.pop()
        moves = seg >= 0 or base_moves
        into = reader.body(int(m.jnt_bodyid[carriers[seg][0]])) if seg >= 0 else reader.body(base)
        if b != base:
            T = compose(T, reader.placement(b))
            if reader.left_out_free(b, into, moves, "body"):
                continue
            for j in reader.joints_of(b):
                if j in moving:
                    if reader.joint_type(j) == "hinge":  # the link frame at the anchor
                        origin, T = compose(T, translation(m.jnt_pos[j])), translation(-m.jnt_pos[j])
                    else:
                        origin, T = T, IDENTITY
                    carriers.append([j, origin, Body.empty(), seg])
                    seg, moves, into = len(carriers) - 1, True, reader.body(b)
                    continue
                value, why = reader.values[j]
                reader.locked.append(Locked(reader.joint(j), value, into, why, moves, on_chain=j in held))
                T = compose(T, reader.motion(j, value))
        body = reader.inertial(b).moved(T)
        if seg >= 0:
            carriers[seg][2] = carriers[seg][2] + body
        else:
            base_body = base_body + body
        frames[b] = (seg, T)
        todo += [(child, seg, T) for child in reversed(reader.children.get(b, []))]
    return [tuple(c) for c in carriers], base_body, frames


def _catalog(reader: Compiled) -> tuple[Frame, ...]:
    """Every body reached and every site on one, as frames (`Robot.frame_catalog`): a body by its
    name, a site by its own (site:NAME where a body has that name)."""
    m = reader.m
    exact_T = lambda T: tuple(tuple(link_number(x) for x in row) for row in T)  # noqa: E731
    out = {reader.body(b): Frame(reader.body(b), seg, exact_T(T)) for b, (seg, T) in reader.frames.items()}
    for s in range(m.nsite):
        b = int(m.site_bodyid[s])
        if b not in reader.frames:
            continue
        seg, T = reader.frames[b]
        R = reader.orientation(m.site_quat[s], f"site {m.site(s).name!r}")
        placed = tuple(tuple(R[i]) + (exact(float(m.site_pos[s][i])),) for i in range(3)) + ((0, 0, 0, 1),)
        name = m.site(s).name or f"site#{s}"
        name = f"site:{name}" if name in out else name
        out[name] = Frame(name, seg, exact_T(compose(T, placed)))
    return tuple(out.values())


def _model_name(m) -> str:
    """The `<mujoco model>` name of a compiled model ('' when unnamed)."""
    names = m.names if isinstance(m.names, bytes) else bytes(m.names)
    return names.split(b"\0", 1)[0].decode()
