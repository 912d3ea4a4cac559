"""Trees and floating bases of a URDF: every joint of a chosen moving set moves, in the file's depth-first order.

`from_urdf(…, tips="all" | [links], base_joint=…)` reads through here: the
moving set is every revolute, continuous and prismatic joint below the base
(`tips="all"`) or those on the paths from the base to each listed link; the
rest locks and merges exactly as for a chain (`reader._Reader`).  The links
come in Pinocchio's order (`buildModelFromUrdf`): depth first from the base,
the joints below a link taken by name (urdfdom keeps them in a map), fixed
joints walked through.  Each link names its parent (`Link(parent=…)`) and its
joint (`Link(name=…)`).  With a base joint ("free", "planar") the base link
and everything fixed or locked to it become `Robot.base_body`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from ..placement import compose
from ..robot import IDENTITY, Link
from .bodies import Body, read_body
from .record import Locked
from .tree import MOVING, MULTI, Tree
from .xml import Element, URDFError, where

__all__ = ["Segment", "walk", "ordered", "moving_set", "file_base_joint", "massless_joints", "link_of"]


@dataclass
class Segment:
    """One rigid body of the robot: what its joint moves (`joint` None: the base), hung on
    segment `parent` (-1: the base) at `origin` (its joint's placement in the parent's frame),
    with everything fixed or locked to it merged into `body` (in its own frame)."""

    head: str
    joint: Element | None
    parent: int
    origin: tuple
    body: Body = field(default_factory=Body.empty)


def ordered(tree: Tree, link: str) -> list:
    """The links below `link`, ordered as Pinocchio's URDF parser walks them: by joint name."""
    return sorted(tree.children.get(link, []), key=lambda child: tree.joints[child].name or "")


def moving_set(tree: Tree, base: str, tips, excluded: set, given: dict, source: str) -> tuple[set, set]:
    """(the joints that move, the links on the paths from the base to them and to the tips).

    tips: "all" (every revolute, continuous and prismatic joint below the base that is not
    locked or excluded; a mimic joint moves on its own where its leader moves, as Pinocchio's
    parser reads it, and follows a locked leader) or link names (the joints on the paths from
    the base to each).  Joints in `given` are held (locked).
    """
    scope = tree.below(base, excluded) - {base}
    if tips == "all":
        moving = {
            tree.joints[c].name
            for c in scope
            if tree.joints[c].attrib.get("type") in MOVING
            and tree.joints[c].name not in given
            and tree.joints[c].find("mimic") is None
        }
        followers = {
            c: tree.joints[c].find("mimic").attrib.get("joint")
            for c in scope
            if tree.joints[c].find("mimic") is not None
        }
        grown = True
        while grown:  # mimics of mimics: a follower moves where the joint it follows moves
            grown = False
            for c, leader in followers.items():
                name = tree.joints[c].name
                if (
                    leader in moving
                    and name not in moving
                    and name not in given
                    and tree.joints[c].attrib.get("type") in MOVING
                ):
                    moving.add(name)
                    grown = True
        heads = {c for c in scope if tree.joints[c].name in moving}
    else:
        heads = set()
        for tip in tips:
            name = tip
            while name != base:
                heads.add(name)
                name = tree.parent(name)
        for child in sorted(heads):
            joint = tree.joints[child]
            kind = joint.attrib.get("type")
            if kind in MULTI or (kind not in MOVING and kind != "fixed"):
                raise URDFError(
                    f"{where(source, joint)}: joint type {kind!r} on the way to a tip is not supported "
                    "(revolute, continuous, prismatic and fixed are)"
                )
        moving = {
            tree.joints[c].name
            for c in heads
            if tree.joints[c].attrib.get("type") in MOVING and tree.joints[c].name not in given
        }
        for child in sorted(heads):
            joint = tree.joints[child]
            if joint.find("mimic") is not None and joint.name in moving:
                said = f"{where(source, joint)}: a mimic joint cannot move on its own: end its branch before it"
                raise URDFError(f"{said} (tips=[…]) or lock its leader", f"{said} (--tips) or lock its leader")
    on_path = {base}
    for head in heads:
        name = head
        while name not in on_path:
            on_path.add(name)
            name = tree.parent(name)
    return moving, on_path


def file_base_joint(tree: Tree, source: str, base_joint: str | None, base_link: str | None) -> Element | None:
    """The file's own floating (or planar) joint under a root that carries nothing else, taken as
    the base joint asked for (None where the file has none: the root is the floating body).

    Raises:
        URDFError: the file's joint is not the kind asked for (a planar joint whose plane is not
            the xy plane of its frame, or a floating joint for base_joint="planar" and the reverse).
    """
    if base_joint is None or base_link is not None:
        return None
    children = tree.children.get(tree.root, [])
    if len(children) != 1:
        return None
    joint = tree.joints[children[0]]
    kind = joint.attrib.get("type")
    if kind not in MULTI:
        return None
    axis = joint.find("axis")
    normal = tuple(float(x) for x in axis.attrib.get("xyz", "1 0 0").split()) if axis is not None else (1, 0, 0)
    if (kind, base_joint) == ("floating", "free") or (
        (kind, base_joint) == ("planar", "planar") and normal == (0, 0, 1)
    ):
        return joint
    child = children[0]
    said = (
        f"{where(source, joint)}: the file carries the robot on its own {kind} joint"
        + (f" about the normal {normal}" if kind == "planar" else "")
        + f", which is not base_joint={base_joint!r}"
    )
    raise URDFError(
        f"{said}: read link {child!r} as the floating body with base_link={child!r}",
        f"{said}: read link {child} as the floating body with --base {child}",
    )


def walk(reader, tree: Tree, base: str, moving: set, excluded: set, held: set, base_moves: bool) -> tuple:
    """(segments, frames): every moving joint's segment in Pinocchio's order (the base's first,
    index -1 as a parent), and each link reached → (its segment's index, its frame in that
    segment's frame).  Locked joints are recorded on `reader`, fixed joints walked through;
    `held` are the joints that would move but are locked (`Locked.on_chain`)."""
    base_segment = Segment(base, None, -1, IDENTITY)
    segments: list[Segment] = []
    frames: dict = {}
    todo: list = [(base, -1, IDENTITY, None)]
    while todo:  # depth first, in order: pop the next, push its children reversed
        name, seg, T, joint = todo.pop()
        if joint is not None:  # a moving joint reached: its segment, numbered in pre-order
            segments.append(Segment(name, joint, seg, T))
            seg, T = len(segments) - 1, IDENTITY
        here = segments[seg] if seg >= 0 else base_segment
        moves = seg >= 0 or base_moves
        frames[name] = (seg, T)
        body = read_body(
            reader.source,
            tree.links[name],
            lambda e, name=name: reader.origin(e, f"link {name!r} inertial origin"),
            reader._complain(moves, name, here.head),
            reader._balance(name) if moves and reader.balance else None,
        )
        here.body = here.body + body.moved(T)
        pushed = []
        for child in ordered(tree, name):
            if child in excluded:
                continue
            joint = tree.joints[child]
            kind = joint.attrib.get("type")
            To = compose(T, reader.origin(joint, f"joint {joint.name!r} origin"))
            if joint.name in moving:
                pushed.append((child, seg, To, joint))
                continue
            if kind in MOVING:
                value, why = reader.values[joint.name]
                reader.locked.append(Locked(joint.name, value, here.head, why, moves, on_chain=joint.name in held))
                To = compose(To, reader.motion(joint, value))
            elif kind in MULTI:
                reader.locked.append(Locked(joint.name, 0.0, here.head, "default", moves))
            elif kind != "fixed":
                raise URDFError(f"{where(reader.source, joint)}: unknown joint type {kind!r}")
            pushed.append((child, seg, To, None))
        todo += reversed(pushed)
    return base_segment, segments, frames


def massless_joints(names: list, links: list, parents: tuple) -> list:
    """The joints that move no mass and no inertia: their link and every link below it carry none."""
    carries = [not (link.m == 0 and all(x == 0 for row in link.I for x in row)) for link in links]
    for i in reversed(range(len(links))):
        if carries[i] and parents[i] >= 0:
            carries[parents[i]] = True
    return [name for name, c in zip(names, carries) if not c]


def link_of(reader, segment: Segment, parent: int) -> Link:
    """The `Link` of a moving segment, hung on link `parent` (-1: the base), named after its joint."""
    link = reader.link(segment.joint, segment.origin, segment.body)
    return dataclasses.replace(link, parent=parent, name=segment.joint.name)
