"""Random arms for differential tests: every feature of the model, in any mix.

`random_arm(seed)` draws a serial arm with 1…7 joints in standard or
modified DH, or (`ArmOptions(general=…)`) with URDF-like joints placed by
an origin (rpy exact or generic) about an axis (±x, ±y, ±z or generic): revolute and prismatic joints, exact twists (0, ±π/2, π) and
generic ones, joint offsets, massless links, point masses and full inertia
tensors, motors with gear ratios of either sign, rotor inertia, viscous and
asymmetric Coulomb friction, a tilted or upside-down base, a tool, gravity
in any direction, either payload semantics, and symbolic parameters
substituted afterwards.  `robot_code(robot)` prints an arm as constructor
code a reader can paste into a regression test.

Every arm drawn has a positive-definite M: each joint has rotor inertia or
its own link has a positive-definite spatial inertia (mass and a full
tensor), which makes q̇ᵀMq̇ > 0 for q̇ ≠ 0 by induction along the chain.
`degenerate_arm(seed)` breaks that on purpose (a massless last link with no
rotor), for the clear-error check.
"""

from __future__ import annotations

import dataclasses
import math
import random

import numpy as np
import sympy as sp

from .placement import placement
from .rotations import quaternion_matrix
from .robot import IDENTITY, Link, Robot

__all__ = ["random_arm", "degenerate_arm", "robot_code", "ArmOptions"]

_EXACT_TWISTS = (0.0, math.pi / 2, -math.pi / 2, math.pi)
_AXES = ((1, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0), (0, -1, 0), (0, 0, -1))


@dataclasses.dataclass(frozen=True)
class ArmOptions:
    """Ranges of the draw: joint count and how often each feature appears (0…1)."""

    n_min: int = 1
    n_max: int = 7
    prismatic: float = 0.3
    generic_twist: float = 0.3
    massless: float = 0.15
    point_mass: float = 0.15
    motor: float = 0.6
    symbolic: float = 0.15
    general: float = 0.0  # arms in the general convention (URDF-like origin and axis); 0 keeps old seeds


def _rotation(rng: random.Random) -> np.ndarray:
    """A uniformly random rotation matrix (from a random unit quaternion)."""
    w, x, y, z = (rng.gauss(0, 1) for _ in range(4))
    s = math.sqrt(w * w + x * x + y * y + z * z)
    return quaternion_matrix((w / s, x / s, y / s, z / s), order="wxyz")


def _transform(R: np.ndarray, p) -> tuple:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return tuple(tuple(float(x) for x in row) for row in T)


def _inertia(rng: random.Random, m: float) -> tuple:
    """A physical COM inertia: tr(S)·1 − S for a random positive-definite
    second moment S (so the triangle inequality holds strictly)."""
    R = _rotation(rng)
    S = R @ np.diag([m * rng.uniform(0.002, 0.05) for _ in range(3)]) @ R.T
    I = np.trace(S) * np.eye(3) - S
    I = (I + I.T) / 2
    return tuple(tuple(float(x) for x in row) for row in I)


def _length(rng: random.Random, zero: float = 0.3) -> float:
    return 0.0 if rng.random() < zero else round(rng.uniform(-0.6, 0.6), 4)


def _link(rng: random.Random, o: ArmOptions, last: bool) -> Link:
    prismatic = rng.random() < o.prismatic
    alpha = rng.uniform(-math.pi, math.pi) if rng.random() < o.generic_twist else rng.choice(_EXACT_TWISTS)
    offset = 0.0 if rng.random() < 0.5 else rng.uniform(-math.pi, math.pi) if not prismatic else rng.uniform(-0.2, 0.2)
    kind = rng.random()
    massless = kind < o.massless
    point = not massless and kind < o.massless + o.point_mass
    m = 0.0 if massless else rng.uniform(0.2, 8.0)
    r = (0.0, 0.0, 0.0) if massless else tuple(_length(rng, 0.2) / 2 for _ in range(3))
    I = ((0.0,) * 3,) * 3 if massless or point else _inertia(rng, m)
    motor = massless or point or rng.random() < o.motor
    G = rng.choice((-1, 1)) * rng.uniform(1.0, 100.0) if motor else 1.0
    Jm = rng.uniform(1e-5, 1e-3) if motor else 0.0
    if motor and abs(G) * abs(G) * Jm < 1e-3:  # rotor inertia large enough to keep M well conditioned
        Jm = 1e-3 / (G * G)
    B = rng.uniform(0, 1e-3) if motor and rng.random() < 0.7 else 0.0
    Tc = (rng.uniform(0, 0.5), -rng.uniform(0, 0.5)) if motor and rng.random() < 0.7 else (0.0, 0.0)
    if prismatic:
        lo = rng.uniform(-0.5, 0.3)
        qlim = (lo, lo + rng.uniform(0.2, 0.8))
        theta = rng.choice((0.0, math.pi / 2, rng.uniform(-math.pi, math.pi)))
        return Link(
            joint="prismatic",
            theta=theta,
            a=_length(rng),
            alpha=alpha,
            offset=offset,
            qlim=qlim,
            m=m,
            r=r,
            I=I,
            Jm=Jm,
            B=B,
            Tc=Tc,
            G=G,
        )
    lo = rng.uniform(-math.pi, 0)
    qlim = (lo, lo + rng.uniform(0.5, 2 * math.pi)) if rng.random() < 0.7 else None
    return Link(
        d=_length(rng), a=_length(rng), alpha=alpha, offset=offset, qlim=qlim, m=m, r=r, I=I, Jm=Jm, B=B, Tc=Tc, G=G
    )


def _general(rng: random.Random, link: Link) -> Link:
    """The link's joint re-placed as a URDF joint: a random origin (each rpy angle
    a multiple of π/2 or generic) and an axis along ±x, ±y, ±z or generic."""
    angle = lambda: rng.choice(_EXACT_TWISTS) if rng.random() < 0.6 else rng.uniform(-math.pi, math.pi)  # noqa: E731
    origin = placement([_length(rng) for _ in range(3)], [angle() for _ in range(3)])
    if rng.random() < 0.8:
        axis = rng.choice(_AXES)
    else:
        v = np.array([rng.gauss(0, 1) for _ in range(3)])
        axis = tuple(float(x) for x in v / np.linalg.norm(v))
    return dataclasses.replace(link, theta=0, d=0, a=0, alpha=0, origin=origin, axis=axis)


def _gravity(rng: random.Random) -> tuple:
    choice = rng.random()
    if choice < 0.5:
        return (0.0, 0.0, 9.81)
    if choice < 0.6:
        return (0.0, 0.0, 0.0)
    v = np.array([rng.gauss(0, 1) for _ in range(3)])
    return tuple(float(x) for x in rng.uniform(1.0, 12.0) * v / np.linalg.norm(v))


def _base(rng: random.Random) -> tuple:
    choice = rng.random()
    if choice < 0.4:
        return IDENTITY
    if choice < 0.6:  # upside down
        return _transform(np.diag([1.0, -1.0, -1.0]), (0.0, 0.0, rng.uniform(0, 2)))
    return _transform(_rotation(rng), [rng.uniform(-1, 1) for _ in range(3)])


def _symbolize(robot: Robot, rng: random.Random) -> Robot:
    """The same arm built with some parameters as sympy symbols, then substituted:
    the path a user takes with a symbolic model."""
    values = {}
    links = []
    for i, link in enumerate(robot.links):
        fields = {}
        for name in ("m", "B") if robot.convention == "general" else ("m", "a", "d", "B"):
            if rng.random() < 0.3 and (name != "d" or link.is_revolute):
                sym = sp.Symbol(f"{name}{i + 1}", real=True)
                values[sym] = getattr(link, name)
                fields[name] = sym
        links.append(dataclasses.replace(link, **fields))
    if not values:
        return robot
    symbolic = dataclasses.replace(robot, links=tuple(links))
    return symbolic.subs(values)


def random_arm(seed: int, options: ArmOptions = ArmOptions(), *, n: int | None = None) -> Robot:
    """A random numeric arm, the same for the same seed (see the module docstring)."""
    rng = random.Random(seed)
    general = options.general > 0 and rng.random() < options.general
    n = n or rng.randint(options.n_min, options.n_max)
    links = [_link(rng, options, last=i == n - 1) for i in range(n)]
    convention = rng.choice(("standard", "modified"))
    if general:
        links, convention = [_general(rng, link) for link in links], "general"
    robot = Robot(
        f"arm{seed}",
        tuple(links),
        convention=convention,
        gravity=_gravity(rng),
        base=_base(rng),
        tool=IDENTITY if rng.random() < 0.5 else _transform(_rotation(rng), [rng.uniform(-0.2, 0.2) for _ in range(3)]),
        source=f"symdyn.model.random_arms.random_arm({seed})",
    )
    if rng.random() < 0.3 and (robot.links[-1].Jm or any(any(row) for row in robot.links[-1].I)):
        p = [rng.uniform(-0.2, 0.2) for _ in range(3)]
        robot = robot.payload(rng.uniform(0.1, 3.0), p, additive=rng.random() < 0.5)
    if rng.random() < options.symbolic:
        robot = _symbolize(robot, rng)
    return robot


def degenerate_arm(seed: int) -> Robot:
    """A random arm whose last link is massless with no rotor: M(q) is singular."""
    robot = random_arm(seed, ArmOptions(n_max=4, symbolic=0.0))
    last = dataclasses.replace(robot.links[-1], m=0, r=(0, 0, 0), I=((0,) * 3,) * 3, Jm=0, B=0, Tc=(0, 0), G=1)
    return dataclasses.replace(robot, name=f"degenerate{seed}", links=robot.links[:-1] + (last,))


# --------------------------------------------------------------------------- printing


def _num(x) -> str:
    if isinstance(x, float):
        return repr(x)
    if isinstance(x, tuple):
        inner = ", ".join(_num(e) for e in x)
        return f"({inner},)" if len(x) == 1 else f"({inner})"
    if isinstance(x, sp.Basic):
        return f"sympify({str(x)!r})"
    return repr(x)


def robot_code(robot: Robot) -> str:
    """Python source that rebuilds `robot` exactly (floats round-trip)."""
    defaults = Link()
    lines = ["Robot(", f"    {robot.name!r},", "    ("]
    for link in robot.links:
        args = [
            f"{f.name}={_num(getattr(link, f.name))}"
            for f in dataclasses.fields(link)
            if _num(getattr(link, f.name)) != _num(getattr(defaults, f.name))
        ]
        lines.append(f"        Link({', '.join(args)}),")
    lines.append("    ),")
    for name, default in (
        ("convention", "standard"),
        ("gravity", (0, 0, 9.81)),
        ("base", IDENTITY),
        ("tool", IDENTITY),
    ):
        value = getattr(robot, name)
        if _num(value) != _num(default):
            lines.append(f"    {name}={_num(value)},")
    lines.append(")")
    return "\n".join(lines)
