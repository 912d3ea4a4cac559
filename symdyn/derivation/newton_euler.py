"""Symbolic recursive Newton–Euler, customized (Khalil): the second route.

Khalil's form of the recursion, in modified-DH frames (a standard-DH robot
is re-expressed first by `kinematics.along_z`, which changes no joint
quantity): inertia about the body origin and first moments of mass (no COM
accelerations), no linear velocities, exact constants, products
with exact zeros and ones skipped, and every non-trivial intermediate given
a name on a `Tape` as it is formed (w2_z, dv3_x, f4_y, …), so the result is
a DAG, never one big tree.  M comes from unit accelerations, G from zero
motion, C from unit velocities with the cross terms split symmetrically
(which is exactly the Christoffel C).  On a tree each link's motion comes
from its parent and its force goes to its parent; M's entries between
branches are exact zeros, never computed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from .dynamics import Dynamics, friction_expr, rotor_inertia
from .kinematics import LinkFrame, along_z, ancestors, link_frames
from ..model import Link, Robot
from . import floating
from .progress import Progress, silent
from .symbols import exact, joint_symbols
from .tape import Tape


# --------------------------------------------------------------------------- small vector algebra


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _add(*vs):
    return [sp.Add(*(v[k] for v in vs)) for k in range(3)]


def _matvec(M, v):
    return [sp.Add(*(M[i, j] * v[j] for j in range(3))) for i in range(3)]


def _tmatvec(M, v):
    return [sp.Add(*(M[j, i] * v[j] for j in range(3))) for i in range(3)]


def _scale(v, s):
    return [x * s for x in v]


def _dot(a, b):
    return sp.Add(*(x * y for x, y in zip(a, b)))


# --------------------------------------------------------------------------- inertial parameters


@dataclass(frozen=True)
class LinkInertia:
    """Khalil's standard parameters of one link: inertia about the body origin
    Io (3×3), first moment h = m·r, mass m, rotor inertia Ia = G²·Jm."""

    Io: sp.Matrix
    h: tuple
    m: sp.Expr
    Ia: sp.Expr


def link_inertias(robot: Robot) -> list[LinkInertia]:
    """Standard parameters of every link, exact (floats become rationals)."""
    return [_inertia(link, Ia) for link, Ia in zip(robot.links, rotor_inertia(robot))]


def base_inertia(robot: Robot) -> LinkInertia:
    """Standard parameters of the body a base joint moves (massless when the robot gives none)."""
    return _inertia(robot.base_body or Link(), 0)


def _inertia(link: Link, Ia) -> LinkInertia:
    m = exact(link.m)
    r = [exact(x) for x in link.r]
    # the upper triangle, mirrored: an inertia symmetric to rounding is read as exactly symmetric,
    # as the regressor's XY, XZ, YZ parameters read it
    Ic = sp.Matrix(3, 3, lambda i, j: exact(link.I[min(i, j)][max(i, j)]))
    rr = sum(x * x for x in r)
    Io = sp.Matrix(3, 3, lambda i, j: sp.expand(Ic[i, j] + m * ((rr if i == j else 0) - r[i] * r[j])))
    return LinkInertia(Io=Io, h=tuple(sp.expand(m * x) for x in r), m=m, Ia=Ia)


# --------------------------------------------------------------------------- the recursion


@dataclass
class Motion:
    """Angular velocity w and acceleration dw, the classical acceleration dV
    of the body origin (gravity included) and U = dw× + w×w× (9 entries,
    row-major), all named; Khalil's customized recursion needs no linear
    velocity."""

    w: list
    dw: list
    dV: list
    U: list


def _u_times(U, x):
    return [sp.Add(*(U[3 * i + j] * x[j] for j in range(3))) for i in range(3)]


def _named_u(tape: Tape, w, dw, tag: str, k) -> list:
    """U = dw× + w×w× (row-major), its entries and w's squares and products named."""
    sq = [tape.name(w[a] * w[a], f"{tag}w{k}{'xyz'[a]}2") for a in range(3)]
    wxy = tape.name(w[0] * w[1], f"{tag}w{k}xy")
    wxz = tape.name(w[0] * w[2], f"{tag}w{k}xz")
    wyz = tape.name(w[1] * w[2], f"{tag}w{k}yz")
    U = [
        -(sq[1] + sq[2]),
        wxy - dw[2],
        wxz + dw[1],
        wxy + dw[2],
        -(sq[0] + sq[2]),
        wyz - dw[0],
        wxz - dw[1],
        wyz + dw[0],
        -(sq[0] + sq[1]),
    ]
    return [
        tape.name(u, f"{tag}U{k}_{r}{c}") for u, (r, c) in zip(U, [(r, c) for r in range(1, 4) for c in range(1, 4)])
    ]


def base_motion(tape: Tape, kind: str, v, a, g, tag: str = "") -> Motion:
    """The motion of the body a base joint of `kind` moves, from its velocity v and acceleration a
    in v's order (its frame) and the upward acceleration g in its frame: the classical
    acceleration of its origin is v̇ + ω × v + g."""
    lin, w = floating.spatial(kind, v)
    dlin, dw = floating.spatial(kind, a)
    w, dw = tape.vector(w, f"{tag}w0"), tape.vector(dw, f"{tag}dw0")
    dV = tape.vector(_add(dlin, _cross(w, lin), g), f"{tag}dV0")
    return Motion(w, dw, dV, _named_u(tape, w, dw, tag, 0))


def forward(
    tape: Tape, frames: Sequence[LinkFrame], qd, qdd, g0, tag: str = "", base: Motion | None = None
) -> list[Motion]:
    """Outward pass in modified-DH frames (joint axis = z of the body frame): each
    link's motion from its parent's (`LinkFrame.parent`; a tree's branches apart).

    g0 is the base's upward acceleration in frame {0} (Corke's gravity,
    rotated by the base); the base itself is at rest, unless `base` gives the
    motion of the body a base joint moves (`base_motion`, gravity included).
    """
    at_rest = base or Motion([0, 0, 0], [0, 0, 0], list(g0), [0] * 9)
    out: list[Motion] = []
    for i, f in enumerate(frames):
        k = i + 1
        if f.S != (0, 0, 1, 0, 0, 0) and f.S != (0, 0, 0, 0, 0, 1):
            raise ValueError(
                "the customized recursion needs modified-DH frames (joint axis = z); convert with robot.to_modified()"
            )
        parent = at_rest if f.parent < 0 else out[f.parent]
        w, dw, dV, U = parent.w, parent.dw, parent.dV, parent.U
        revolute = f.S[2] == 1
        wI = tape.vector(_tmatvec(f.R, w), f"{tag}wi{k}")
        dwI = _tmatvec(f.R, dw)
        dV = _tmatvec(f.R, _add(dV, _u_times(U, list(f.p))))
        if revolute:
            w = tape.vector([wI[0], wI[1], wI[2] + qd[i]], f"{tag}w{k}")
            dw = tape.vector([dwI[0] + wI[1] * qd[i], dwI[1] - wI[0] * qd[i], dwI[2] + qdd[i]], f"{tag}dw{k}")
        else:
            w, dw = wI, tape.vector(dwI, f"{tag}dw{k}")
            dV = [dV[0] + 2 * wI[1] * qd[i], dV[1] - 2 * wI[0] * qd[i], dV[2] + qdd[i]]
        dV = tape.vector(dV, f"{tag}dV{k}")
        out.append(Motion(w, dw, dV, _named_u(tape, w, dw, tag, k)))
    return out


def body_force(tape: Tape, mo: Motion, inertia: LinkInertia, tag: str, k: int) -> tuple[list, list]:
    """Force f = m·dV + U·h and moment n = Io·dw + w × (Io·w) + h × dV of body k
    about its origin (Khalil); Io·w is named {tag}K{k}."""
    Io, h, m = inertia.Io, list(inertia.h), inertia.m
    K = tape.vector(_matvec(Io, mo.w), f"{tag}K{k}")
    n = _add(_matvec(Io, mo.dw), _cross(mo.w, K), _cross(h, mo.dV))
    f = _add(_scale(mo.dV, m), _u_times(mo.U, h))
    return n, f


def backward(
    tape: Tape,
    frames: Sequence[LinkFrame],
    forces: list,
    qdd,
    inertias,
    tag: str = "",
    last: int | None = None,
    base: list | None = None,
) -> list:
    """Inward pass: joint forces τᵢ = Sᵢ·fᵢ (+ rotor inertia), each link's force added to
    its parent's (`LinkFrame.parent`); `forces[i]` is body i's own (n, f) or None.  Links
    after `last` carry nothing; a link that no force reaches has τᵢ exactly 0 (with the
    rotor term, when it has one) and nothing named.  `base`, the [n, f] of the body a
    base joint moves, receives the forces of the links on it (in place)."""
    n_links = len(frames)
    last = n_links - 1 if last is None else last
    tau = [sp.S.Zero] * n_links
    carried: list = [None] * n_links  # (n, f) handed in by the children, in link i's frame
    for i in range(last, -1, -1):
        k = i + 1
        if forces[i] is None and carried[i] is None:
            tau[i] = inertias[i].Ia * qdd[i]
            continue
        n_acc, f_acc = carried[i] or ([0, 0, 0], [0, 0, 0])
        if forces[i] is not None:
            n_acc, f_acc = _add(n_acc, forces[i][0]), _add(f_acc, forces[i][1])
        n_i = tape.vector(n_acc, f"{tag}n{k}")
        f_i = tape.vector(f_acc, f"{tag}f{k}")
        S = frames[i].S
        tau[i] = _dot(S[:3], n_i) + _dot(S[3:], f_i) + inertias[i].Ia * qdd[i]
        parent = frames[i].parent
        if parent >= 0 or base is not None:
            R, p = frames[i].R, frames[i].p
            f_up = _matvec(R, f_i)
            n_up = _add(_matvec(R, n_i), _cross(list(p), f_up))
            if parent < 0:
                base[0], base[1] = _add(base[0], n_up), _add(base[1], f_up)
                continue
            if carried[parent] is not None:
                n_up, f_up = _add(carried[parent][0], n_up), _add(carried[parent][1], f_up)
            carried[parent] = (n_up, f_up)
    return tau


def rnea(tape: Tape, frames, inertias, qd, qdd, g0, tag: str = "", floating_base=None) -> list:
    """Joint forces of the whole recursion (no friction), as named expressions.  A floating
    base: `floating_base` = (kind, its inertia, v, v̇, upward acceleration in its frame), and
    the base joint's rows come first (`floating.rows`)."""
    base_mo = None if floating_base is None else base_motion(tape, floating_base[0], *floating_base[2:], tag=tag)
    motions = forward(tape, frames, qd, qdd, g0, tag, base=base_mo)
    forces = [body_force(tape, mo, I, tag, i + 1) for i, (mo, I) in enumerate(zip(motions, inertias))]
    if floating_base is None:
        return backward(tape, frames, forces, qdd, inertias, tag)
    total = list(body_force(tape, base_mo, floating_base[1], tag, 0))
    tau = backward(tape, frames, forces, qdd, inertias, tag, base=total)
    n0, f0 = tape.vector(total[0], f"{tag}n0"), tape.vector(total[1], f"{tag}f0")
    return floating.rows(floating_base[0], f0, n0) + tau


def composite_inertia(tape: Tape, frames: Sequence[LinkFrame], inertias, tag: str = "c", base=None) -> list:
    """Joint-space inertia M by the customized composite-link algorithm.

    Composite parameters (J, MS, m) are accumulated from the tips in each
    link's frame, each child's added to its parent's (`LinkFrame.parent`):
    J_j += R Jc Rᵀ + m(|P|²1 − PPᵀ) + 2(P·S′)1 − S′Pᵀ − PS′ᵀ with
    S′ = R·MSc; then column j's force Ic·S_j is carried down through the
    links j hangs from, M_ij = S_i·(n, f).  M_ij of joints on different
    branches of a tree (neither hangs from the other) is exactly 0 and costs
    nothing.  Named entries keep it a DAG; returns M as n×n lists.  A floating
    base, `base` = (kind, its inertia): the whole robot's composite on the base
    body gives the base block, every column is carried on to the base body, and
    the base joint's rows and columns come first.
    """
    n = len(frames)
    children: list[list[int]] = [[] for _ in range(n + 1)]  # the last: the links on the base
    for c in range(n):
        children[frames[c].parent].append(c)
    J = [None] * n
    MS = [None] * n
    mass = [None] * n

    def composite(k, own: LinkInertia, kids):
        Jj, MSj, mj = sp.Matrix(own.Io), list(own.h), own.m
        for c in kids:
            R, P = frames[c].R, list(frames[c].p)
            Jc, S, m = J[c], MS[c], mass[c]
            RJ = R * Jc
            RJR = sp.Matrix(3, 3, lambda a, b: sp.Add(*(RJ[a, c] * R[b, c] for c in range(3))) if a <= b else 0)
            Sp = tape.vector(_matvec(R, S), f"{tag}S{c + 1}")
            PS = _dot(P, Sp)
            PP = _dot(P, P)
            for a in range(3):
                for b in range(a, 3):
                    shift = m * ((PP if a == b else 0) - P[a] * P[b])
                    shift += (2 * PS if a == b else 0) - Sp[a] * P[b] - P[a] * Sp[b]
                    Jj[a, b] = Jj[a, b] + RJR[a, b] + shift
            MSj = _add(MSj, Sp, _scale(P, m))
            mj = mj + m
        for a in range(3):
            for b in range(a, 3):
                Jj[a, b] = tape.name(Jj[a, b], f"{tag}J{k}_{'xyz'[a]}{'xyz'[b]}")
                Jj[b, a] = Jj[a, b]
        return Jj, tape.vector(MSj, f"{tag}MS{k}"), tape.name(mj, f"{tag}m{k}")

    for j in range(n - 1, -1, -1):
        J[j], MS[j], mass[j] = composite(j + 1, inertias[j], children[j])
    nb = 0 if base is None else len(floating.columns(base[0]))
    M = [[sp.S.Zero] * (nb + n) for _ in range(nb + n)]
    for j in range(n):
        revolute = frames[j].S[2] == 1
        if revolute:
            nn, ff = [J[j][0, 2], J[j][1, 2], J[j][2, 2]], [-MS[j][1], MS[j][0], 0]
        else:
            nn, ff = [MS[j][1], -MS[j][0], 0], [0, 0, mass[j]]
        M[nb + j][nb + j] = (nn[2] if revolute else ff[2]) + inertias[j].Ia
        child, i = j, frames[j].parent
        while i >= 0 or (base is not None and child >= 0):
            R, P = frames[child].R, list(frames[child].p)
            ff = tape.vector(_matvec(R, ff), f"{tag}f{j + 1}_{i + 1}")
            nn = tape.vector(_add(_matvec(R, nn), _cross(P, ff)), f"{tag}n{j + 1}_{i + 1}")
            if i < 0:  # on the base body: the base joint's rows of column j
                for r, value in enumerate(floating.rows(base[0], ff, nn)):
                    M[r][nb + j] = M[nb + j][r] = value
                break
            M[nb + i][nb + j] = M[nb + j][nb + i] = nn[2] if frames[i].S[2] == 1 else ff[2]
            child, i = i, frames[i].parent
    if base is not None:  # the whole robot on the base body: f = m v + ω × MS, n = MS × v + J ω
        Jb, MSb, mb = composite(0, base[1], children[-1])
        for c, (lin, ang) in enumerate(floating.columns(base[0])):
            f = _add(_scale(lin, mb), _cross(ang, MSb))
            moment = _add(_cross(MSb, lin), _matvec(Jb, ang))
            for r, value in enumerate(floating.rows(base[0], f, moment)):
                M[r][c] = value
    return M


def _related(parents) -> set:
    """Pairs (j, k), j < k, of joints one of which hangs from the other: the pairs whose
    M_jk and Christoffel symbols Γ_ijk can differ from 0 (on a chain, every pair)."""
    return {(min(j, k), max(j, k)) for k in range(len(parents)) for j in ancestors(parents, k) if j != k}


def gravity_in_base(robot: Robot) -> list:
    """Corke's gravity (base upward acceleration, world) expressed in frame {0}."""
    R = sp.Matrix([[exact(x) for x in row[:3]] for row in robot.base[:3]])
    return list(R.T * sp.Matrix([exact(x) for x in robot.gravity]))


# --------------------------------------------------------------------------- M, C, G, τ


@dataclass(frozen=True)
class Recursion:
    """The named programs of one Newton–Euler derivation: the tape and the
    outputs of each term in terms of its names."""

    tape: Tape
    outputs: dict


def recursion(
    robot: Robot,
    inertias: Sequence[LinkInertia] | None = None,
    progress: Progress | None = None,
    christoffel: bool = True,
    body: LinkInertia | None = None,
) -> Recursion:
    """Run the customized recursion for τ, G (rest), C·q̇, M by composite links, and
    (`christoffel`) the Christoffel symbols (unit velocities, symmetric split):
    n(n + 1)/2 more recursions, the only part that grows like n³.  A floating base
    (`floating`): its rows and columns first, its body's parameters `body` (default the
    robot's, `base_inertia`; regrouped ones from `regressor.regrouped_base_body`); no
    Christoffel symbols (its velocities are no coordinates' rates)."""
    n = robot.n
    q, qd, qdd = joint_symbols(n)
    robot = along_z(robot)
    frames = link_frames(robot, q)
    inertias = link_inertias(robot) if inertias is None else list(inertias)
    tape = Tape()
    zero, none = [0] * n, [0, 0, 0]
    g0 = gravity_in_base(robot)
    unit = lambda j: [1 if i == j else 0 for i in range(n)]  # noqa: E731
    progress = progress or silent()

    kind = robot.base_joint
    if kind is not None:  # the body a base joint moves: its velocity, acceleration and gravity in its frame
        qb, vb, ab = floating.base_symbols(kind)
        gb = tape.vector(list(floating.base_rotation(kind, qb).T * sp.Matrix(g0)), "gb")
        body, rest = base_inertia(robot) if body is None else body, [0] * len(vb)
        tau = rnea(tape, frames, inertias, qd, qdd, g0, floating_base=(kind, body, vb, ab, gb))
        progress.step("tau")
        G = rnea(tape, frames, inertias, zero, zero, g0, tag="g", floating_base=(kind, body, rest, rest, gb))
        progress.step("G")
        Cqd = rnea(tape, frames, inertias, qd, zero, none, tag="c", floating_base=(kind, body, vb, rest, none))
        M = composite_inertia(tape, frames, inertias, base=(kind, body))
        progress.step("M")
        return Recursion(tape=tape, outputs={"tau": tau, "M": M, "G": G, "Cqd": Cqd})
    tau = rnea(tape, frames, inertias, qd, qdd, g0)
    progress.step("tau")
    G = rnea(tape, frames, inertias, zero, zero, g0, tag="g")
    progress.step("G")
    Cqd = rnea(tape, frames, inertias, qd, zero, none, tag="c")
    M = composite_inertia(tape, frames, inertias)
    progress.step("M")
    if not christoffel:
        return Recursion(tape=tape, outputs={"tau": tau, "M": M, "G": G, "Cqd": Cqd})
    h = {}
    for j in range(n):
        h[j, j] = rnea(tape, frames, inertias, unit(j), zero, none, tag=f"h{j + 1}")
        progress.step(f"Christoffel {j + 1}{j + 1}")
    gamma = {}
    related = _related(robot.parents)
    for j in range(n):
        gamma[j, j] = h[j, j]
        for k in range(j + 1, n):
            if (j, k) not in related:  # different branches of a tree: Γ_ijk = 0 for every i
                gamma[j, k] = gamma[k, j] = [sp.S.Zero] * n
                continue
            both = rnea(
                tape, frames, inertias, [a + b for a, b in zip(unit(j), unit(k))], zero, none, tag=f"h{j + 1}{k + 1}"
            )
            progress.step(f"Christoffel {j + 1}{k + 1}")
            gamma[j, k] = gamma[k, j] = [(b - x - y) / 2 for b, x, y in zip(both, h[j, j], h[k, k])]
    C = [[sp.Add(*(gamma[i, j][r] * qd[i] for i in range(n))) for j in range(n)] for r in range(n)]
    return Recursion(tape=tape, outputs={"tau": tau, "M": M, "G": G, "C": C, "Cqd": Cqd, "Gamma": gamma})


def derive(
    robot: Robot,
    inertias: Sequence[LinkInertia] | None = None,
    *,
    progress: bool = False,
    christoffel: bool = True,
    body: LinkInertia | None = None,
) -> Dynamics:
    """Closed-form dynamics by Newton–Euler: M, C, G, F and τ written in the
    recursion's named intermediates (plain sympy matrices on request).
    christoffel=False leaves C out of the recursion (`Dynamics.C` is then
    ½ ∂(C q̇)/∂q̇, the same matrix).  A floating base puts its coordinates, velocities and
    rows first (q of size nq, v and τ of size nv) and takes C as ½ ∂(C v)/∂v plus its
    velocities' brackets (`floating.bracket_term`); `body` gives its body's parameters
    (default the robot's)."""
    n = robot.n
    christoffel = christoffel and robot.base_joint is None
    bar = Progress(
        f"newton-euler {robot.name}", 3 + (n + len(_related(robot.parents)) if christoffel else 0), enabled=progress
    )
    rec = recursion(robot, inertias, bar, christoffel, body)
    bar.done()
    q, qd, qdd = joint_symbols(robot.n)
    F = friction_expr(robot, qd)
    if robot.base_joint is not None:
        qb, vb, ab = floating.base_symbols(robot.base_joint)
        q, qd, qdd = qb + q, vb + qd, ab + qdd
        F = sp.ImmutableMatrix([0] * len(vb) + list(F))
    outs = rec.outputs
    named = {
        "M": sp.ImmutableMatrix(outs["M"]),
        "G": sp.ImmutableMatrix(outs["G"]),
        "Cqd": sp.ImmutableMatrix(outs["Cqd"]),
        "F": F,
        "tau": sp.ImmutableMatrix(outs["tau"]) + F,
    }
    if christoffel:
        named["C"] = sp.ImmutableMatrix(outs["C"])
    return Dynamics(
        robot=robot,
        method="newton-euler",
        q=q,
        qd=qd,
        qdd=qdd,
        F=F,
        definitions=tuple(rec.tape.defs.items()),
        named=named,
    )
