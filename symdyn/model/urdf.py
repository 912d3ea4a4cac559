"""URDF in: `from_urdf(path_or_xml, base_link=…, tip_link=…)` → a general-convention `Robot`.

Reads the chain from `base_link` to `tip_link`: revolute, continuous and
prismatic joints become links placed by their `<origin>` about their
`<axis>`; fixed joints are folded in — into the next joint's origin, and
the bodies they carry (with everything hanging off the chain through fixed
joints) are merged into the moving body they ride on, with mass, centre of
mass and inertia combined exactly; after the last moving joint they form the
tool.  Moving branches off the chain are left out.  A link without
`<inertial>` is massless (as the URDF spec and Pinocchio read it).
Limits, effort and velocity limits, damping (viscous) and friction
(Coulomb) are read where given.  What the model cannot represent (floating
or planar joints or mimic joints in the chain) and what is physically
impossible (negative mass, an inertia that is not positive semidefinite or
violates the triangle inequality) is refused with the element's name and
line.  The standard library's expat parser is enough for URDF and gives
those line numbers; no URDF package is needed.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

import numpy as np
import sympy as sp

from .placement import exact, placement
from .robot import IDENTITY, Link, Robot

__all__ = ["from_urdf", "URDFError"]

_MOVING = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic"}
_UNSUPPORTED = ("floating", "planar")


class URDFError(ValueError):
    """A URDF the model cannot take; the message names the element and its line."""


@dataclass
class _Element:
    tag: str
    attrib: dict
    line: int
    children: list = field(default_factory=list)

    def find(self, tag: str) -> "_Element | None":
        return next((c for c in self.children if c.tag == tag), None)

    def findall(self, tag: str) -> list:
        return [c for c in self.children if c.tag == tag]


def _parse(text: str, source: str) -> _Element:
    """The XML tree with the line of every element (expat keeps them; ElementTree does not)."""
    parser = expat.ParserCreate()
    stack: list[_Element] = []
    root: list[_Element] = []

    def start(tag, attrib):
        element = _Element(tag, attrib, parser.CurrentLineNumber)
        (stack[-1].children if stack else root).append(element)
        stack.append(element)

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    try:
        parser.Parse(text, True)
    except expat.ExpatError as exc:
        raise URDFError(f"{source}: not well-formed XML: {exc}") from None
    if not root or root[0].tag != "robot":
        raise URDFError(f"{source}: the root element must be <robot>, got <{root[0].tag if root else ''}>")
    return root[0]


# --------------------------------------------------------------------------- reading elements

def _where(source: str, element: _Element) -> str:
    name = element.attrib.get("name")
    return f"{source}:{element.line}: <{element.tag}{f' name={name!r}' if name else ''}>"


def _numbers(source: str, element: _Element | None, attr: str, count: int, default=None) -> list:
    if element is None or attr not in element.attrib:
        if default is None:
            raise URDFError(f"{_where(source, element)} has no {attr}")
        return list(default)
    try:
        values = [float(x) for x in element.attrib[attr].split()]
    except ValueError:
        values = []
    if len(values) != count or any(v != v or abs(v) == float("inf") for v in values):
        raise URDFError(f"{_where(source, element)}: {attr}={element.attrib[attr]!r} must be {count} finite numbers")
    return values


def _origin(source: str, element: _Element | None) -> tuple:
    """The exact 4×4 transform of an `<origin xyz rpy>` child (identity when absent)."""
    origin = element.find("origin") if element is not None else None
    if origin is None:
        return IDENTITY
    return placement(_numbers(source, origin, "xyz", 3, (0, 0, 0)), _numbers(source, origin, "rpy", 3, (0, 0, 0)))


@dataclass(frozen=True)
class _Body:
    """Mass, COM and COM inertia of a rigid body in some frame (exact numbers)."""

    m: sp.Expr
    r: tuple
    I: tuple

    @staticmethod
    def empty() -> "_Body":
        zero = sp.S.Zero
        return _Body(zero, (zero,) * 3, ((zero,) * 3,) * 3)

    def moved(self, T: tuple) -> "_Body":
        """The same body seen from the frame in which T places its frame."""
        R = [row[:3] for row in T[:3]]
        r = tuple(T[i][3] + sum(R[i][k] * self.r[k] for k in range(3)) for i in range(3))
        I = tuple(tuple(sum(R[i][k] * self.I[k][l] * R[j][l] for k in range(3) for l in range(3))
                        for j in range(3)) for i in range(3))
        return _Body(self.m, r, I)

    def __add__(self, other: "_Body") -> "_Body":
        m = self.m + other.m
        if m == 0:   # no COM; an inertia without mass is the same about any point (Pinocchio keeps it too)
            return _Body(m, (sp.S.Zero,) * 3, tuple(tuple(a + b for a, b in zip(p, q))
                                                    for p, q in zip(self.I, other.I)))
        c = tuple((self.m * a + other.m * b) / m for a, b in zip(self.r, other.r))

        def about_c(body):
            d = [body.r[i] - c[i] for i in range(3)]
            dd = sum(x * x for x in d)
            return [[body.I[i][j] + body.m * ((dd if i == j else 0) - d[i] * d[j]) for j in range(3)]
                    for i in range(3)]

        a, b = about_c(self), about_c(other)
        return _Body(m, c, tuple(tuple(a[i][j] + b[i][j] for j in range(3)) for i in range(3)))


def _check_inertia(source: str, tensor: _Element, link: _Element, I: tuple) -> None:
    """Refuse a link's own inertia that is not positive semidefinite or violates the
    triangle inequality (checked here, before a merge could hide it; the tolerances of
    the `Link` checks)."""
    eig = np.linalg.eigvalsh(np.array(I, dtype=float))
    what = f"{_where(source, tensor)} of link {link.attrib.get('name')!r}"
    if eig.min() < -1e-12 * max(1.0, abs(eig).max()):
        raise URDFError(f"{what} is not positive semidefinite: principal moments {eig.tolist()}")
    if eig[0] + eig[1] < eig[2] * (1 - 1e-9):
        raise URDFError(f"{what} is physically impossible: its principal moments {eig.tolist()} "
                        "violate the triangle inequality (I1 + I2 >= I3)")


def _body(source: str, link: _Element) -> _Body:
    """A link's `<inertial>` in the link frame (massless when absent)."""
    inertial = link.find("inertial")
    if inertial is None:
        return _Body.empty()
    mass = inertial.find("mass")
    if mass is None:
        raise URDFError(f"{_where(source, inertial)} of link {link.attrib.get('name')!r} has no <mass>")
    m = _numbers(source, mass, "value", 1)[0]
    if m < 0:
        raise URDFError(f"{_where(source, mass)}: the mass of link {link.attrib.get('name')!r} is negative: {m}")
    tensor = inertial.find("inertia")
    if tensor is None:
        raise URDFError(f"{_where(source, inertial)} of link {link.attrib.get('name')!r} has no <inertia>")
    names = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    xx, xy, xz, yy, yz, zz = (exact(_numbers(source, tensor, k, 1, (0,))[0]) for k in names)
    _check_inertia(source, tensor, link, ((xx, xy, xz), (xy, yy, yz), (xz, yz, zz)))
    local = _Body(exact(m), (sp.S.Zero,) * 3, ((xx, xy, xz), (xy, yy, yz), (xz, yz, zz)))
    return local.moved(_origin(source, inertial))


# --------------------------------------------------------------------------- the chain

def _chain(source: str, robot: _Element, base: str | None, tip: str | None):
    """Links by name, joints by child, and the joints from base to tip in order."""
    links = {}
    for link in robot.findall("link"):
        name = link.attrib.get("name")
        if not name:
            raise URDFError(f"{_where(source, link)} has no name")
        links[name] = link
    joints, children = {}, {}
    for joint in robot.findall("joint"):
        for role in ("parent", "child"):
            ref = joint.find(role)
            if ref is None or "link" not in ref.attrib:
                raise URDFError(f"{_where(source, joint)} has no <{role} link=…>")
            if ref.attrib["link"] not in links:
                raise URDFError(f"{_where(source, ref)} of joint {joint.attrib.get('name')!r} names unknown "
                                f"link {ref.attrib['link']!r}")
        parent, child = joint.find("parent").attrib["link"], joint.find("child").attrib["link"]
        if child in joints:
            raise URDFError(f"{_where(source, joint)}: link {child!r} has two parent joints")
        joints[child] = joint
        children.setdefault(parent, []).append(child)
    roots = [name for name in links if name not in joints]
    if len(roots) != 1:
        raise URDFError(f"{source}: expected one root link, found {roots or 'none (a cycle)'}")
    reached, todo = set(), [roots[0]]
    while todo:
        name = todo.pop()
        reached.add(name)
        todo += children.get(name, [])
    loop = [name for name in links if name not in reached]   # each has a parent, none reaches the root
    if loop:
        raise URDFError(f"{_where(source, joints[loop[0]])}: links {sorted(loop)} form a cycle "
                        f"that does not reach the root {roots[0]!r}")
    for role, name in (("base_link", base), ("tip_link", tip)):
        if name is not None and name not in links:
            raise URDFError(f"{source}: {role} {name!r} is not a link of robot {robot.attrib.get('name')!r}; "
                            f"its links are {sorted(links)}")
    base = base or roots[0]
    if tip is None:
        leaves, todo = [], [base]
        while todo:
            name = todo.pop()
            kids = children.get(name, [])
            leaves += [] if kids else [name]
            todo += kids
        if len(leaves) != 1:
            raise URDFError(f"{source}: the tree below {base!r} has several leaves {sorted(leaves)}; "
                            "choose the chain's end with tip_link=…")
        tip = leaves[0]
    path, name = [], tip
    while name != base:
        if name not in joints:
            raise URDFError(f"{source}: tip_link {tip!r} is not below base_link {base!r}")
        path.append(joints[name])
        name = joints[name].find("parent").attrib["link"]
    return links, joints, children, path[::-1]


def _fixed_subtree(source, links, joints, children, name, on_chain) -> _Body:
    """Link `name` with everything hanging off it through fixed joints (not the chain), in its frame."""
    body = _body(source, links[name])
    for child in children.get(name, []):
        joint = joints[child]
        if child in on_chain or joint.attrib.get("type") != "fixed":
            continue
        body = body + _fixed_subtree(source, links, joints, children, child, on_chain).moved(_origin(source, joint))
    return body


def _compose(A: tuple, B: tuple) -> tuple:
    return tuple(tuple(sum(A[i][k] * B[k][j] for k in range(4)) for j in range(4)) for i in range(4))


def _number(x: sp.Expr):
    """A value for the Link: an int, or a float when its decimal is the exact value
    (as a derivation reads it back), else the exact Rational."""
    x = sp.sympify(x)   # the identity's entries are plain ints
    if x.is_Integer:
        return int(x)
    return float(x) if exact(float(x)) == x else x


def _link(source: str, joint: _Element, origin: tuple, body: _Body) -> Link:
    kind = _MOVING[joint.attrib["type"]]
    axis = _numbers(source, joint.find("axis"), "xyz", 3, (1, 0, 0))
    norm = sum(a * a for a in axis) ** 0.5
    if norm == 0:
        raise URDFError(f"{_where(source, joint)}: the axis is zero")
    axis = tuple(a / norm if abs(norm - 1) > 1e-12 else a for a in axis)
    limit, dynamics = joint.find("limit"), joint.find("dynamics")
    qlim = None
    if joint.attrib["type"] != "continuous" and limit is not None and "lower" in limit.attrib:
        lo, hi = _numbers(source, limit, "lower", 1)[0], _numbers(source, limit, "upper", 1, (0,))[0]
        qlim = (lo, hi) if lo < hi else None
    effort = _numbers(source, limit, "effort", 1, (0,))[0] if limit is not None else 0
    velocity = _numbers(source, limit, "velocity", 1, (0,))[0] if limit is not None else 0
    damping = _numbers(source, dynamics, "damping", 1, (0,))[0] if dynamics is not None else 0
    friction = _numbers(source, dynamics, "friction", 1, (0,))[0] if dynamics is not None else 0
    try:
        return Link(joint=kind, origin=tuple(tuple(_number(x) for x in row) for row in origin), axis=axis,
                    qlim=qlim, m=_number(body.m), r=tuple(_number(x) for x in body.r),
                    I=tuple(tuple(_number(x) for x in row) for row in body.I),
                    B=damping, Tc=(friction, -friction), effort_limit=effort or None,
                    velocity_limit=velocity or None)
    except ValueError as exc:
        raise URDFError(f"{_where(source, joint)}: {exc}") from None


def from_urdf(path_or_xml, base_link: str | None = None, tip_link: str | None = None, *,
              name: str | None = None) -> Robot:
    """A `Robot` (general convention) of the chain from `base_link` (default: the
    root) to `tip_link` (default: the only leaf) of a URDF file or string."""
    text, source = _read(path_or_xml)
    robot = _parse(text, source)
    links, joints, children, path = _chain(source, robot, base_link, tip_link)
    on_chain = {j.find("child").attrib["link"] for j in path} | {j.find("parent").attrib["link"] for j in path}
    pending, carrier, body, out = IDENTITY, None, _Body.empty(), []
    for joint in path:   # pending: from the moving body's frame (or the base) to the joint reached
        kind = joint.attrib.get("type")
        if kind in _UNSUPPORTED or (kind not in _MOVING and kind != "fixed"):
            raise URDFError(f"{_where(source, joint)}: joint type {kind!r} in the chain is not supported "
                            "(revolute, continuous, prismatic and fixed are)")
        if joint.find("mimic") is not None and kind in _MOVING:
            raise URDFError(f"{_where(source, joint)}: mimic joints in the chain are not supported")
        sub = _fixed_subtree(source, links, joints, children, joint.find("child").attrib["link"], on_chain)
        T = _compose(pending, _origin(source, joint))
        if kind == "fixed":
            pending = T
            body = body + sub.moved(T) if carrier else body   # ahead of the first joint: part of the base
            continue
        if carrier:
            out.append(_link(source, *carrier, body))
        carrier, pending, body = (joint, T), IDENTITY, sub
    if carrier is None:
        raise URDFError(f"{source}: the chain from {path[0].find('parent').attrib['link'] if path else base_link!r} "
                        f"to its tip has no moving joint")
    out.append(_link(source, carrier[0], carrier[1], body))
    tool = tuple(tuple(_number(x) for x in row) for row in pending)
    return Robot(name or robot.attrib.get("name", "urdf"), tuple(out), convention="general", tool=tool,
                 source=f"URDF {source}")


def _read(path_or_xml) -> tuple[str, str]:
    """The URDF text and a name for messages: a path (str or Path) or the XML itself."""
    if isinstance(path_or_xml, os.PathLike) or (isinstance(path_or_xml, str) and "<" not in path_or_xml):
        path = Path(path_or_xml)
        try:
            return path.read_text(), str(path)
        except OSError as exc:
            raise URDFError(f"cannot read URDF file {str(path)!r}: {exc.strerror}") from None
    if not isinstance(path_or_xml, str):
        raise URDFError(f"from_urdf needs a path or the URDF text, got {type(path_or_xml).__name__}")
    return path_or_xml, "<urdf string>"
