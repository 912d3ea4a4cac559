"""The task space in closed form, as a textbook prints it: each frame's forward kinematics
(x = a1·C1 + a2·C12 …, the rotation's entries) and its Jacobian, LOCAL_WORLD_ALIGNED.

A consumer of derivations beside `printing`: the task-space derivation's expressions written
out (`TaskSpace.full`), tidied in the book form of the dynamics they come with
(`derivation.simplify.tidy`: products of sines and cosines of natural angles), rendered by
`printing.render` (text, pretty or LaTeX).
"""

from __future__ import annotations

import dataclasses

import sympy as sp

from ..derivation.dynamics import Dynamics
from ..derivation.simplify import tidy
from ..derivation.task_space import task_space
from ..model.frames import IDENTITY
from .constants import abbreviation
from .printing import _display, number, render

__all__ = ["in_base_axes", "frame_elements", "frames_form", "frames_constant_form"]


def in_base_axes(robot):
    """A floating-base robot with its base held at the origin: its frames' poses and Jacobians
    are the floating robot's in the base body's axes, functions of the joints alone."""
    return dataclasses.replace(robot, base_joint=None, base_body=None, base=IDENTITY, urdf=None, mjcf=None)


def frame_elements(dyn: Dynamics, form: str = "book") -> list[tuple[str, list]]:
    """[(frame name, [(element name, expr)])]: x, y, z of the frame's origin in the world, its
    rotation R11 … R33, and its Jacobian's non-zero entries J11 … (rows vx, vy, vz, wx, wy, wz).
    On a floating base, all of them in the base body's axes (`in_base_axes`), the Jacobian's
    columns the joints': the world's follow by the base's pose (`frames_form` says how)."""
    ts = task_space(in_base_axes(dyn.robot) if dyn.robot.base_joint is not None else dyn.robot)
    pose, J = ts.full("frame_pose"), ts.full("frame_jacobian_aligned")
    out = []
    for j, frame in enumerate(ts.frames):
        items = []
        for i, axis in enumerate("xyz"):
            items.append((axis, _display(tidy(pose[4 * j + i, 3], dyn, form))))
        for r in range(3):
            for c in range(3):
                items.append((f"R{r + 1}{c + 1}", _display(tidy(pose[4 * j + r, c], dyn, form))))
        for r in range(6):
            for c in range(J.cols):
                value = J[6 * j + r, c]
                if value != 0:
                    items.append((f"J{r + 1}_{c + 1}", _display(tidy(value, dyn, form))))
        out.append((frame.name, items))
    return out


def frames_form(dyn: Dynamics, fmt: str = "text", *, digits: int = 5, form: str = "book") -> str:
    """Every task frame's forward kinematics and Jacobian, rendered (`frame_elements`)."""
    comment = "%" if fmt == "latex" else "#"
    blocks = []
    floating = dyn.robot.base_joint is not None
    for name, items in frame_elements(dyn, form):
        link = next(f.link for f in dyn.robot.task_frames if f.name == name)
        on = "the base" if link < 0 else f"link {link + 1}"
        where = "the base body's axes (below)" if floating else "the world"
        head = (
            f"{comment} frame {name!r} on {on}: its origin (x, y, z) and rotation R in {where}; its Jacobian "
            "J (rows vx vy vz wx wy wz, LOCAL_WORLD_ALIGNED; zero entries not shown"
            + ("; columns: the joints')" if floating else ")")
        )
        blocks.append(head + "\n" + render(items, fmt, digits=digits, document=False))
    if floating:
        blocks.append(_base_note(dyn.robot, comment))
    return "\n\n".join(blocks)


def _base_note(robot, comment: str) -> str:
    """How a floating base's frames printed in its axes are placed in the world."""
    if robot.base_joint == "free":
        turn = (
            "R0 the rotation of the quaternion u = (base_qx, base_qy, base_qz), w = base_qw: "
            "R0 = 1 + 2/|q|^2 (w [u×] + [u×]^2)"
        )
        base = "p0 = (base_x, base_y, base_z)"
        twist = "v = (base velocity, angular velocity) in the base's axes"
    else:
        turn = "R0 the turn by base_yaw about z"
        base = "p0 = (base_x, base_y, 0)"
        twist = "v = (vx, vy, 0) and angular velocity (0, 0, wz) in the base's axes"
    lines = [
        f"the base at {base}, turned by {turn}: in the world,",
        "  origin p0 + R0 (x, y, z), rotation R0 R, and Jacobian",
        "  [[R0, -R0 [p×], R0 J_lin], [0, R0, R0 J_ang]] with p = (x, y, z) and J = [J_lin; J_ang] above,",
        f"  its first columns the base's: {twist}",
    ]
    if robot.base != IDENTITY:  # the world's frame {0} placed by robot.base
        lines.append(
            f"  all of it then placed by the robot's base B = {[[float(x) for x in row] for row in robot.base]}"
        )
    return "\n".join(f"{comment} {line}" for line in lines)


def _named_lengths(robot) -> tuple:
    """The robot with its non-zero DH lengths a_i, d_i as symbols a1, d3, … (numbers elsewhere),
    and {symbol: value}: named as the convention's table names them (modified DH, Craig's: link
    i holds a_{i-1}, so the Puma's 0.4318 m is a2)."""
    values: dict = {}
    links = []
    shift = 1 if robot.convention == "modified" else 0
    for i, link in enumerate(robot.links, start=1):
        fields = {}
        for name in ("a", "d"):
            value = getattr(link, name)
            if name == "d" and not link.is_revolute:
                continue  # a prismatic joint's d is its coordinate
            if isinstance(value, (int, float)) and value != 0:
                sym = sp.Symbol(f"{name}{i - shift if name == 'a' else i}", real=True)
                values[sym] = value
                fields[name] = sym
        links.append(dataclasses.replace(link, **fields))
    return dataclasses.replace(robot, links=tuple(links)), values


def frames_constant_form(dyn: Dynamics, fmt: str = "text", *, digits: int = 5) -> str:
    """Each task frame's origin and rotation in named constants — the DH lengths a_i, d_i with
    their values — and trig abbreviations (C1 = cos q1, S23 = sin(q2 + q3)), as Paul's and
    Craig's tables print a DH arm's forward kinematics.

    Raises:
        ValueError: a robot that is not in DH form (its lengths are a general joint's origins).
    """
    robot = dyn.robot
    if robot.convention == "general":
        raise ValueError(
            f"named constants of {robot.name!r}'s frames: they name DH lengths (a_i, d_i), and its joints are "
            "placed by general origins; print its frames without --constants"
        )
    named, values = _named_lengths(robot)
    ts = task_space(named)
    pose = ts.full("frame_pose")
    abbreviations: dict = {}
    comment = "%" if fmt == "latex" else "#"
    blocks = []
    for j, frame in enumerate(ts.frames):
        items = []
        names = [("x", 0, 3), ("y", 1, 3), ("z", 2, 3)] + [
            (f"R{r + 1}{c + 1}", r, c) for r in range(3) for c in range(3)
        ]
        for label, r, c in names:
            expr = tidy(pose[4 * j + r, c], dyn, "book")
            atoms = expr.atoms(sp.sin, sp.cos)
            for atom in atoms:
                abbreviations.setdefault(abbreviation(atom), atom)
            items.append((label, sp.collect(expr.xreplace({a: abbreviation(a) for a in atoms}), list(values))))
        on = "the base" if frame.link < 0 else f"link {frame.link + 1}"
        blocks.append(
            f"{comment} frame {frame.name!r} on {on}: origin and rotation in the world\n"
            + render(items, fmt, digits=digits, document=False)
        )
    where = ", ".join(f"{s} = {number(float(v), digits)} m" for s, v in values.items())
    order = sorted(abbreviations, key=lambda s: (s.name[0] == "S", len(s.name), s.name))
    abbr = ", ".join(f"{s} = {abbreviations[s]}" for s in order)
    where = f"\n{comment} where {where}" if where else ""  # a symbolic arm's lengths are named already
    return "\n\n".join(blocks) + where + f"\n{comment} {abbr}"
