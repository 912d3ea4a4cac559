"""The kinematic tree of a URDF: links, joints, the chain from base to tip, the joints' values.

Every moving joint that is not on the chain is locked: its value is given
(`locked={"joint": value}`), follows its mimic leader (multiplier·leader +
offset), or defaults to 0 — the limit nearest 0 where 0 lies outside the
limits.  A chain joint named in `locked` is made fixed at that value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .xml import Element, URDFError, numbers, where

__all__ = ["Tree", "MOVING"]

#: URDF joint types that move along one axis → symdyn's joint type.
MOVING = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic"}
#: Types that can only be held still (at their zero configuration) off the chain.
MULTI = ("floating", "planar")


@dataclass
class Tree:
    """Links by name, joints by child link and by name, children by parent."""

    source: str
    robot: Element
    links: dict
    joints: dict  # child link → joint
    named: dict  # joint name → joint
    children: dict  # parent link → child links
    root: str

    @staticmethod
    def of(source: str, robot: Element) -> "Tree":
        links = {}
        for link in robot.findall("link"):
            if not link.name:
                raise URDFError(f"{where(source, link)} has no name")
            links[link.name] = link
        joints, named, children = {}, {}, {}
        for joint in robot.findall("joint"):
            for role in ("parent", "child"):
                ref = joint.find(role)
                if ref is None or "link" not in ref.attrib:
                    raise URDFError(f"{where(source, joint)} has no <{role} link=…>")
                if ref.attrib["link"] not in links:
                    raise URDFError(
                        f"{where(source, ref)} of joint {joint.name!r} names unknown link {ref.attrib['link']!r}"
                    )
            parent, child = joint.find("parent").attrib["link"], joint.find("child").attrib["link"]
            if child in joints:
                raise URDFError(f"{where(source, joint)}: link {child!r} has two parent joints")
            joints[child] = joint
            named[joint.name] = joint
            children.setdefault(parent, []).append(child)
        roots = [name for name in links if name not in joints]
        if not roots:
            raise URDFError(f"{source}: every link has a parent joint, so no link is the root: the joints form a cycle")
        if len(roots) > 1:
            raise URDFError(
                f"{source}: the links form {len(roots)} separate trees with roots {roots}; "
                "a URDF is one tree: connect them with joints"
            )
        tree = Tree(source, robot, links, joints, named, children, roots[0])
        loop = [name for name in links if name not in tree.below(roots[0])]
        if loop:
            raise URDFError(
                f"{where(source, joints[loop[0]])}: links {sorted(loop)} form a cycle "
                f"that does not reach the root {roots[0]!r}"
            )
        return tree

    def parent(self, link: str) -> str:
        return self.joints[link].find("parent").attrib["link"]

    def below(self, link: str, skip=frozenset()) -> set:
        """`link` and every link under it, not entering the links in `skip`."""
        reached, todo = set(), [link]
        while todo:
            name = todo.pop()
            reached.add(name)
            todo += [c for c in self.children.get(name, []) if c not in skip]
        return reached

    def chain(self, base: str | None, tip: str | None) -> tuple[str, str, list]:
        """base, tip and the joints from base to tip in order."""
        for role, flag, name in (("base_link", "--base", base), ("tip_link", "--tip", tip)):
            if name is not None and name not in self.links:
                said = f"is not a link of robot {self.robot.name!r}; its links are {sorted(self.links)}"
                raise URDFError(f"{self.source}: {role} {name!r} {said}", f"{self.source}: {flag} {name} {said}")
        base = base or self.root
        if tip is None:
            leaves = sorted(n for n in self.below(base) if not self.children.get(n))
            if len(leaves) != 1:
                said = (
                    f"{self.source}: the tree below {base!r} has several leaves {leaves}; choose the chain's end with "
                )
                raise URDFError(said + "tip_link=…", said + "--tip LINK")
            tip = leaves[0]
        path, name = [], tip
        while name != base:
            if name not in self.joints:
                raise URDFError(
                    f"{self.source}: tip_link {tip!r} is not below base_link {base!r}",
                    f"{self.source}: --tip {tip} is not below --base {base}",
                )
            path.append(self.joints[name])
            name = self.parent(name)
        return base, tip, path[::-1]

    def limits(self, joint: Element) -> tuple | None:
        """(lower, upper) of a limited joint, None for a continuous one or without limits."""
        limit = joint.find("limit")
        if joint.attrib.get("type") == "continuous" or limit is None or "lower" not in limit.attrib:
            return None
        lo = numbers(self.source, limit, "lower", 1)[0]
        hi = numbers(self.source, limit, "upper", 1, (0,))[0]
        return (lo, hi) if lo < hi else None

    def values(self, scope: set, moving: set, given: dict) -> dict:
        """Joint name → (value, why) of every joint in `scope` (joints by child link) that
        does not move: `moving` are the chain's moving joints, `given` the user's locks."""
        kinds = {name: j.attrib.get("type") for name, j in self.named.items()}
        in_scope = {self.joints[c].name for c in scope if c in self.joints}
        for name, value in given.items():
            joint = self.named.get(name)
            if joint is None:
                raise URDFError(
                    f"{self.source}: locked joint {name!r} is not a joint of robot "
                    f"{self.robot.name!r}; its moving joints are "
                    f"{sorted(n for n, k in kinds.items() if k in MOVING)}"
                )
            here = where(self.source, joint)
            if name not in in_scope:
                raise URDFError(
                    f"{here}: locked, but it is not below the base link or it is excluded: "
                    "its value cannot affect this robot"
                )
            if kinds[name] not in MOVING:
                raise URDFError(
                    f"{here}: a {kinds[name]} joint cannot be locked at a value "
                    "(revolute, continuous and prismatic joints can)"
                )
            if joint.find("mimic") is not None:
                raise URDFError(
                    f"{here}: a mimic joint follows its leader "
                    f"{joint.find('mimic').attrib.get('joint')!r}; lock the leader instead"
                )
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise URDFError(f"{here}: locked value {value!r} must be a finite number (rad or m)")
            lim = self.limits(joint)
            if lim and not lim[0] <= value <= lim[1]:
                raise URDFError(f"{here}: locked value {value!r} is outside its limits [{lim[0]}, {lim[1]}]")
        out = {}

        def value_of(name: str, seen: tuple = ()):
            if name in out:
                return out[name][0]
            joint = self.named[name]
            here = where(self.source, joint)
            if name in moving:
                return None
            mimic = joint.find("mimic")
            if kinds[name] == "fixed":
                return 0.0
            if kinds[name] in MULTI:
                out[name] = (0.0, "default")
            elif mimic is not None:
                leader = mimic.attrib.get("joint")
                if leader not in self.named or kinds[leader] not in MOVING:
                    raise URDFError(f"{here}: <mimic joint={leader!r}> does not name a moving joint")
                if leader in seen:
                    raise URDFError(f"{here}: mimic joints follow each other in a circle {list(seen)}")
                lead = value_of(leader, seen + (name,))
                if lead is None:
                    child = joint.find("child").attrib["link"]
                    said = f"{here}: mimics {leader!r}, which moves with the chain, so its body would move too: "
                    raise URDFError(
                        said + f"lock {leader!r} (locked={{{leader!r}: value}}) or exclude link {child!r}",
                        said + f"lock it (--lock {leader}=VALUE) or leave link {child} out (--exclude {child})",
                    )
                mult = numbers(self.source, mimic, "multiplier", 1, (1,))[0]
                offset = numbers(self.source, mimic, "offset", 1, (0,))[0]
                out[name] = (mult * lead + offset, f"mimic of {leader}")
            elif name in given:
                out[name] = (float(given[name]), "given")
            else:
                lim = self.limits(joint)
                out[name] = (min(max(0.0, lim[0]), lim[1]) if lim else 0.0, "default")
            return out[name][0]

        for name in sorted(in_scope):
            value_of(name)
        return out
