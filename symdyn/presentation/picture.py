"""A picture of a robot as read: what a new user looks at to know a file was read as they meant.

Presentation of the model, before any derivation (its frames are the numeric reference's): `plot(robot)` (also `robot.plot()`) draws
the skeleton in 3-D at q = 0 — the chain from base to tip highlighted, each
joint's axis, each moving link's centre of mass and its inertia as the uniform
ellipsoid of the same mass and principal moments, the task frames (`robot.task_frames`) as
named triads — and, for a robot read from a
URDF, the whole tree (`robot.urdf.skeleton`): the locked branches merged into the
links they ride on, the excluded subtrees and the links above the base, each
marked.  `symdyn show FILE --out robot.png` writes it.  Needs matplotlib (the
`plot` extra), imported when a picture is drawn.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..numeric.reference import body_frames

__all__ = ["plot", "frames", "ellipsoid_axes"]

#: Colours and labels of a URDF bone's role (`symdyn.model.urdf.Bone.role`).
ROLES = {
    "chain": ("tab:blue", "chain (moving)"),
    "riding": ("tab:gray", "locked or fixed, merged into the link it rides on"),
    "excluded": ("tab:red", "excluded (left out)"),
    "above": ("silver", "above the base (fixed)"),
}


def frames(robot: Any, q: Sequence[float] | None = None) -> list[np.ndarray]:
    """The 4×4 frames (floats) of the base, of each link and of the tool, in the world, at q
    (default 0): base, then each link's frame (its parent's · A_i: base·A1, base·A1·A2, … for a
    chain), then the last link's · tool.  q: the joints (n), or a floating base's whole q (nq),
    whose base coordinates place the base body (default: at the origin).

    Raises:
        ValueError: a symbolic robot (substitute its parameters first), or q of the wrong length.
    """
    robot.require_numeric("a picture")
    q = np.zeros(robot.n) if q is None else np.asarray(q, dtype=float)
    if q.shape == (robot.n,) and robot.nq != robot.n:  # the joints only: the base where q0 puts it
        q = np.concatenate([robot.neutral()[: robot.nq - robot.n], q])
    if q.shape != (robot.nq,):
        sizes = f"{robot.n} entries (one per joint)" + (
            f" or {robot.nq} (q with the base's)" if robot.nq != robot.n else ""
        )
        raise ValueError(f"q must have {sizes}, got shape {q.shape}")
    bodies = list(body_frames(robot, q))
    return bodies + [bodies[-1] @ np.array(robot.tool, dtype=float)]


def ellipsoid_axes(m: float, I: Sequence | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(semi-axes, rotation) of the uniform solid ellipsoid with mass m and inertia I about its
    centre: a_i = sqrt(5 (I_j + I_k − I_i) / (2 m)), axes the principal axes (columns).

    Raises:
        ValueError: m is not positive.
    """
    if not m > 0:
        raise ValueError(f"an inertia ellipsoid needs a positive mass, got {m}")
    eig, R = np.linalg.eigh(np.array(I, dtype=float))
    total = eig.sum()
    semi = np.sqrt(np.maximum(5.0 * (total - 2.0 * eig) / (2.0 * m), 0.0))
    return semi, R


def plot(robot: Any, q: Sequence[float] | None = None, *, ax: Any = None, title: str | None = None) -> Any:
    """A matplotlib Figure of `robot` at q (default 0; URDF branches at their locked values).

    Chain links in blue with each joint's axis (an arrow at the joint, its length a fifth of
    the arm's reach; revolute solid, prismatic dashed), centres of mass as dots, inertia
    ellipsoids (the uniform solid of the same mass and principal moments) as wireframes; for a
    robot read from a URDF at q = 0, every other link of the file marked by its role (locked
    and merged, excluded, above the base) with its locked joints as crosses.  ax: a 3-D Axes
    to draw into (default: a new figure).

    Raises:
        ImportError: matplotlib is missing (pip install 'symdyn[plot]').
        ValueError: a symbolic robot, or q of the wrong length.
    """
    try:
        from matplotlib.figure import Figure
        from mpl_toolkits.mplot3d import Axes3D  # noqa: F401 (registers the 3-D projection)
    except ImportError:  # pragma: no cover - the plot extra
        raise ImportError("a picture needs matplotlib: pip install 'symdyn[plot]'") from None
    Ts = frames(robot, q)
    if ax is None:
        fig = Figure(figsize=(8, 7))  # no pyplot: no backend, no window, nothing global
        ax = fig.add_subplot(projection="3d")
    fig = ax.figure
    points = [T[:3, 3] for T in Ts]
    record = getattr(robot, "urdf", None)
    bones = record.skeleton if record is not None and q is None and record.describes(robot) else ()
    if bones:  # the file's tree, in the base link's frame (the robot's world before its base transform)
        by = {b.link: b for b in bones}
        to_base = np.linalg.inv(np.array(by[record.base_link].T)) if record.base_link in by else np.eye(4)
        world = np.array(robot.base, dtype=float) @ to_base
        seen = set()
        for b in bones:
            if not b.parent:
                continue
            color, label = ROLES[b.role if b.role != "chain" or by[b.parent].role == "chain" else "above"]
            p0 = (world @ np.array(by[b.parent].T))[:3, 3]
            p1 = (world @ np.array(b.T))[:3, 3]
            style = "-" if b.role == "chain" else ":" if b.role == "excluded" else "--"
            ax.plot(*zip(p0, p1), style, color=color, lw=1.2, label=None if b.role in seen else label)
            seen.add(b.role)
            locked = b.kind in ("revolute", "continuous", "prismatic") and b.joint not in record.joints
            if locked and b.role != "above":
                ax.scatter(*p1, marker="x", color=color, s=30, label=None if "x" in seen else "locked joint")
                seen.add("x")
            points += [p0, p1]
    pts = np.array(points)
    reach = float(np.ptp(pts, axis=0).max()) or 1.0
    if robot.is_chain:
        ax.plot(*pts[: len(Ts)].T, "-o", color="tab:blue", lw=3, ms=4, label="chain: base, joints, tool")
    else:  # every branch: each link from its parent's frame, then the tool on the last link
        ends = [(parent + 1, i + 1) for i, parent in enumerate(robot.parents)] + [(len(Ts) - 2, len(Ts) - 1)]
        for k, (a, b) in enumerate(ends):
            label = "tree: base, joints, tool" if k == 0 else None
            ax.plot(*pts[[a, b]].T, "-o", color="tab:blue", lw=3, ms=4, label=label)
        body = robot.base_body
        if body is not None and float(body.m) > 0:  # the floating base's centre of mass
            c = (Ts[0] @ np.append(np.array(body.r, dtype=float), 1.0))[:3]
            ax.scatter(*c, color="tab:purple", s=40, label=f"{robot.base_joint} base body's centre of mass")
    for i, link in enumerate(robot.links):
        T = Ts[i + 1]
        axis = T[:3, :3] @ (
            np.array(link.axis, dtype=float) if robot.convention == "general" else np.array([0, 0, 1.0])
        )
        a0 = T[:3, 3]
        ax.quiver(*a0, *(axis * reach / 5), color="tab:orange", lw=2, linestyle="-" if link.is_revolute else "--")
        ax.text(*(a0 + axis * reach / 5), f"q{i + 1}", color="tab:orange", fontsize=8)
        m = float(link.m)
        if m > 0:
            c = (T @ np.append(np.array(link.r, dtype=float), 1.0))[:3]
            ax.scatter(*c, color="tab:green", s=20 + 30 * m ** (1 / 3), label="centre of mass" if i == 0 else None)
            semi, R = ellipsoid_axes(m, link.I)
            u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 13), np.linspace(0, np.pi, 7))
            xyz = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1) * semi
            xyz = xyz @ (T[:3, :3] @ R).T + c
            ax.plot_wireframe(*np.moveaxis(xyz, -1, 0), color="tab:green", lw=0.3, alpha=0.35)
    for k, frame in enumerate(robot.task_frames):  # the frames the task-space functions serve
        T = Ts[frame.link + 1] @ np.array(frame.placement, dtype=float)
        for axis, color in enumerate(("red", "green", "blue")):
            ax.quiver(*T[:3, 3], *(T[:3, axis] * reach / 10), color=color, lw=1)
        ax.scatter(
            *T[:3, 3], marker="s", color="black", s=12, label="task frames (x y z: red green blue)" if k == 0 else None
        )
        ax.text(*T[:3, 3], f" {frame.name}", color="black", fontsize=7)
    ax.quiver(0, 0, 0, 0, 0, 0, color="tab:orange", label="joint axes (dashed: prismatic)")
    mid = (pts.max(axis=0) + pts.min(axis=0)) / 2
    for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid):
        set_lim(c - reach / 2 - reach * 0.1, c + reach / 2 + reach * 0.1)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title(
        title or f"{robot.name}: {f'{robot.n} joints' if robot.n else 'one body'} at q = 0"
        if q is None
        else f"{robot.name} at q = {q}"
    )
    fig.legend(*ax.get_legend_handles_labels(), loc="lower center", ncol=3, fontsize=7, frameon=False)
    return fig
