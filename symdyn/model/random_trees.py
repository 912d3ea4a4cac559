"""Random URDF trees for differential tests: a random arm's chain plus random branches.

`random_tree(seed)` takes the chain of `random_arm` (general joints: random
origins, axes along ±x, ±y, ±z or generic, full inertias) and hangs random
branches on its links and on the base: revolute, continuous, prismatic and
fixed joints, branches of branches, mimic joints with a multiplier and an
offset, limits that exclude 0.  It returns the URDF text, the chain's tip and
random `locked` values (some off the chain, sometimes a chain joint), so a
test can compare `from_urdf(text, tip_link=tip, locked=locked)` with
Pinocchio's reduced model of the same text.
"""

from __future__ import annotations

import dataclasses
import math
import random

import numpy as np

from .rotations import quaternion_matrix

from .random_arms import ArmOptions, random_arm

__all__ = ["RandomTree", "random_tree"]

_AXES = ((1, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0), (0, -1, 0), (0, 0, -1))
_CHAIN = ArmOptions(n_min=1, n_max=5, massless=0.0, point_mass=0.0, motor=0.0, symbolic=0.0, general=1.0)


@dataclasses.dataclass(frozen=True)
class RandomTree:
    text: str
    tip: str
    locked: dict


def _rpy(R: np.ndarray) -> list:
    """roll, pitch, yaw with R = Rz(yaw)·Ry(pitch)·Rx(roll)."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) < 1e-12:  # gimbal lock: yaw taken as 0
        return [math.atan2(-R[1, 2], R[1, 1]), pitch, 0.0]
    return [math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])]


def _rotation_rpy(rpy) -> np.ndarray:
    """Rz(yaw)·Ry(pitch)·Rx(roll) in floats."""
    (cr, sr), (cp, sp_), (cy, sy) = ((math.cos(a), math.sin(a)) for a in rpy)
    return (
        np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
        @ np.array([[cp, 0, sp_], [0, 1, 0], [-sp_, 0, cp]])
        @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    )


def _f(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _inertial(m: float, r, I) -> str:
    I = [[repr(float(x)) for x in row] for row in I]
    return (
        f'<inertial><origin xyz="{_f(r)}"/><mass value="{float(m)!r}"/>'
        f'<inertia ixx="{I[0][0]}" ixy="{I[0][1]}" ixz="{I[0][2]}" iyy="{I[1][1]}" '
        f'iyz="{I[1][2]}" izz="{I[2][2]}"/></inertial>'
    )


def _random_inertia(rng: random.Random, m: float) -> np.ndarray:
    a, b = rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0)
    moments = np.array([a, b, rng.uniform(abs(a - b), a + b)]) * m * 0.01  # triangle inequality holds
    w, x, y, z = (rng.gauss(0, 1) for _ in range(4))
    q = np.array([w, x, y, z]) / math.sqrt(w * w + x * x + y * y + z * z)
    R = quaternion_matrix(q, order="wxyz")
    return R @ np.diag(moments) @ R.T


def random_tree(seed: int) -> RandomTree:
    """A random tree, the same for the same seed (see the module docstring)."""
    rng = random.Random(seed)
    arm = random_arm(seed, _CHAIN)
    parts, locked, movers = ['<link name="base"/>'], {}, []

    def joint(name, kind, parent, child, origin, axis=None, limit=None, mimic=None):
        R = np.array([[float(x) for x in row[:3]] for row in origin[:3]])
        xyz = [float(origin[i][3]) for i in range(3)]
        text = (
            f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{_f(xyz)}" rpy="{_f(_rpy(R))}"/>'
        )
        text += f'<axis xyz="{_f(axis)}"/>' if axis is not None else ""
        text += (
            f'<limit lower="{float(limit[0])!r}" upper="{float(limit[1])!r}" effort="10" velocity="1"/>'
            if limit is not None
            else ""
        )
        text += (
            f'<mimic joint="{mimic[0]}" multiplier="{mimic[1]!r}" offset="{mimic[2]!r}"/>' if mimic is not None else ""
        )
        parts.append(text + "</joint>")

    def branch(parent: str, depth: int) -> None:
        name = f"b{len(parts)}"
        kind = rng.choice(("revolute", "continuous", "prismatic", "fixed"))
        angles = [
            rng.choice((0.0, math.pi / 2, -math.pi / 2, math.pi))
            if rng.random() < 0.5
            else rng.uniform(-math.pi, math.pi)
            for _ in range(3)
        ]
        origin = [list(row) + [rng.uniform(-0.2, 0.2)] for row in _rotation_rpy(angles)] + [[0, 0, 0, 1]]
        axis = rng.choice(_AXES) if rng.random() < 0.7 else tuple(rng.gauss(0, 1) for _ in range(3))
        limit, mimic = None, None
        if kind in ("revolute", "prismatic"):
            lo = rng.uniform(-1.0, 0.5)
            limit = (lo, lo + rng.uniform(0.2, 1.5))
        if kind != "fixed":
            if movers and rng.random() < 0.3:
                mimic = (rng.choice(movers), rng.choice((1.0, -1.0, 0.5)), rng.uniform(-0.1, 0.1))
            elif rng.random() < 0.5:
                locked[name] = rng.uniform(*limit) if limit else rng.uniform(-3.0, 3.0)
            if mimic is None:
                movers.append(name)
        m = rng.uniform(0.05, 1.0)
        joint(name, kind, parent, f"{name}_link", origin, None if kind == "fixed" else axis, limit, mimic)
        parts.append(
            f'<link name="{name}_link">{_inertial(m, [rng.uniform(-0.1, 0.1) for _ in range(3)], _random_inertia(rng, m))}</link>'
        )
        if depth < 2 and rng.random() < 0.4:
            branch(f"{name}_link", depth + 1)

    parent = "base"
    for i, link in enumerate(arm.links):
        name = f"l{i + 1}"
        kind = link.joint
        limit = tuple(float(x) for x in link.qlim) if link.qlim is not None else None
        joint(
            f"j{i + 1}",
            "continuous" if kind == "revolute" and limit is None else kind,
            parent,
            name,
            link.origin,
            link.axis,
            limit,
        )
        parts.append(f'<link name="{name}">{_inertial(float(link.m), link.r, link.I)}</link>')
        for _ in range(rng.choice((0, 0, 1, 2))):
            branch(rng.choice((parent, name)) if parent == "base" else name, 0)
        parent = name
    chain = [f"j{i + 1}" for i in range(arm.n)]
    if arm.n > 1 and rng.random() < 0.2:
        j = rng.choice(chain)
        lo, hi = arm.qlim[int(j[1:]) - 1]
        locked[j] = rng.uniform(float(lo), float(hi))
    text = f'<?xml version="1.0"?>\n<robot name="tree{seed}">\n' + "\n".join(parts) + "\n</robot>\n"
    return RandomTree(text, parent, locked)
