"""The task space in closed form, as a textbook prints it: each frame's forward kinematics
(x = a1·C1 + a2·C12 …, the rotation's entries) and its Jacobian, LOCAL_WORLD_ALIGNED.

A consumer of derivations beside `printing`: the task-space derivation's expressions written
out (`TaskSpace.full`), tidied in the book form of the dynamics they come with
(`derivation.simplify.tidy`: products of sines and cosines of natural angles), rendered by
`printing.render` (text, pretty or LaTeX).
"""

from __future__ import annotations

from ..derivation.dynamics import Dynamics
from ..derivation.simplify import tidy
from ..derivation.task_space import task_space
from .printing import _display, render

__all__ = ["frame_elements", "frames_form"]


def frame_elements(dyn: Dynamics, form: str = "book") -> list[tuple[str, list]]:
    """[(frame name, [(element name, expr)])]: x, y, z of the frame's origin in the world, its
    rotation R11 … R33, and its Jacobian's non-zero entries J11 … (rows vx, vy, vz, wx, wy, wz)."""
    ts = task_space(dyn.robot)
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
    for name, items in frame_elements(dyn, form):
        link = next(f.link for f in dyn.robot.task_frames if f.name == name)
        on = "the base" if link < 0 else f"link {link + 1}"
        head = (
            f"{comment} frame {name!r} on {on}: its origin (x, y, z) and rotation R in the world; its Jacobian "
            "J (rows vx vy vz wx wy wz, LOCAL_WORLD_ALIGNED; zero entries not shown)"
        )
        blocks.append(head + "\n" + render(items, fmt, digits=digits, document=False))
    return "\n\n".join(blocks)
