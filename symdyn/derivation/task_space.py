"""The task space, derived: frame poses, Jacobians, velocities, classical accelerations, the
centre of mass and the centroidal momentum, as named intermediates.

Part of the derive stage, beside the dynamics.  One outward recursion in world-aligned
coordinates (Pinocchio's LOCAL_WORLD_ALIGNED) gives every link's pose (R, o), the world
axis z and offset velocity u of its joint's motion, its angular velocity ω, the velocity
of its origin, ω̇ and the classical acceleration of its origin; each intermediate is named on
a `Tape` as it is formed, so a frame's Jacobian column costs what its entries cost (z and
u + z × (p − o) of the joints it hangs from; exact zeros elsewhere), never a product of
matrices.  Conventions are Pinocchio's: spatial vectors [linear; angular]; `LOCAL` the
frame's own axes; the classical acceleration for `frame_acceleration` and the drift J̇·v
(the same at a = 0); A_G about the centre of mass with world axes; a floating base's
velocity in its body frame (free-flyer q, v).  Ȧ_G·v and the centre of mass's drift come
from Newton–Euler's two passes in the links' own axes instead (`_rest_wrench`).  The Khalil
recursion of τ holds no positions and carries gravity in its accelerations, so the task space
keeps a recursion of its own.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import sympy as sp

from ..model import Link, Robot
from ..model.frames import Frame
from . import floating
from .kinematics import ancestors, link_frames, rows, turned_inertia
from .symbols import exact, joint_symbols
from .tape import Tape

__all__ = [
    "TaskSpace",
    "task_space",
    "derive_task_space",
    "functions",
    "parts",
    "arguments",
    "shape",
    "OUTPUTS",
    "TOGETHER",
    "DRIFTS",
]

#: Each task-space function: (its output's name, the inputs it takes).
OUTPUTS = {
    "frame_pose": ("pose", ("q",)),
    "frame_jacobian": ("J", ("q",)),
    "frame_jacobian_aligned": ("J", ("q",)),
    "frame_velocity": ("velocity", ("q", "v")),
    "frame_acceleration": ("acceleration", ("q", "v", "a")),
    "frame_drift": ("drift", ("q", "v")),
    "com": ("com", ("q",)),
    "com_jacobian": ("Jcom", ("q",)),
    "com_drift": ("com_drift", ("q", "v")),
    "centroidal_map": ("Ag", ("q",)),
    "centroidal_drift": ("dAg_v", ("q", "v")),
}

#: Functions returning several of `OUTPUTS` from one pass, the recursion they share computed once:
#: what a contact or operational-space controller calls each step (each frame's pose, Jacobian
#: and J̇·v) and a whole-body one (the centre of mass, its Jacobian and A_G).
TOGETHER = {
    "frame_kinematics": ("frame_pose", "frame_jacobian_aligned", "frame_drift"),
    "centroidal": ("com", "com_jacobian", "centroidal_map"),
}


def parts(function: str) -> tuple[str, ...]:
    """The functions of `OUTPUTS` that `function` returns, in order (itself when it is one)."""
    return TOGETHER.get(function, (function,))


def arguments(function: str) -> tuple[str, ...]:
    """The inputs a task-space function takes, in the order q, v, a."""
    used = {arg for part in parts(function) for arg in OUTPUTS[part][1]}
    return tuple(arg for arg in ("q", "v", "a") if arg in used)


@dataclass(frozen=True)
class TaskSpace:
    """The task-space quantities of a robot's frames as sympy matrices over named intermediates.

    q (nq), v and a (nv): the symbols (base first, then the joints: q1…, qd1…, qdd1…);
    frames: the `Frame`s served, in order; definitions: the named intermediates, in order;
    outputs: function name → matrix (`OUTPUTS`; shapes per `shape`).  The functions at a = 0
    (drifts) are `outputs` with the accelerations set to zero (`at_rest`)."""

    robot: Robot
    q: tuple
    v: tuple
    a: tuple
    frames: tuple
    definitions: tuple
    outputs: dict

    def shape(self, function: str) -> tuple[int, ...]:
        """The per-state shape of a function's output (`shape`)."""
        return shape(function, len(self.frames), len(self.v))

    def inputs(self, function: str) -> tuple:
        """((argname, symbols), …) of a function."""
        given = {"q": self.q, "v": self.v, "a": self.a}
        return tuple((arg, given[arg]) for arg in arguments(function))

    def at_rest(self) -> dict:
        """The substitution a = 0 (the drifts)."""
        return {s: sp.S.Zero for s in self.a}

    def full(self, function: str) -> sp.ImmutableMatrix:
        """A function's output with every intermediate written out (plain sympy; small robots)."""
        defs = dict(self.definitions)
        done: dict = {}
        for s, e in defs.items():
            done[s] = sp.sympify(e).xreplace(done)
        out = self.outputs[function].xreplace(done)
        return out.xreplace(self.at_rest()) if function in DRIFTS else out


def shape(function: str, m: int, nv: int) -> tuple[int, ...]:
    """The per-state shape of a task-space function's output for m frames and nv velocities."""
    return {
        "frame_pose": (m, 4, 4),
        "frame_jacobian": (m, 6, nv),
        "frame_jacobian_aligned": (m, 6, nv),
        "frame_velocity": (m, 6),
        "frame_acceleration": (m, 6),
        "frame_drift": (m, 6),
        "com": (3,),
        "com_jacobian": (3, nv),
        "com_drift": (3,),
        "centroidal_map": (6, nv),
        "centroidal_drift": (6,),
    }[function]


#: The functions taken at a = 0 from the acceleration recursion.
DRIFTS = ("frame_drift", "com_drift", "centroidal_drift")

#: The functions of the centre of mass and the centroidal momentum (none for a massless robot).
CENTROIDAL = ("com", "com_jacobian", "com_drift", "centroidal_map", "centroidal_drift")


def _total_mass(robot: Robot):
    bodies = list(robot.links) + ([robot.base_body] if robot.base_joint and robot.base_body is not None else [])
    return sp.Add(*(exact(link.m) for link in bodies))


def functions(robot: Robot) -> tuple[str, ...]:
    """The task-space functions of `robot`, in `OUTPUTS`' order then `TOGETHER`'s: every one, less
    those of the centre of mass when the robot carries no mass (its centre of mass is undefined)."""
    massless = _total_mass(robot) == 0
    return tuple(name for name in (*OUTPUTS, *TOGETHER) if not (massless and any(p in CENTROIDAL for p in parts(name))))


# --------------------------------------------------------------------------- small vector algebra


def _cross(a, b) -> list:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _plus(*vs) -> list:
    return [sp.Add(*(v[k] for v in vs)) for k in range(3)]


def _times(R, v) -> list:
    return [sp.Add(*(R[i][j] * v[j] for j in range(3))) for i in range(3)]


def _times_t(R, v) -> list:
    """Rᵀ·v."""
    return [sp.Add(*(R[j][i] * v[j] for j in range(3))) for i in range(3)]


def _scale(v, s) -> list:
    return [x * s for x in v]


def _rot(tape: Tape, R, label: str) -> list:
    """A 3×3 rotation (rows of expressions) with its entries named {label}_11 …"""
    return [[tape.name(R[i][j], f"{label}_{i + 1}{j + 1}") for j in range(3)] for i in range(3)]


def _matmul(A, B) -> list:
    return [[sp.Add(*(A[i][k] * B[k][j] for k in range(3))) for j in range(3)] for i in range(3)]


# --------------------------------------------------------------------------- the recursion


@dataclass
class _Body:
    """A body's world-aligned kinematics: rotation R (rows), origin o, angular velocity w,
    origin velocity vo, angular acceleration dw, classical origin acceleration ao."""

    R: list
    o: list
    w: list
    vo: list
    dw: list
    ao: list


@dataclass(frozen=True)
class _Column:
    """One velocity's motion: the body it moves (-1: the base), the world axis z and the
    velocity u of that body's origin o per unit rate."""

    body: int
    z: list
    u: list
    o: list


def _base(tape: Tape, robot: Robot) -> tuple[_Body, list[_Column], tuple, tuple, tuple]:
    """The base body (frame {0}, or the body a base joint moves) and its columns; (q, v, a) of
    the base joint (empty on a fixed base)."""
    Rb = [[exact(x) for x in row[:3]] for row in robot.base[:3]]
    pb = [exact(row[3]) for row in robot.base[:3]]
    zero = [sp.S.Zero] * 3
    kind = robot.base_joint
    if kind is None:
        return _Body(Rb, pb, zero, zero, zero, zero), [], (), (), ()
    qb, vb, ab = floating.base_symbols(kind)
    R = _rot(tape, _matmul(Rb, rows(floating.base_rotation(kind, qb))), "R0")
    place = [qb[0], qb[1], qb[2] if kind == "free" else 0]
    o = tape.vector(_plus(pb, _times(Rb, place)), "o0")
    lin, ang = floating.spatial(kind, vb)
    dlin, dang = floating.spatial(kind, ab)
    w = tape.vector(_times(R, ang), "w0")
    vo = tape.vector(_times(R, lin), "vo0")
    dw = tape.vector(_times(R, dang), "dw0")
    ao = tape.vector(_times(R, _plus(dlin, _cross(ang, lin))), "ao0")
    columns = []
    for k, (lin_k, ang_k) in enumerate(floating.columns(kind)):
        z = [tape.name(e, f"zb{k + 1}_{'xyz'[i]}") for i, e in enumerate(_times(R, ang_k))]
        u = [tape.name(e, f"ub{k + 1}_{'xyz'[i]}") for i, e in enumerate(_times(R, lin_k))]
        columns.append(_Column(-1, z, u, o))
    return _Body(R, o, w, vo, dw, ao), columns, qb, vb, ab


def task_space(robot: Robot, frames: tuple[Frame, ...] | None = None) -> TaskSpace:
    """Derive the task space of `robot` for `frames` (default `robot.task_frames`).

    The outward pass (world-aligned, per link k on parent p with joint rate q̇ₖ, q̈ₖ):
    Rₖ = Rₚ·R(qₖ), oₖ = oₚ + Rₚ·p(qₖ), zₖ = Rₖ·S_ω, uₖ = Rₖ·S_v; ωₖ = ωₚ + zₖq̇ₖ,
    vₖ = vₚ + ωₚ × (oₖ − oₚ) + uₖq̇ₖ, ω̇ₖ = ω̇ₚ + ωₚ × zₖq̇ₖ + zₖq̈ₖ,
    aₖ = aₚ + ω̇ₚ × (oₖ − oₚ) + ωₚ × (vₖ − vₚ) + ωₖ × uₖq̇ₖ + uₖq̈ₖ.
    """
    frames = robot.task_frames if frames is None else tuple(frames)
    n = robot.n
    q, qd, qdd = joint_symbols(n)
    tape = Tape()
    base, columns, qb, vb, ab = _base(tape, robot)
    bodies: list[_Body] = []
    links = link_frames(robot, q)  # once: each call rebuilds every joint's transform
    for k, f in enumerate(links):
        p = base if f.parent < 0 else bodies[f.parent]
        tag = k + 1
        R = _rot(tape, _matmul(p.R, rows(f.R)), f"R{tag}")
        r = tape.vector(_times(p.R, list(f.p)), f"r{tag}")
        o = tape.vector(_plus(p.o, r), f"o{tag}")
        z = tape.vector(_times(R, f.S[:3]), f"z{tag}")
        u = tape.vector(_times(R, f.S[3:]), f"u{tag}")
        rel = _plus(_cross(p.w, r), _scale(u, qd[k]))  # vₖ − vₚ
        w = tape.vector(_plus(p.w, _scale(z, qd[k])), f"w{tag}")
        vo = tape.vector(_plus(p.vo, rel), f"vo{tag}")
        dw = tape.vector(_plus(p.dw, _cross(p.w, _scale(z, qd[k])), _scale(z, qdd[k])), f"dw{tag}")
        ao = _plus(p.ao, _cross(p.dw, r), _cross(p.w, rel), _cross(w, _scale(u, qd[k])), _scale(u, qdd[k]))
        bodies.append(_Body(R, o, w, vo, tape.vector(dw, f"dw{tag}"), tape.vector(ao, f"ao{tag}")))
        columns.append(_Column(k, z, u, o))
    parents = robot.parents
    moved_by = [set(ancestors(parents, k)) for k in range(n)]  # the joints that move body k

    def moves(column: _Column, body: int) -> bool:
        return column.body == -1 or (body >= 0 and column.body in moved_by[body])

    outputs = {}
    outputs.update(_frames(tape, frames, base, bodies, columns, moves))
    outputs["frame_jacobian"] = sp.ImmutableMatrix.vstack(
        *(_local_jacobian(tape, frame, j, links, robot.base_joint, len(columns)) for j, frame in enumerate(frames))
    )
    outputs.update(_centroidal(tape, robot, links, base, bodies, columns))
    v = tuple(vb) + tuple(qd)
    return TaskSpace(
        robot=robot,
        q=tuple(qb) + tuple(q),
        v=v,
        a=tuple(ab) + tuple(qdd),
        frames=frames,
        definitions=tuple(tape.defs.items()),
        outputs=outputs,
    )


def derive_task_space(robot: Robot, *, cache: bool = True) -> TaskSpace:
    """`task_space(robot)` for its task frames, read from the disk cache when the same robot and
    frames were derived before by this symdyn (`derivation.cache`: keyed by the fingerprint, the
    frames' names, the version and the derivation code)."""
    from .. import __version__
    from .cache import cached, key
    from .entry import code_fingerprint

    names = ",".join(f.name for f in robot.task_frames)
    entry = key(robot.fingerprint(), "task-space", names, __version__, code_fingerprint())
    derived, _ = cached("task-space", entry, lambda: task_space(robot), use_cache=cache)
    return dataclasses.replace(derived, robot=robot)


def _frames(tape: Tape, frames, base: _Body, bodies: list[_Body], columns: list[_Column], moves) -> dict:
    """Pose, Jacobians (LOCAL and LOCAL_WORLD_ALIGNED), LOCAL velocity and classical acceleration
    of each frame, stacked frame by frame."""
    nv = len(columns)
    pose, aligned, velocity, acceleration, world = [], [], [], [], []
    for j, frame in enumerate(frames):
        tag = f"f{j + 1}"
        body = base if frame.link < 0 else bodies[frame.link]
        Rf = [[exact(x) for x in row[:3]] for row in frame.placement[:3]]
        pf = [exact(row[3]) for row in frame.placement[:3]]
        R = _rot(tape, _matmul(body.R, Rf), f"R{tag}")
        r = tape.vector(_times(body.R, pf), f"r{tag}")
        p = tape.vector(_plus(body.o, r), f"p{tag}")
        pose += [R[i] + [p[i]] for i in range(3)] + [[0, 0, 0, 1]]
        cols_aligned = []
        for c, column in enumerate(columns):
            if not moves(column, frame.link):
                cols_aligned.append([sp.S.Zero] * 6)
                continue
            arm = [tape.name(e, f"d{tag}_{c + 1}{'xyz'[i]}") for i, e in enumerate(_plus(p, _scale(column.o, -1)))]
            lin = [
                tape.name(e, f"J{tag}_{c + 1}{'xyz'[i]}") for i, e in enumerate(_plus(column.u, _cross(column.z, arm)))
            ]
            cols_aligned.append(lin + list(column.z))
        aligned += [[cols_aligned[c][i] for c in range(nv)] for i in range(6)]
        v = _plus(body.vo, _cross(body.w, r))
        velocity.append(_times_t(R, v) + _times_t(R, body.w))
        world.append(v + list(body.w))
        a = _plus(body.ao, _cross(body.dw, r), _cross(body.w, _cross(body.w, r)))
        acceleration.append(a + list(body.dw))
    m = len(frames)
    return {
        "frame_pose": sp.ImmutableMatrix(4 * m, 4, [x for row in pose for x in row]),
        "frame_jacobian_aligned": sp.ImmutableMatrix(6 * m, nv, [x for row in aligned for x in row]),
        "frame_velocity": sp.ImmutableMatrix(m, 6, [x for row in velocity for x in row]),
        "frame_acceleration": sp.ImmutableMatrix(m, 6, [x for row in acceleration for x in row]),
        "frame_drift": sp.ImmutableMatrix(m, 6, [x for row in acceleration for x in row]),
        # not a function of its own: each frame's origin velocity and angular velocity in the
        # world's axes, for a surface contact's spatial drift (`derivation.contacts`)
        "frame_velocity_world": sp.ImmutableMatrix(m, 6, [x for row in world for x in row]),
    }


def _local_jacobian(tape: Tape, frame: Frame, j: int, links, kind: str | None, nv: int) -> sp.ImmutableMatrix:
    """A frame's Jacobian in its own axes (LOCAL, 6 × nv), by a pass from the frame down to the
    base in the frame's coordinates: with ᶠRₖ (link k's axes in the frame's) and dₖ (from link
    k's origin to the frame's, in the frame's axes), joint k's column is [ᶠRₖS_v + ᶠRₖS_ω × dₖ;
    ᶠRₖS_ω]; its parent's ᶠRₚ = ᶠRₖ·ᵖRₖᵀ and dₚ = dₖ + ᶠRₚ·ᵖoₖ.  No world pose is needed,
    and each joint costs a rotation step, a shift and a cross product."""
    tag = f"l{j + 1}"
    Rc = [[exact(x) for x in row[:3]] for row in frame.placement[:3]]
    pc = [exact(row[3]) for row in frame.placement[:3]]
    R = [[Rc[b][a] for b in range(3)] for a in range(3)]  # ᶠR of the link the frame is on: Rcᵀ
    d = tape.vector(_times(R, pc), f"d{tag}_{frame.link + 1}")
    nb = nv - len(links)
    cols = [[sp.S.Zero] * 6 for _ in range(nv)]
    k = frame.link
    while True:
        if k < 0:
            if kind is not None:  # the base body's own velocities, in its frame
                for c, (lin, ang) in enumerate(floating.columns(kind)):
                    w = _times(R, ang)
                    cols[c] = _plus(_times(R, lin), _cross(w, d)) + w
            break
        S = links[k].S
        w = _times(R, S[:3])
        lin = _plus(_times(R, S[3:]), _cross(w, d))
        cols[nb + k] = [tape.name(e, f"J{tag}_{nb + k + 1}{'xyz'[i]}") for i, e in enumerate(lin)] + w
        parent = links[k].parent
        Rt = [[links[k].R[b, a] for b in range(3)] for a in range(3)]
        R = _rot(tape, _matmul(R, Rt), f"R{tag}_{parent + 1}")
        d = tape.vector(_plus(d, _times(R, list(links[k].p))), f"d{tag}_{parent + 1}")
        k = parent
    return sp.ImmutableMatrix(6, nv, lambda r, c: cols[c][r])


def _composites(tape: Tape, robot: Robot, links) -> tuple[list, tuple]:
    """Each link's subtree — mass, first moment and inertia about the link's origin, in the link's
    own frame — accumulated from the leaves in (Khalil's composite links: a child's
    R·J·Rᵀ + M(|P|²1 − PPᵀ) + 2(P·S)1 − S·Pᵀ − P·Sᵀ with S = R·H, its first moment R·H + M·P),
    and the whole robot's in the base's frame (a floating base's body included)."""

    def own(link) -> list:
        m, r, Ic = _inertia(link)
        rr = sum(x * x for x in r)
        J = [[Ic[i][j] + m * ((rr if i == j else 0) - r[i] * r[j]) for j in range(3)] for i in range(3)]
        return [m, [m * x for x in r], J]

    acc: dict = {k: own(link) for k, link in enumerate(robot.links)}
    acc[-1] = own(robot.base_body) if robot.base_joint is not None and robot.base_body is not None else own(Link())
    out: list = [None] * robot.n
    for k in range(robot.n - 1, -1, -1):
        m, H, J = acc.pop(k)
        tag = f"{k + 1}"
        H = tape.vector(H, f"Hc{tag}")
        Jn = [[sp.S.Zero] * 3 for _ in range(3)]
        for i in range(3):
            for j in range(i, 3):
                Jn[i][j] = Jn[j][i] = tape.name(J[i][j], f"Jc{tag}_{i + 1}{j + 1}")
        out[k] = (m, H, Jn)
        R, P = rows(links[k].R), list(links[k].p)
        S = _times(R, H)
        RJR = turned_inertia(tape, R, Jn, tag)
        PS, PP = sum(a * b for a, b in zip(P, S)), sum(a * a for a in P)
        parent = acc[links[k].parent]
        parent[0] = parent[0] + m
        parent[1] = _plus(parent[1], S, _scale(P, m))
        for i in range(3):
            for j in range(i, 3):
                shift = (
                    m * ((PP if i == j else 0) - P[i] * P[j]) + (2 * PS if i == j else 0) - S[i] * P[j] - P[i] * S[j]
                )
                value = parent[2][i][j] + RJR[i][j] + shift
                parent[2][i][j] = parent[2][j][i] = value
    m, H, J = acc[-1]
    return out, (m, tape.vector(H, "Hc0"), J)


def _momentum(composite, lin, ang) -> tuple[list, list]:
    """(force, moment about the frame's origin) of a composite (mass, first moment, inertia about
    the origin) moving with the twist (lin, ang) of that frame: f = m·v + ω × H, n = H × v + J·ω."""
    m, H, J = composite
    return _plus(_scale(lin, m), _cross(ang, H)), _plus(_cross(H, lin), _times(J, ang))


def _columns(tape: Tape, robot: Robot, links, base: _Body, bodies: list[_Body], columns: list[_Column], total) -> tuple:
    """The centre of mass G (the whole robot's first moment over its mass) and the columns of its
    Jacobian and of A_G, from the composites: a joint moves
    its link's subtree with the joint's twist; the momentum in the link's frame, turned into the
    world's axes, is P (and M·J_c = P) and L about the link's origin, moved to the centre of mass
    G: L_G = L + (o − G) × P.  The base's columns move the whole robot."""
    subtrees, whole = _composites(tape, robot, links)
    G = tape.vector(_plus(base.o, _scale(_times(base.R, whole[1]), 1 / total)), "G")
    nb = len(columns) - robot.n
    Jcom, Ag = [], []
    for c, column in enumerate(columns):
        if c < nb:
            lin, ang = floating.columns(robot.base_joint)[c]
            f, n = _momentum(whole, lin, ang)
            R, o = base.R, base.o
        else:
            k = c - nb
            S = links[k].S
            f, n = _momentum(subtrees[k], S[3:], S[:3])
            R, o = bodies[k].R, bodies[k].o
        P = tape.vector(_times(R, f), f"P{c + 1}")
        arm = tape.vector(_plus(o, _scale(G, -1)), f"oG{c + 1}")
        L = _plus(_times(R, n), _cross(arm, P))
        Jcom.append(_scale(P, 1 / total))
        Ag.append(list(P) + L)
    return G, Jcom, Ag


def _inertia(link) -> tuple:
    """(m, r, Ic) of a link, exact (the upper triangle of I, mirrored)."""
    m = exact(link.m)
    r = [exact(x) for x in link.r]
    Ic = [[exact(link.I[min(i, j)][max(i, j)]) for j in range(3)] for i in range(3)]
    return m, r, Ic


def _rest_wrench(tape: Tape, robot: Robot, links) -> tuple[list, list]:
    """The total force and moment (about the base's origin, in the base's axes) that the bodies'
    motion takes at a = 0, without gravity: Newton–Euler in each link's own axes, outward (link k
    on parent p, Rᵀ turning p's axes into k's, joint axis S = (S_ω, S_v) in k's)
    ωₖ = Rᵀωₚ + S_ω q̇, ω̇ₖ = Rᵀω̇ₚ + Rᵀωₚ × S_ω q̇,
    aₖ = Rᵀ(aₚ + ω̇ₚ × p + ωₚ × (ωₚ × p)) + (Rᵀωₚ + ωₖ) × S_v q̇ (its origin's classical
    acceleration), each body's f = m a_c and n = I ω̇ + ω × I ω + c × f about its origin; then
    inward, each subtree's wrench turned into its parent's axes.  No body's world rotation or
    world inertia is formed: against the world-aligned sum it replaced, the Panda's Ȧ_G·v takes
    1 170 operations, not 1 552, and its com_drift 490, not 668 (generated/panda)."""
    _, qd, _ = joint_symbols(robot.n)
    zero = [sp.S.Zero] * 3
    kind = robot.base_joint
    if kind is None:
        state = {-1: (zero, zero, zero)}
    else:  # the base's body-frame twist; at a = 0 its origin accelerates by ω × v
        lin, ang = floating.spatial(kind, floating.base_symbols(kind)[1])
        state = {-1: (list(ang), zero, _cross(ang, lin))}
    for k, f in enumerate(links):
        wp, dwp, ap = state[f.parent]
        R, p, tag = rows(f.R), list(f.p), k + 1
        spin, slide = _scale(f.S[:3], qd[k]), _scale(f.S[3:], qd[k])
        wr = tape.vector(_times_t(R, wp), f"wr{tag}")
        w = tape.vector(_plus(wr, spin), f"wl{tag}")
        dw = tape.vector(_plus(_times_t(R, dwp), _cross(wr, spin)), f"dwl{tag}")
        ao = _plus(_times_t(R, _plus(ap, _cross(dwp, p), _cross(wp, _cross(wp, p)))), _cross(_plus(wr, w), slide))
        state[k] = (w, dw, tape.vector(ao, f"al{tag}"))

    def own(link, w, dw, ao) -> list:
        m, r, Ic = _inertia(link)
        f = _scale(_plus(ao, _cross(dw, r), _cross(w, _cross(w, r))), m)
        return [f, _plus(_times(Ic, dw), _cross(w, _times(Ic, w)), _cross(r, f))]

    total = {k: own(link, *state[k]) for k, link in enumerate(robot.links)}
    body = robot.base_body if kind is not None else None
    total[-1] = own(body, *state[-1]) if body is not None else [zero, zero]
    for k in range(robot.n - 1, -1, -1):
        f, n = total.pop(k)
        f, n = tape.vector(f, f"Fl{k + 1}"), tape.vector(n, f"Nl{k + 1}")
        R, p = rows(links[k].R), list(links[k].p)
        Rf = _times(R, f)
        parent = total[links[k].parent]
        total[links[k].parent] = [_plus(parent[0], Rf), _plus(parent[1], _times(R, n), _cross(p, Rf))]
    return total[-1]


def _centroidal(tape: Tape, robot: Robot, links, base: _Body, bodies: list[_Body], columns: list[_Column]) -> dict:
    """Centre of mass, its Jacobian and drift, the centroidal map A_G and Ȧ_G·v (about the centre
    of mass, world axes), every body counted (a floating base's body too), rotors not.  Moments
    are taken about the base's origin o₀ (well-conditioned far from the world's origin)."""
    nv, total = len(columns), _total_mass(robot)
    if total == 0:
        return {}
    com, Jcom, Ag = _columns(tape, robot, links, base, bodies, columns, total)
    g = tape.vector(_plus(com, _scale(base.o, -1)), "cg")  # G − o₀
    # Ȧ_G·v = d/dt h_G at a = 0: Σ m a_c and Σ [I ω̇ + ω × I ω + m (c − G) × a_c]
    f, n = _rest_wrench(tape, robot, links)
    force = tape.vector(_times(base.R, f), "mac")
    moment = _plus(_times(base.R, n), _scale(_cross(g, force), -1))
    return {
        "com": sp.ImmutableMatrix(com),
        "com_jacobian": sp.ImmutableMatrix(3, nv, lambda i, c: Jcom[c][i]),
        "com_drift": sp.ImmutableMatrix(_scale(force, 1 / total)),
        "centroidal_map": sp.ImmutableMatrix(6, nv, lambda i, c: Ag[c][i]),
        "centroidal_drift": sp.ImmutableMatrix(list(force) + moment),
    }
