"""Robot model: links with kinematic, inertial, motor and friction parameters.

The first stage of the flow model → derive → simplify → program → emit.
`Link` and `Robot` are frozen dataclasses; every operation (payload,
nofriction, subs, to_modified) returns a new robot.  A parameter may be a
number or a sympy expression; numeric consumers (the reference) ask for
`robot.require_numeric()` first.  Conventions follow Corke's Robotics
Toolbox (see the README of shared/reference).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Mapping, Sequence

import numpy as np
import sympy as sp

from . import frames
from . import inertia
from . import reframe
from .placement import exact_cos_sin, is_symbolic, rotx, roty, rotz, transl, walk  # noqa: F401 (the model's exact transforms)

CONVENTIONS = ("standard", "modified", "general")
JOINT_TYPES = ("revolute", "prismatic")
#: Joints that may carry the whole robot (`Robot(base_joint=…)`): none (a fixed base), a
#: 6-DOF free base (Pinocchio's free-flyer) or a planar base (x, y, yaw, as a mobile base).
BASE_JOINTS = (None, "free", "planar")

Number = Any  # int, float or sympy expression


IDENTITY = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))


# --------------------------------------------------------------------------- helpers


def _scalar(x: Number, what: str) -> Number:
    """Accept an int, float or sympy expression; reject anything else by name."""
    if isinstance(x, bool):
        raise ValueError(f"{what} must be a number or sympy expression, got a bool")
    if isinstance(x, (int, float)):
        if not math.isfinite(x):
            raise ValueError(f"{what} must be finite, got {x}")
        return x
    if isinstance(x, np.generic) and np.issubdtype(type(x), np.number):
        return _scalar(x.item(), what)
    if isinstance(x, sp.Basic):
        if x.is_Number:
            if x.is_Integer:
                return int(x)
            if x.is_Rational:
                return x  # keep exact rationals exact
            return _scalar(float(x), what)
        return x
    raise ValueError(f"{what} must be a number or sympy expression, got {type(x).__name__} {x!r}")


def _vector(v: Sequence, length: int, what: str) -> tuple:
    try:
        items = list(v.tolist() if hasattr(v, "tolist") and not isinstance(v, sp.Basic) else v)
    except TypeError:
        raise ValueError(f"{what} must be a sequence of {length} numbers, got {v!r}") from None
    if isinstance(v, sp.MatrixBase):
        items = list(v)
    if len(items) != length:
        raise ValueError(f"{what} must have {length} elements, got {len(items)}: {v!r}")
    return tuple(_scalar(x, f"{what}[{i}]") for i, x in enumerate(items))


def _matrix(m: Sequence, rows: int, cols: int, what: str) -> tuple:
    if isinstance(m, sp.MatrixBase):
        m = m.tolist()
    elif isinstance(m, np.ndarray):
        m = m.tolist()
    try:
        rows_ = [list(r) for r in m]
    except TypeError:
        raise ValueError(f"{what} must be a {rows}×{cols} matrix, got {m!r}") from None
    if len(rows_) != rows or any(len(r) != cols for r in rows_):
        shape = f"{len(rows_)}×{'/'.join(str(len(r)) for r in rows_)}"
        raise ValueError(f"{what} must be a {rows}×{cols} matrix, got {shape}")
    return tuple(tuple(_scalar(x, f"{what}[{i},{j}]") for j, x in enumerate(r)) for i, r in enumerate(rows_))


def _canonical(x: Any) -> str:
    """A stable text form of a parameter for hashing (exact for sympy)."""
    if isinstance(x, sp.Basic):
        return sp.srepr(x)
    if isinstance(x, float):
        return repr(x)
    if isinstance(x, (tuple, list)):
        return "(" + ",".join(_canonical(e) for e in x) + ")"
    return repr(x)


# --------------------------------------------------------------------------- Link


@dataclass(frozen=True)
class Link:
    """One link and the joint that moves it (Corke's `Link`).

    Kinematics (DH): `theta` (constant part for a prismatic joint), `d`
    (constant part for a revolute joint), `a`, `alpha`, `offset` (added to
    the joint variable), `qlim` (lower, upper) or None.  In the modified
    convention `a`, `alpha` are Craig's aᵢ₋₁, αᵢ₋₁.
    Kinematics (general convention, as URDF): `origin`, the joint's constant
    4×4 placement in the parent link's frame (see `placement(xyz, rpy)`),
    and `axis`, the unit joint axis in the link's own frame, which moves
    with the joint: ⁱ⁻¹Tᵢ = origin · Rot(axis, q + offset) or
    origin · Trans(axis·(q + offset)).
    Inertia: mass `m`, centre of mass `r` in the link frame, inertia `I`
    (3×3, symmetric, about the COM, link-frame axes).
    Motor (motor side, as the Toolbox): rotor inertia `Jm`, viscous friction
    `B`, Coulomb friction `Tc` = (Tc⁺, Tc⁻) with Tc⁻ ≤ 0, gear ratio `G`.
    Limits that do not enter the dynamics (as URDF's `<limit effort velocity>`):
    `effort_limit` (N·m or N) and `velocity_limit` (rad/s or m/s), or None.
    `physical=False` waives the triangle inequality of the principal moments
    for published data that violates it (it does not enter the dynamics).
    Trees: `parent`, the index in `robot.links` of the link this one hangs on
    (-1: the base; None, the default: the link before it, as in a chain); a
    parent comes before its children.  `name` names the joint (a file's name;
    `robot.joint_names`).

    Raises:
        ValueError: an unknown joint type; a parameter that is not a finite number
            or sympy expression (a bool included); r, axis, Tc or qlim of the wrong
            length, I not 3×3, origin not a proper homogeneous transform; an
            axis that is not a unit vector; qlim not lower < upper; an effort or
            velocity limit that is not positive.  The physical checks (mass,
            inertia, motor parameters) are the `Robot`'s.
    """

    joint: str = "revolute"
    theta: Number = 0
    d: Number = 0
    a: Number = 0
    alpha: Number = 0
    offset: Number = 0
    qlim: tuple | None = None
    origin: tuple | None = None
    axis: tuple = (0, 0, 1)
    m: Number = 0
    r: tuple = (0, 0, 0)
    I: tuple = ((0, 0, 0), (0, 0, 0), (0, 0, 0))
    Jm: Number = 0
    B: Number = 0
    Tc: tuple = (0, 0)
    G: Number = 1
    effort_limit: float | None = field(default=None, compare=False)
    velocity_limit: float | None = field(default=None, compare=False)
    physical: bool = field(default=True, compare=False)
    parent: int | None = None
    name: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 (frozen)
        if self.parent is not None and (isinstance(self.parent, bool) or not isinstance(self.parent, int)):
            raise ValueError(f"parent must be a link index (int, -1 for the base) or None, got {self.parent!r}")
        if self.name is not None and not (isinstance(self.name, str) and self.name):
            raise ValueError(f"name must be a non-empty string or None, got {self.name!r}")
        if self.joint not in JOINT_TYPES:
            raise ValueError(f"unknown joint type {self.joint!r}: expected one of {JOINT_TYPES}")
        for name in ("theta", "d", "a", "alpha", "offset", "m", "Jm", "B", "G"):
            set_(name, _scalar(getattr(self, name), name))
        set_("r", _vector(self.r, 3, "r"))
        set_("I", _matrix(self.I, 3, 3, "I"))
        set_("Tc", _vector(self.Tc, 2, "Tc"))
        if self.origin is not None:
            set_("origin", _transform(self.origin, "origin"))
        set_("axis", _vector(self.axis, 3, "axis"))
        for name in ("effort_limit", "velocity_limit"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, (int, float)) and 0 < value < math.inf):
                raise ValueError(f"{name} must be a positive number or None, got {value!r}")
        if not any(is_symbolic(x) for x in self.axis):
            norm = math.sqrt(sum(float(x) ** 2 for x in self.axis))
            if abs(norm - 1) > 1e-9:
                raise ValueError(f"joint axis must be a unit vector, got {self.axis} (norm {norm})")
        if self.qlim is not None:
            lo, hi = _vector(self.qlim, 2, "qlim")
            if not is_symbolic(lo) and not is_symbolic(hi) and not lo < hi:
                raise ValueError(f"joint limits reversed or empty: qlim = ({lo}, {hi}); expected lower < upper")
            set_("qlim", (lo, hi))

    @property
    def is_revolute(self) -> bool:
        return self.joint == "revolute"

    @property
    def is_general(self) -> bool:
        """Placed by `origin` and `axis` (general convention) rather than DH."""
        return self.origin is not None or tuple(self.axis) != (0, 0, 1)

    def _params(self) -> tuple:
        """Every parameter that affects the dynamics; a DH link's unused origin
        and axis are left out, so its fingerprint is what it always was."""
        skip = {"physical", "effort_limit", "velocity_limit", "name"} | (
            set() if self.is_general else {"origin", "axis"}
        )
        if self.parent is None:  # a chain's link: its fingerprint is what it always was
            skip.add("parent")
        return tuple(getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in skip)


#: The function `Robot.plot` draws with (`symdyn.presentation.picture.plot`, a later stage), installed
#: by the `symdyn` package through `set_drawing`.
_DRAWING: Callable[..., Any] | None = None


def set_drawing(draw: Callable[..., Any]) -> None:
    """Install the function `Robot.plot` calls: draw(robot, q, ax=…, title=…) → a Figure."""
    global _DRAWING
    _DRAWING = draw


def _check_link_physics(link: Link, i: int) -> None:
    """Mass ≥ 0, inertia symmetric, positive semidefinite and obeying the triangle
    inequality (unless the link says it is not physical); sane motor params."""
    label = f"link {i + 1}" if i >= 0 else "the base body"
    if not is_symbolic(link.m) and link.m < 0:
        raise ValueError(f"mass of {label} is negative: m = {link.m}")
    I = link.I
    for a, b in ((0, 1), (0, 2), (1, 2)):
        x, y = I[a][b], I[b][a]
        if is_symbolic(x) or is_symbolic(y):
            if sp.simplify(sp.sympify(x) - y) != 0:
                raise ValueError(f"inertia of {label} is not symmetric: I[{a},{b}]={x}, I[{b},{a}]={y}")
        elif abs(x - y) > 1e-12 * (1 + abs(x) + abs(y)):
            raise ValueError(f"inertia of {label} is not symmetric: I[{a},{b}]={x}, I[{b},{a}]={y}")
    if not any(is_symbolic(x) for row in I for x in row):
        eig = np.linalg.eigvalsh(np.array(I, dtype=float))
        if not inertia.semidefinite(eig):
            raise ValueError(f"inertia of {label} is not positive semidefinite: eigenvalues {eig.tolist()}")
        if link.physical and not inertia.obeys_triangle(eig):
            raise ValueError(
                f"inertia of {label} is physically impossible: its principal moments "
                f"{eig.tolist()} violate the triangle inequality (I1 + I2 ≥ I3); "
                "for published data known to violate it, pass Link(..., physical=False)"
            )
    for name in ("Jm", "B"):
        v = getattr(link, name)
        if not is_symbolic(v) and v < 0:
            raise ValueError(f"{name} of {label} is negative: {v}")
    tp, tn = link.Tc
    if (not is_symbolic(tp) and tp < 0) or (not is_symbolic(tn) and tn > 0):
        raise ValueError(f"Coulomb friction of {label} must be Tc = (Tc+ >= 0, Tc- <= 0), got {link.Tc}")
    if not is_symbolic(link.G) and link.G == 0:
        motor = [link.Jm, link.B, *link.Tc]
        if any(is_symbolic(x) or x != 0 for x in motor):
            raise ValueError(
                f"gear ratio of {label} is 0 but it has motor parameters "
                f"(Jm, B, Tc) = ({link.Jm}, {link.B}, {link.Tc}); give the ratio G"
            )


def _check_link_convention(link: Link, i: int, convention: str, robot: str) -> None:
    """DH links have no origin or axis; general links have no DH parameters."""
    if convention == "general":
        for name in ("a", "alpha", "d", "theta"):
            if is_symbolic(getattr(link, name)) or getattr(link, name) != 0:
                raise ValueError(
                    f"link {i + 1} of robot {robot!r} sets DH parameter {name} = "
                    f"{getattr(link, name)}, but the robot uses the general convention: "
                    "place its joint by origin (and axis) instead"
                )
    elif link.is_general:
        raise ValueError(
            f"link {i + 1} of robot {robot!r} sets origin or axis, which only the general "
            f"convention reads, but the robot uses {convention} DH; "
            "pass convention='general'"
        )


# --------------------------------------------------------------------------- Robot


@dataclass(frozen=True)
class Robot:
    """A serial-link arm: links, DH convention, gravity, base and tool.

    `gravity` is Corke's: the base's upward acceleration in the world, e.g.
    (0, 0, 9.81) for a z-up base.  `base` and `tool` are 4×4 homogeneous
    transforms.  `poses` maps names (qz, qr, …) to joint vectors.  Use
    `dataclasses.replace(robot, base=T, gravity=g)` for variants.

    Raises:
        ValueError: an unknown convention; no links on a fixed base, or one that is not a `Link`;
            a link with negative mass, an inertia that is not symmetric, positive
            semidefinite or (unless `physical=False`) within the triangle
            inequality, negative Jm or B, Tc not (≥ 0, ≤ 0), motor parameters with
            G = 0; DH parameters on a general-convention link, or origin/axis on
            a DH link; gravity not a 3-vector; base or tool not a proper
            homogeneous transform; a pose of the wrong length.
    """

    name: str
    links: tuple
    convention: str = "standard"
    gravity: tuple = (0, 0, 9.81)
    base: tuple = IDENTITY
    tool: tuple = IDENTITY
    poses: Mapping[str, tuple] = field(default_factory=dict, compare=False, hash=False)
    source: str = field(default="", compare=False, hash=False)
    urdf: Any = field(default=None, compare=False, hash=False)
    #: What `from_mjcf` read, locked and snapped (`symdyn.model.mjcf.MjcfRecord`), or None.
    mjcf: Any = field(default=None, compare=False, hash=False)
    #: None (fixed base), "free" or "planar": the joint that carries the whole robot (`floating`).
    base_joint: str | None = None
    #: The body the base joint moves (mass, COM, inertia of a `Link`; its joint fields unused),
    #: which the links with parent -1 hang on; None: a massless base body.
    base_body: Link | None = None
    #: The frames the task-space functions serve, by name, in order (`frame_names` lists the
    #: known ones); empty: the default (`task_frames`).  `with_frames(names)` chooses them.
    frames: tuple = ()
    #: Every frame of the file the robot was read from (`symdyn.model.frames.Frame`: each link of
    #: the file, moving, locked or merged; each MJCF body and site); empty for a robot built here.
    frame_catalog: tuple = field(default=(), compare=False, hash=False)
    #: The contact set of the contact functions: ((frame name, "point" or "surface"), …) in order
    #: (`with_contacts`); empty: none.
    contacts: tuple = ()
    #: The contact set's Baumgarte gains (kp, kd) (`with_contacts`): (0, 0) holds J a + γ = 0
    #: exactly; otherwise J a + γ = −kd J v − kp e(q, anchor) (Pinocchio's corrector).
    baumgarte: tuple = (0.0, 0.0)
    #: `Robot.from_urdf(path_or_xml, *, base_link=…, tip_link=…, locked=…, exclude=…, snap=…)`: the
    #: arm of a URDF file (`symdyn.model.urdf.from_urdf`, attached by `symdyn.model`, which builds on this module).
    from_urdf: ClassVar[Callable[..., "Robot"]]
    #: `robot.to_urdf(path=None, *, source=…)`: the URDF text with the robot's inertials
    #: (`symdyn.model.urdf.to_urdf`, attached by `symdyn.model`).
    to_urdf: ClassVar[Callable[..., str]]
    #: `Robot.from_mjcf(path, *, base_body=…, tip_body=…, locked=…, exclude=…, snap=…, name=…)`: the arm of
    #: an MJCF file compiled by MuJoCo (`symdyn.model.mjcf.from_mjcf`, attached by `symdyn.model`).
    from_mjcf: ClassVar[Callable[..., "Robot"]]
    #: `robot.from_mujoco_state(qpos, qvel, qacc=None)` → (q, v[, a]) and `robot.to_mujoco_state(q, v, a=None)`
    #: → (qpos, qvel[, qacc]): MuJoCo's states and symdyn's (`symdyn.model.mjcf.state`, attached by `symdyn.model`).
    from_mujoco_state: ClassVar[Callable[..., tuple]]
    to_mujoco_state: ClassVar[Callable[..., tuple]]

    def __post_init__(self) -> None:
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 (frozen)
        if self.convention not in CONVENTIONS:
            raise ValueError(f"unknown DH convention {self.convention!r}: expected one of {CONVENTIONS}")
        links = tuple(self.links)
        if not links and self.base_joint is None:  # a lone body (a drone) moves on its base joint
            raise ValueError(f"robot {self.name!r} has no links and a fixed base: nothing moves")
        for i, link in enumerate(links):
            if not isinstance(link, Link):
                raise ValueError(f"links[{i}] of robot {self.name!r} is a {type(link).__name__}, expected Link")
            _check_link_physics(link, i)
            _check_link_convention(link, i, self.convention, self.name)
        set_("links", _chain_parents_implicit(links, self.name))
        if self.base_joint not in BASE_JOINTS:
            raise ValueError(
                f"unknown base_joint {self.base_joint!r} of robot {self.name!r}: expected one of {BASE_JOINTS}"
            )
        if self.base_body is not None:
            if self.base_joint is None:
                raise ValueError(f"robot {self.name!r} has a base_body but no base_joint to move it (fixed base)")
            if not isinstance(self.base_body, Link):
                raise ValueError(
                    f"base_body of robot {self.name!r} must be a Link, got {type(self.base_body).__name__}"
                )
            _check_link_physics(self.base_body, -1)
        set_("gravity", _vector(self.gravity, 3, "gravity"))
        set_("base", _transform(self.base, "base"))
        set_("tool", _transform(self.tool, "tool"))
        poses = {}
        for k, v in dict(self.poses).items():
            poses[k] = _vector(v, self.nq, f"pose {k}")
        set_("poses", poses)
        set_("frame_catalog", tuple(self.frame_catalog))
        if isinstance(self.frames, str):
            raise ValueError(f"frames of robot {self.name!r} must be a list of names, got the string {self.frames!r}")
        set_("frames", tuple(self.frames))
        if self.frames:
            frames.resolve(self, self.frames)  # every name known, none twice
        set_("contacts", frames.contact_set(self, self.contacts))
        set_("baumgarte", frames.baumgarte_gains(self, self.baumgarte))

    def __str__(self) -> str:
        """A summary a person reads: joints, convention, source and, for a robot read from a
        URDF or MJCF file, what was locked, excluded and snapped (`robot.urdf`, `robot.mjcf`)."""
        kinds = "".join("R" if link.is_revolute else "P" for link in self.links)
        shape = "" if all(link.parent is None for link in self.links) else ", a tree"
        base = f", on a {self.base_joint} base (nq = {self.nq}, nv = {self.nv})" if self.base_joint else ""
        lines = [
            f"Robot {self.name!r}: {f'{self.n} joints ({kinds})' if self.n else 'one body, no joints'}{shape}{base}, "
            f"{self.convention} convention" + (f", {self.source}" if self.source else "")
        ]
        records = [r for r in (self.urdf, self.mjcf) if r is not None]
        return "\n".join(lines + [line for r in records for line in r.lines()])

    # ---- basic facts
    @property
    def n(self) -> int:
        """Number of joints (links), the base joint not counted."""
        return len(self.links)

    @property
    def parents(self) -> tuple[int, ...]:
        """Each link's parent: its index in `links`, -1 for the base (a chain: -1, 0, 1, …)."""
        return tuple(i - 1 if link.parent is None else link.parent for i, link in enumerate(self.links))

    @property
    def is_chain(self) -> bool:
        """Every link hangs on the one before it and the base is fixed: what every stage reads."""
        return self.base_joint is None and all(link.parent is None for link in self.links)

    @property
    def nq(self) -> int:
        """Size of q: the base joint's coordinates (7 free, 3 planar), then one per joint."""
        return self.n + {None: 0, "free": 7, "planar": 3}[self.base_joint]

    @property
    def nv(self) -> int:
        """Size of v, v̇ and τ: the base joint's velocities (6 free, 3 planar), then one per joint."""
        return self.n + {None: 0, "free": 6, "planar": 3}[self.base_joint]

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The joints in the order of their coordinates in q (after the base joint's): the
        file's names where the robot was read from one (depth-first, as Pinocchio orders
        them), else q1, q2, …"""
        return tuple(link.name or f"q{i + 1}" for i, link in enumerate(self.links))

    @property
    def frame_names(self) -> tuple[str, ...]:
        """Every frame the task-space functions can serve (`with_frames`): the file's links, bodies
        and sites, the tool, and where no file names them "base" and link1 … linkn."""
        return tuple(frames.known_frames(self))

    @property
    def task_frames(self) -> tuple:
        """The `Frame`s the task-space functions serve, in order: those of `frames`, else the
        tool of a chain or each leaf link of a tree (`symdyn.model.frames.default_names`)."""
        return frames.resolve(self, self.frames or frames.default_names(self))

    def with_frames(self, names: Sequence[str]) -> "Robot":
        """A copy serving the frames `names` (in that order) in its task-space functions.

        Raises:
            ValueError: a name the robot does not know (the closest known ones are named),
                a name given twice, or no name.
        """
        names = names if isinstance(names, str) else tuple(names)  # a generator is read once
        frames.resolve(self, names)
        return dataclasses.replace(self, frames=names)

    def with_contacts(self, contacts: Mapping[str, str], *, kp: float = 0.0, kd: float = 0.0) -> "Robot":
        """A copy whose contact functions (`contact_fdyn`, `contact_impulse` and their derivatives)
        hold the frames of `contacts` — {frame name: "point" (its origin's linear acceleration: 3
        rows) or "surface" (its whole spatial acceleration: 6 rows)} in the order given; forces in
        the world's axes at the frame (LOCAL_WORLD_ALIGNED).  Each contact set is a model of its own.

        `kp`, `kd` ≥ 0: Baumgarte gains, as Pinocchio's `BaumgarteCorrectorParameters` on each
        contact: `contact_fdyn` then holds J a + γ = −kd J v − kp e.  With kp > 0 it and its
        derivatives take one more input, `anchor`: where each contact should be, in the world —
        x y z for a point, x y z qx qy qz qw for a surface (Pinocchio's XYZQUAT; any non-zero
        quaternion, read by its direction) — and e is the frame's error from it: p − p_anchor for a point, −log₆ of the
        frame's placement relative to the anchor in world axes for a surface (`docs/contacts.md`).
        The impact (`contact_impulse`) has no corrector.

        Raises:
            ValueError: an unknown frame (the closest known are named), a kind that is neither
                "point" nor "surface", no contact, or a gain that is negative or not finite.
        """
        return dataclasses.replace(self, contacts=tuple(dict(contacts).items()), baumgarte=(kp, kd))

    def require_chain(self, what: str) -> None:
        """Refuse a tree or a floating base where `what` reads chains only.

        Raises:
            NotImplementedError: the robot is a tree or has a base joint.
        """
        if not self.is_chain:
            shape = (
                f"a {self.base_joint} base" if self.base_joint else "a tree (links whose parent is not the link before)"
            )
            raise NotImplementedError(
                f"{what} reads serial chains on a fixed base; robot {self.name!r} has {shape}. "
                "The numeric reference (symdyn.reference) models trees and floating bases"
            )

    def require_fixed_base(self, what: str) -> None:
        """Refuse a floating base where `what` reads fixed-base robots (chains and trees) only.

        Raises:
            NotImplementedError: the robot has a base joint.
        """
        if self.base_joint is not None:
            raise NotImplementedError(
                f"{what} reads robots on a fixed base (chains and trees); robot {self.name!r} has a "
                f"{self.base_joint} base joint"
            )

    def integrate(self, q: Any, v: Any, dt: float = 1.0) -> np.ndarray:
        """q ⊕ v·dt: joints q + v·dt, a free base moved along its body-frame twist (SE(3)
        exponential, as Pinocchio's `integrate`), a planar one along SE(2)'s.  Batched.

        Raises:
            ValueError: q or v of the wrong size or not finite; a base quaternion whose norm
                is not 1 within 1e-6 (`normalize` it first).
        """
        from .base_joint import integrate

        return integrate(self, q, v, dt)

    def difference(self, q0: Any, q1: Any) -> np.ndarray:
        """v with q0 ⊕ v = q1 (Pinocchio's `difference`): the inverse of `integrate` over one unit of time.

        Raises:
            ValueError: q0 or q1 of the wrong size or not finite, or a quaternion of the wrong norm.
        """
        from .base_joint import difference

        return difference(self, q0, q1)

    def normalize(self, q: Any) -> np.ndarray:
        """q with its base quaternion of unit norm (the only coordinates that must be normalised).

        Raises:
            ValueError: q of the wrong size, not finite, or with a zero quaternion.
        """
        from .base_joint import normalize

        return normalize(self, q)

    def neutral(self) -> np.ndarray:
        """The zero configuration: joints 0, a free base at the origin with quaternion (0, 0, 0, 1)."""
        q = np.zeros(self.nq)
        if self.base_joint == "free":
            q[6] = 1.0
        return q

    @property
    def is_symbolic(self) -> bool:
        return bool(self.free_symbols)

    @property
    def free_symbols(self) -> frozenset:
        """The sympy symbols among the robot's parameters."""
        syms: set = set()
        for v in walk(self._params()):
            if isinstance(v, sp.Basic):
                syms |= v.free_symbols
        return frozenset(syms)

    @property
    def qlim(self) -> np.ndarray:
        """Joint limits as an (n, 2) float array; ±π (revolute) or ±1 m (prismatic) where unset."""
        out = np.empty((self.n, 2))
        for i, link in enumerate(self.links):
            if link.qlim is None:
                out[i] = (-math.pi, math.pi) if link.is_revolute else (-1.0, 1.0)
            else:
                out[i] = [float(x) for x in link.qlim]
        return out

    def __getattr__(self, name: str):
        # poses as attributes: robot.qz, robot.qr, ...
        poses = self.__dict__.get("poses", {})
        if name in poses:
            return np.array(poses[name], dtype=float)
        raise AttributeError(f"{type(self).__name__!s} has no attribute {name!r}")

    def _params(self) -> tuple:
        links = tuple(link._params() for link in self.links)
        # chosen frames enter the generated code: their names and placements count (none chosen:
        # the default frames follow from the fields here, and the fingerprint is what it was)
        chosen = (tuple(f.key() for f in self.task_frames),) if self.frames else ()
        if self.contacts:  # a contact set enters the generated code too
            placed = frames.resolve(self, [name for name, _ in self.contacts])
            chosen += (tuple((f.key(), kind) for f, (_, kind) in zip(placed, self.contacts)),)
            if any(self.baumgarte):  # gains enter the code; none: the fingerprint is what it was
                chosen += (("baumgarte",) + self.baumgarte,)
        if self.base_joint is None:  # a fixed base: the fingerprint is what it always was
            return (self.convention, self.gravity, self.base, self.tool, links) + chosen
        body = self.base_body._params() if self.base_body is not None else None
        return (self.convention, self.gravity, self.base, self.tool, links, self.base_joint, body) + chosen

    def fingerprint(self) -> str:
        """SHA-256 of every parameter that affects the dynamics (not name or poses)."""
        return hashlib.sha256(_canonical(self._params()).encode()).hexdigest()

    def dynamics_fingerprint(self) -> str:
        """The fingerprint without the chosen task frames and contact set: what the joint-space
        derivation depends on, so that the contact sets of one robot (each a model of its own)
        share one derivation (`derive`'s cache)."""
        if not (self.frames or self.contacts):
            return self.fingerprint()
        return dataclasses.replace(self, frames=(), contacts=(), baumgarte=(0.0, 0.0)).fingerprint()

    def require_numeric(self, what: str = "this operation") -> None:
        if self.is_symbolic:
            names = ", ".join(sorted(str(s) for s in self.free_symbols))
            raise ValueError(
                f"{what} needs a numeric robot, but {self.name!r} has symbolic "
                f"parameters {names}; substitute values with robot.subs({{...}})"
            )

    # ---- variants
    def subs(self, values: Mapping) -> "Robot":
        """Substitute values for symbolic parameters (the links', the base body's, gravity, base,
        tool and the file's frames); returns a new robot."""
        by_name = {str(s): s for s in self.free_symbols}  # "a1" names the real Symbol a1
        mapping = {by_name.get(k, sp.Symbol(k)) if isinstance(k, str) else k: sp.sympify(v) for k, v in values.items()}
        unknown = [k for k in mapping if k not in self.free_symbols]
        if unknown:
            raise KeyError(
                f"robot {self.name!r} has no parameter(s) {unknown}; "
                f"its symbols are {sorted(map(str, self.free_symbols))}"
            )

        def sub(x):
            if isinstance(x, sp.Basic):
                y = x.xreplace(mapping)
                return y if not y.is_Number else (float(y) if isinstance(y, sp.Float) else y)
            if isinstance(x, tuple):
                return tuple(sub(e) for e in x)
            return x

        def sub_link(link: Link) -> Link:
            return dataclasses.replace(
                link, **{f.name: sub(getattr(link, f.name)) for f in dataclasses.fields(link) if f.name != "joint"}
            )

        links = tuple(sub_link(link) for link in self.links)
        body = None if self.base_body is None else sub_link(self.base_body)
        catalog = tuple(dataclasses.replace(f, placement=sub(f.placement)) for f in self.frame_catalog)
        return dataclasses.replace(
            self,
            links=links,
            gravity=sub(self.gravity),
            base=sub(self.base),
            tool=sub(self.tool),
            base_body=body,
            frame_catalog=catalog,
        )

    def plot(self, q: Sequence[float] | None = None, *, ax: Any = None, title: str | None = None) -> Any:
        """A matplotlib Figure of the robot at q (default 0): the chain, joint axes, centres of
        mass, inertia ellipsoids and, read from a URDF, the whole tree with its locked branches
        and excluded subtrees marked (`symdyn.presentation.picture.plot`; `symdyn show` on the command
        line).  Save it with `fig.savefig("robot.png")`.

        Raises:
            ImportError: matplotlib is missing (pip install 'symdyn[plot]').
            ValueError: a symbolic robot, or q of the wrong length.
        """
        if _DRAWING is None:
            raise ImportError("Robot.plot draws through symdyn.presentation.picture: import symdyn first")
        return _DRAWING(self, q, ax=ax, title=title)

    def nofriction(self, all: bool = False) -> "Robot":  # noqa: A002 (Toolbox name)
        """Remove Coulomb friction; with `all=True` remove viscous friction too.  A robot as read
        from a file keeps its record, which then says what was left out (`print(robot)`)."""
        links = tuple(dataclasses.replace(link, Tc=(0, 0), B=0 if all else link.B) for link in self.links)
        out = dataclasses.replace(self, links=links)
        records = {
            key: record.without_friction(self, out, all)
            for key, record in (("urdf", self.urdf), ("mjcf", self.mjcf))
            if hasattr(record, "without_friction")
        }
        return dataclasses.replace(out, **records) if records else out

    def payload(self, m: Number, p: Sequence = (0, 0, 0), *, additive: bool = False) -> "Robot":
        """Attach a payload of mass m at p (frame of the last link).

        additive=False (the book's `payload`): the last link's mass becomes m
        and its COM p, its inertia tensor is kept ("this assumes the last link
        itself has no mass").  additive=True: a point mass m at p is *added*
        to the last link — combined mass, COM and inertia about the new COM.
        """
        m = _scalar(m, "payload mass")
        p = _vector(p, 3, "payload position")
        if not is_symbolic(m) and m < 0:
            raise ValueError(f"payload mass is negative: {m}")
        last = self.links[-1]
        if not additive:
            new = dataclasses.replace(last, m=m, r=p)
        else:
            new = dataclasses.replace(last, **_combine_mass(last.m, last.r, last.I, m, p))
        return dataclasses.replace(self, links=self.links[:-1] + (new,))

    def to_modified(self) -> "Robot":
        """The same arm in modified (Craig) DH, dynamics unchanged (`symdyn.model.reframe.to_modified`):
        a standard-DH chain's frames moved, a general robot's axes turned along its links' z.

        Raises:
            NotImplementedError: a standard-DH tree (`symdyn.derivation.kinematics.along_z` converts those).
        """
        return reframe.to_modified(self)


def _chain_parents_implicit(links: tuple, robot: str) -> tuple:
    """Links with each parent checked (a link before it, or -1) and written None where it is
    the link before, so that a chain written with explicit parents is the same chain."""
    out = []
    for i, link in enumerate(links):
        if link.parent is not None and not -1 <= link.parent < i:
            raise ValueError(
                f"link {i + 1} of robot {robot!r} names parent {link.parent}: a parent is the index of a "
                f"link before it (0…{i - 1}) or -1 for the base"
            )
        out.append(dataclasses.replace(link, parent=None) if link.parent == i - 1 else link)
    return tuple(out)


def _transform(T: Sequence, what: str) -> tuple:
    T = _matrix(T, 4, 4, what)
    if tuple(T[3]) != (0, 0, 0, 1) and not any(is_symbolic(x) for x in T[3]):
        if any(abs(float(x) - y) > 1e-12 for x, y in zip(T[3], (0, 0, 0, 1))):
            raise ValueError(f"{what} is not a homogeneous transform: last row is {T[3]}, expected (0, 0, 0, 1)")
    R = [row[:3] for row in T[:3]]
    if not any(is_symbolic(x) for row in R for x in row):
        Rn = np.array(R, dtype=float)
        if np.abs(Rn @ Rn.T - np.eye(3)).max() > 1e-9 or np.linalg.det(Rn) < 0:
            raise ValueError(f"{what} rotation is not a proper rotation matrix (R·Rᵀ ≠ 1 or det < 0): {R}")
    return T


def _combine_mass(m1, r1, I1, m2, r2) -> dict:
    """Mass, COM and COM inertia of two bodies: (m1, r1, I1) plus a point mass m2 at r2."""
    mt = m1 + m2
    if not is_symbolic(mt) and mt == 0:
        return {"m": 0, "r": r1, "I": I1}
    c = tuple((m1 * a + m2 * b) / mt for a, b in zip(r1, r2))

    def shift(mass, r):
        d = [r[i] - c[i] for i in range(3)]
        dd = sum(x * x for x in d)
        return [[mass * ((dd if i == j else 0) - d[i] * d[j]) for j in range(3)] for i in range(3)]

    s1, s2 = shift(m1, r1), shift(m2, r2)
    I = tuple(tuple(I1[i][j] + s1[i][j] + s2[i][j] for j in range(3)) for i in range(3))
    return {"m": mt, "r": c, "I": I}
