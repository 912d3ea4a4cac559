"""`from_urdf`: the chain from `base_link` to `tip_link` of a URDF as a general-convention `Robot`.

Revolute, continuous and prismatic chain joints become links placed by their
`<origin>` about their `<axis>`.  Everything else below the base is kept,
never dropped: fixed joints are folded into the next joint's origin, and
every body that rides on a moving link — through fixed joints or through
*locked* joints off the chain (fingers, a head, another arm) — is merged into
it, mass, centre of mass and inertia combined exactly; after the last moving
joint they form the tool.  `exclude=[links]` drops subtrees on purpose.
Angles and axes near exact values are snapped by one documented rule
(`symdyn.model.snapping`).  Strict where it matters, tolerant where it
cannot: a defect of a body that enters the dynamics is an error naming the
element and line; the same defect on a body resting on the fixed base is a
warning.  What was chosen, locked, excluded and snapped is `robot.urdf`.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from ..placement import compose, joint_motion, link_number, placement, rpy_rotation
from ..frames import Frame, served
from ..robot import BASE_JOINTS, IDENTITY, Link, Robot
from ..snapping import Snapping, snap_angle, snap_axis
from .xacro import Expansion, XacroError, expand, is_xacro
from . import branches
from .bodies import Body, balanced, read_body
from .record import Bone, Locked, Repair, Snap, UrdfRecord
from .tree import MOVING, MULTI, Tree
from .xml import Element, Text, URDFError, URDFWarning, numbers, parse, read, where

__all__ = ["from_urdf"]


class _Reader:
    """One reading of one file: its tree, the snapping rule, the locks, what was noted."""

    def __init__(self, tree: Tree, file: str, snap: bool, balance: bool = False, on_chain: frozenset = frozenset()):
        self.tree, self.source, self.file, self.snap = tree, tree.source, file, snap
        self.balance, self.on_chain = balance, on_chain
        self.repairs: list[Repair] = []
        self.snaps: list[Snap] = []
        self.warnings: list[str] = []
        self.locked: list[Locked] = []
        self.values: dict = {}
        self.frames: dict = {}  # each link reached → (the robot link it rides on, its frame in that link's)
        self.refusals: list[tuple[str, str]] = []  # (message, its command-line words): raised together

    # ---- numbers, snapped by the one rule
    def _angle(self, value: float, what: str) -> float:
        snapped = snap_angle(value) if self.snap else None
        if snapped is None:
            return value
        self.snaps.append(Snap(what, repr(value), snapped.label, snapped.change))
        return snapped.value

    def origin(self, element: Element | None, what: str) -> tuple:
        """The exact 4×4 transform of an `<origin xyz rpy>` child (identity when absent)."""
        origin = element.find("origin") if element is not None else None
        if origin is None:
            return IDENTITY
        xyz = numbers(self.source, origin, "xyz", 3, (0, 0, 0))
        rpy = numbers(self.source, origin, "rpy", 3, (0, 0, 0))
        place = f"{self.file}:{origin.line} {what} rpy"
        rpy = [self._angle(x, f"{place}[{i}]") for i, x in enumerate(rpy)]
        return placement(xyz, rpy)

    def axis(self, joint: Element) -> tuple:
        """The joint's unit axis (normalised as Pinocchio does; snapped to ±x, ±y, ±z by the rule)."""
        axis = numbers(self.source, joint.find("axis"), "xyz", 3, (1, 0, 0))
        norm = sum(a * a for a in axis) ** 0.5
        if norm == 0:
            raise URDFError(f"{where(self.source, joint)}: the axis is zero")
        axis = tuple(a / norm if abs(norm - 1) > 1e-12 else a for a in axis)
        snapped = snap_axis(axis) if self.snap else None
        if snapped is None:
            return axis
        line = joint.find("axis").line if joint.find("axis") is not None else joint.line
        self.snaps.append(
            Snap(
                f"{self.file}:{line} joint {joint.name!r} axis",
                " ".join(map(repr, axis)),
                snapped.label,
                snapped.change,
            )
        )
        return snapped.value

    def motion(self, joint: Element, value: float) -> tuple:
        """The exact transform of a revolute, continuous or prismatic `joint` held at `value`."""
        return joint_motion(MOVING[joint.attrib["type"]], self.axis(joint), value)

    # ---- bodies
    def _branch(self, name: str) -> str:
        """The first link off the chain on the way from the chain to link `name`."""
        while self.tree.parent(name) not in self.on_chain:
            name = self.tree.parent(name)
        return name

    def _complain(self, moves: bool, name: str, into: str):
        if moves:

            def refuse(message: str) -> None:
                repairable = "impossible" in message or "positive semidefinite" in message
                fix = ("repair it with inertia='balance' (the nearest physical inertia, reported)", "--balance-inertia")
                if name in self.on_chain:
                    ways = ["correct the file"] + ([fix[0]] if repairable else [])
                    flags = ["correct the file"] + ([fix[1]] if repairable else [])
                    say = f"; link {name!r} is on the chain: "
                    raise URDFError(message + say + ", or ".join(ways), message + say + ", or ".join(flags))
                branch = self._branch(name)
                also = f" (or the branch it hangs from: exclude=[{branch!r}])" if branch != name else ""
                also_cli = f" (or the branch it hangs from: --exclude {branch})" if branch != name else ""
                say = f"; link {name!r} is off the chain, riding on the moving link {into!r}: leave it out with "
                raise URDFError(
                    message + say + f"exclude=[{name!r}]{also}" + (f", or {fix[0]}" if repairable else ""),
                    message + say + f"--exclude {name}{also_cli}" + (f", or {fix[1]}" if repairable else ""),
                )

            def collect(message: str) -> None:  # every defect of the file named in one error
                try:
                    refuse(message)
                except URDFError as exc:
                    self.refusals.append((str(exc), exc.command_line))

            return collect

        def warn(message: str) -> None:  # issued by from_urdf, to its caller
            self.warnings.append(
                message + "; accepted: it rests on the fixed base and cannot affect the dynamics (it is left out)"
            )

        return warn

    def subtree(self, name: str, skip: set, into: str, moves: bool, seg: int = -1, at: tuple = IDENTITY) -> Body:
        """Link `name` with everything hanging off it except the links in `skip` (the chain,
        excluded subtrees), in its frame; locked joints are recorded as merged into `into`, and
        each link's frame as riding on robot link `seg` (-1: the base) at `at` (name's frame in it)."""
        self.frames[name] = (seg, at)
        link = self.tree.links[name]
        body = read_body(
            self.source,
            link,
            lambda e: self.origin(e, f"link {name!r} inertial origin"),
            self._complain(moves, name, into),
            self._balance(name) if moves and self.balance else None,
        )
        for child in self.tree.children.get(name, []):
            if child in skip:
                continue
            joint = self.tree.joints[child]
            kind = joint.attrib.get("type")
            T = self.origin(joint, f"joint {joint.name!r} origin")
            if kind in MOVING:
                value, why = self.values[joint.name]
                self.locked.append(Locked(joint.name, value, into, why, moves))
                T = compose(T, joint_motion(MOVING[kind], self.axis(joint), value))
            elif kind in MULTI:
                self.locked.append(Locked(joint.name, 0.0, into, "default", moves))
            elif kind != "fixed":
                raise URDFError(f"{where(self.source, joint)}: unknown joint type {kind!r}")
            body = body + self.subtree(child, skip, into, moves, seg, compose(at, T)).moved(T)
        return body

    def _balance(self, name: str):
        def balance(tensor: Element, I: tuple, defect: str) -> tuple:
            J, before, after = balanced(I)
            change = float(np.linalg.norm(after - before) / max(abs(before).max(), 1e-300))
            self.repairs.append(
                Repair(name, f"{self.file}:{tensor.line}", tuple(before.tolist()), tuple(after.tolist()), change)
            )
            return J

        return balance

    def raise_refusals(self) -> None:
        """One URDFError naming every body the file makes impossible (each with its ways out),
        so that a user fixes them all at once; nothing when there is none."""
        if len(self.refusals) == 1:
            raise URDFError(*self.refusals[0])
        if self.refusals:
            head = f"{self.file}: {len(self.refusals)} bodies that move are no physical body; each with its way out:"
            raise URDFError(
                "\n  ".join([head, *(m for m, _ in self.refusals)]),
                "\n  ".join([head, *(c for _, c in self.refusals)]),
            )

    # ---- the chain's links
    def link(self, joint: Element, origin: tuple, body: Body) -> Link:
        kind = MOVING[joint.attrib["type"]]
        limit, dynamics = joint.find("limit"), joint.find("dynamics")
        qlim = self.tree.limits(joint)
        effort = numbers(self.source, limit, "effort", 1, (0,))[0] if limit is not None else 0
        velocity = numbers(self.source, limit, "velocity", 1, (0,))[0] if limit is not None else 0
        damping = numbers(self.source, dynamics, "damping", 1, (0,))[0] if dynamics is not None else 0
        friction = numbers(self.source, dynamics, "friction", 1, (0,))[0] if dynamics is not None else 0
        try:
            return Link(
                joint=kind,
                origin=tuple(tuple(link_number(x) for x in row) for row in origin),
                axis=self.axis(joint),
                qlim=qlim,
                m=link_number(body.m),
                r=tuple(link_number(x) for x in body.r),
                I=tuple(tuple(link_number(x) for x in row) for row in body.I),
                B=damping,
                Tc=(friction, -friction),
                effort_limit=effort or None,
                velocity_limit=velocity or None,
                name=joint.name,
            )
        except ValueError as exc:
            raise URDFError(f"{where(self.source, joint)}: {exc}") from None


@dataclasses.dataclass(frozen=True)
class _Xacro:
    """A xacro file's expansion: `urdf` the text read (its source and file name say it is the
    expansion, whose lines the messages name), `expansion` what the record keeps."""

    urdf: Text
    expansion: Expansion

    def record_fields(self) -> dict:
        return {
            "xacro_args": self.expansion.args,
            "packages": self.expansion.packages,
            "expanded_sha256": self.urdf.sha256,
        }


def _expanded(path_or_xml, text: Text, xacro_args, package_paths) -> _Xacro | None:
    """The expansion of a xacro file or text (None for plain URDF, which takes no xacro options)."""
    package_paths = [package_paths] if isinstance(package_paths, (str, os.PathLike)) else list(package_paths)
    if not is_xacro(text.source if text.source != "<urdf string>" else text.text, text.text):
        if xacro_args or package_paths:
            given = ", ".join(k for k, v in (("xacro_args", xacro_args), ("package_paths", package_paths)) if v)
            raise XacroError(
                f"{text.source}: {given} apply to a xacro file (.xacro, or declaring xmlns:xacro); this is plain URDF",
                f"{text.source}: --xacro-arg and --package-path apply to a xacro file (.xacro, or declaring "
                "xmlns:xacro); this is plain URDF",
            )
        return None
    is_path = text.source != "<urdf string>"
    expansion = expand(
        Path(path_or_xml) if is_path else None,
        text=text.text,
        xacro_args=xacro_args,
        package_paths=package_paths,
        source=text.source,
    )
    label = "<xacro string>" if not is_path else text.file
    return _Xacro(Text(expansion.text, f"{text.source} (expanded by xacro)", f"{label} (expanded)"), expansion)


def _excluded(tree: Tree, exclude, on_chain: set, below_base: set) -> tuple:
    if isinstance(exclude, str):
        exclude = [exclude]
    for name in exclude:
        if name not in tree.links:
            raise URDFError(f"{tree.source}: excluded link {name!r} is not a link of robot {tree.robot.name!r}")
        if name in on_chain:
            said = f"{tree.source}: excluded link {name!r} is on the chain from base to tip; "
            raise URDFError(
                said + "choose another base_link or tip_link instead", said + "choose another --base or --tip"
            )
        if name not in below_base:
            raise URDFError(f"{tree.source}: excluded link {name!r} is not below base_link: it is out already")
    return tuple(exclude)


def from_urdf(
    path_or_xml: str | os.PathLike[str],
    *,
    base_link: str | None = None,
    tip_link: str | None = None,
    tips: str | Iterable[str] | None = None,
    base_joint: str | None = None,
    locked: dict | None = None,
    exclude: str | Iterable[str] = (),
    snap: bool = True,
    name: str | None = None,
    xacro_args: Mapping[str, object] | None = None,
    package_paths: Iterable[str | os.PathLike[str]] = (),
    inertia: str = "check",
    massless: bool = False,
    frames: Iterable[str] | None = None,
) -> Robot:
    """A `Robot` (general convention) of the chain from `base_link` (default: the
    root) to `tip_link` (default: the only leaf) of a URDF file or its text, or of a
    tree (`tips`), on a fixed or floating base (`base_joint`).

    tips: "all" moves every revolute, continuous and prismatic joint below the base
    (`locked` joints are held, and mimic joints follow a locked leader; a mimic joint whose
    leader moves moves on its own, as Pinocchio's URDF parser reads it, with a warning and a
    record line saying so); a list of links moves
    the joints on the paths from the base to each (their union); None (default): the
    chain to `tip_link`.  The links come in the file's depth-first order as Pinocchio's
    `buildModelFromUrdf` gives it (`model.names[1:]`: the joints below a link by name),
    each naming its parent (`robot.parents`) and its joint (`robot.joint_names`).
    base_joint: None (a fixed base), "free" (Pinocchio's free-flyer: q = [x, y, z, qx, qy,
    qz, qw, joints…]) or "planar" (x, y, yaw): `base_link` (default: the root) with
    everything fixed or locked to it becomes the floating body (`robot.base_body`).  A
    root link whose only joint is the file's own `floating` joint (a planar one about z
    for "planar") is read as that base joint: its child floats, placed by its origin.

    A xacro file (`.xacro`, or text declaring the xacro namespace) is expanded
    first, in-process and without ROS (`symdyn.model.urdf.xacro`): `xacro_args`
    ({"ur_type": "ur5e"}, as `ur_type:=ur5e`), `$(find pkg)` and `package://pkg/`
    from `package_paths`, `ROS_PACKAGE_PATH`, `AMENT_PREFIX_PATH`, then the
    folders above the file.  Messages then name the expanded text's lines.

    locked: {joint: value} for joints off the chain (default: 0, or the limit
    nearest 0 when 0 is outside the limits; mimic joints follow their leader)
    or on it (made fixed at that value).  exclude: links dropped with their
    subtrees.  snap: angles and axes near exact values become exact
    (`symdyn.model.snapping`); False keeps the file's numbers.  The robot's
    `urdf` records all of it.  Raises URDFError naming the element and line.

    inertia: "check" (default) refuses an impossible inertia (not positive semidefinite,
    or principal moments against the triangle inequality) of a body that moves, naming
    it and the ways out; "balance" replaces each by the nearest physical inertia
    (Frobenius norm, same principal axes: the smallest change that makes it physical,
    like MuJoCo's `balanceinertia` but not its averaging), every repair recorded with
    its size (`robot.urdf.repairs`, `print(robot)`, a warning).  name: default the
    file's name without .urdf/.xacro (as on the command line, where it names the
    generated files), or `<robot name>` for text.  massless: read a chain whose last
    moving links carry no mass at all (a file without `<inertial>`s, written for
    kinematics), with a warning naming them, instead of refusing it: its M(q) is
    singular for every q, so it serves kinematics, printing and pictures only.
    frames: the frames its task-space functions serve, in order (`Robot.with_frames`: any
    link of the file); default: the tips when `tips` names several, else `Robot.task_frames`'.

    Raises:
        URDFError: (a `ValueError`) an unreadable file or text that is not a URDF
            (not well-formed XML, no `<robot>` or no link); a malformed tree
            (nameless links, joints without parent or child, a link with two
            parents, a cycle, several roots); base_link, tip_link, locked or
            exclude naming no suitable link or joint, or a locked value that is
            not finite or is outside its limits; an unsupported joint type or a
            mimic joint in the chain, a zero axis, an attribute that is not the
            right count of finite numbers, an inertia that is no physical body
            on a moving link (it suggests exclude=[…] for a body off the chain
            and inertia="balance"), a negative mass; a chain without a moving
            joint; moving links that carry no mass at all (M(q) singular for every q;
            it names them, or says that no link has an `<inertial>`), unless
            `massless`; `inertia` not "check" or "balance"; `tips` given with
            `tip_link`, `tips` neither "all" nor a list of link names, a tip that
            is not a link below the base or is excluded, a mimic joint or a joint
            that is neither revolute, continuous, prismatic nor fixed on the way
            to a tip, no joint that moves; `base_joint` not None, "free" or
            "planar", or the file's own root joint of the other kind; a frame the
            file does not have (the closest are named) or given twice.  Its
            `command_line` is the message in the command line's words (--tip,
            --tips, --exclude, …).
        XacroError: (a `URDFError`) a xacro file that cannot be expanded: the xacro
            package is missing, an argument has no value, a package is found nowhere
            (every place looked in is named), any other xacro error; `xacro_args` or
            `package_paths` given for a file that is not xacro.

    Warns:
        URDFWarning: a body resting on the fixed base whose inertial is no physical
            body (accepted and left out: it cannot affect the dynamics); moving links
            without mass, or a file without any `<inertial>`; each inertia repaired
            (inertia="balance"); what xacro warns about while expanding.
    """
    if inertia not in ("check", "balance"):
        raise URDFError(f"inertia must be 'check' or 'balance', got {inertia!r}")
    tips = _tips(tips, tip_link)
    if base_joint not in BASE_JOINTS:
        raise URDFError(
            f"unknown base_joint {base_joint!r}: expected None (a fixed base), 'free' (a 6-DOF floating base, "
            "Pinocchio's free-flyer) or 'planar' (x, y, yaw)",
            f"unknown --base-joint {base_joint}: expected free or planar (default: a fixed base)",
        )
    if not isinstance(package_paths, (str, os.PathLike)):
        package_paths = tuple(package_paths)  # a file with snaps is read twice (as written, too)
    text = read(path_or_xml)
    xacro = _expanded(path_or_xml, text, xacro_args, package_paths)
    urdf = xacro.urdf if xacro is not None else text
    tree = Tree.of(urdf.source, parse(urdf.text, urdf.source))
    given = dict(tree=tree, urdf=urdf, text=text, xacro=xacro, locked=locked, exclude=exclude, snap=snap, name=name)
    given |= dict(inertia=inertia, massless=massless)
    if tips is not None or base_joint is not None:
        robot, record = _read_tree(base_link=base_link, tip_link=tip_link, tips=tips, base_joint=base_joint, **given)
    else:
        robot, record = _read_chain(base_link=base_link, tip_link=tip_link, **given)
    if record.snaps:  # the file's numbers too: the record states how far the snaps move the dynamics
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # this reading says it all
            literal = from_urdf(
                path_or_xml,
                base_link=base_link,
                tip_link=tip_link,
                tips=tips,
                base_joint=base_joint,
                locked=locked,
                exclude=exclude,
                snap=False,
                name=name,
                xacro_args=xacro_args,
                package_paths=package_paths,
                inertia=inertia,
                massless=massless,
            )
        record = dataclasses.replace(record, snapping=Snapping(robot, dataclasses.replace(literal, urdf=None)))
    for message in record.warnings:
        warnings.warn(message, URDFWarning, stacklevel=2)
    for r in record.repairs:
        warnings.warn(f"impossible inertia made physical (inertia='balance'): {r.line()}", URDFWarning, stacklevel=2)
    return served(dataclasses.replace(robot, urdf=record), frames, record.tips)


def _nothing_moves(tree, base_link: str | None) -> bool:
    """No revolute, continuous or prismatic joint below `base_link` (default the root): one body."""
    top = base_link or tree.root
    return not any(tree.joints[c].attrib.get("type") in MOVING for c in tree.below(top) - {top})


def _read_chain(
    *, tree, urdf, text, xacro, base_link, tip_link, locked, exclude, snap, name, inertia, massless
) -> tuple[Robot, UrdfRecord]:
    """The robot and record of the chain from base_link to tip_link (`from_urdf` without tips)."""
    if tip_link is None and _nothing_moves(tree, base_link):
        said = f"{urdf.source}: no joint below {base_link or tree.root!r} moves: a single rigid body (a drone) "
        raise URDFError(
            said + "moves on a base joint: base_joint='free' (or 'planar')", said + "needs --base-joint free"
        )
    base, tip, path = tree.chain(base_link, tip_link)
    on_chain = {base} | {j.find("child").attrib["link"] for j in path}
    below_base = tree.below(base)
    excluded = _excluded(tree, exclude, on_chain, below_base)
    given = dict(locked or {})
    moving = {j.name for j in path if j.attrib.get("type") in MOVING and j.name not in given}
    reader = _Reader(tree, urdf.file, snap, inertia == "balance", frozenset(on_chain))
    reader.values = tree.values(tree.below(base, set(excluded)) - {base}, moving, given)
    skip = on_chain | set(excluded)

    for joint in path:
        kind = joint.attrib.get("type")
        if kind in MULTI or (kind not in MOVING and kind != "fixed"):
            raise URDFError(
                f"{where(urdf.source, joint)}: joint type {kind!r} in the chain is not supported "
                "(revolute, continuous, prismatic and fixed are)"
            )
        if joint.find("mimic") is not None and joint.name in moving:
            said = f"{where(urdf.source, joint)}: mimic joints in the chain are not supported: end the chain before it"
            raise URDFError(f"{said} (tip_link=…)", f"{said} (--tip LINK)")

    reader.subtree(base, skip, base, False)  # what rests on the base: checked, recorded, left out
    pending, carrier, body, out = IDENTITY, None, Body.empty(), []
    for joint in path:  # pending: from the moving body's frame (or the base) to the joint reached
        child = joint.find("child").attrib["link"]
        into = carrier[0].find("child").attrib["link"] if carrier else base
        T = compose(pending, reader.origin(joint, f"joint {joint.name!r} origin"))
        if joint.name not in moving:  # fixed, or a chain joint locked at a value
            if joint.attrib.get("type") in MOVING:
                value, why = reader.values[joint.name]
                reader.locked.append(Locked(joint.name, value, into, why, carrier is not None, on_chain=True))
                T = compose(T, joint_motion(MOVING[joint.attrib["type"]], reader.axis(joint), value))
            sub = reader.subtree(child, skip, into, carrier is not None, len(out) if carrier else -1, T)
            pending = T
            body = body + sub.moved(T) if carrier else body  # ahead of the first joint: part of the base
            continue
        if carrier:
            out.append(reader.link(*carrier, body))
        carrier, pending = (joint, T), IDENTITY
        body = reader.subtree(child, skip, child, True, len(out))
    reader.raise_refusals()
    if carrier is None:
        raise URDFError(f"{urdf.source}: the chain from {base!r} to {tip!r} has no moving joint")
    out.append(reader.link(carrier[0], carrier[1], body))
    empty = _massless(tree, [j.find("child").attrib["link"] for j in path if j.name in moving], out)
    if empty and not massless:
        raise URDFError(
            f"{urdf.source}: {empty}; to read it for its kinematics alone, pass massless=True",
            f"{urdf.source}: {empty}; `symdyn print` and `symdyn show` read it nonetheless",
        )
    reader.warnings += [empty] if empty else []
    tool = tuple(tuple(link_number(x) for x in row) for row in pending)
    robot = Robot(
        name or _file_name(text) or tree.robot.name or "urdf",
        tuple(out),
        convention="general",
        tool=tool,
        frame_catalog=_catalog(reader.frames),
        source=f"{'xacro' if xacro else 'URDF'} {text.file} (sha256 {text.sha256[:16]}…)",
    )
    record = UrdfRecord(
        text.file,
        text.sha256,
        base,
        tip,
        tuple(j.name for j in path if j.name in moving),
        tuple(reader.locked),
        excluded,
        tuple(reader.snaps),
        snap,
        tuple(reader.warnings),
        robot.fingerprint(),
        **(xacro.record_fields() if xacro is not None else {}),
        repairs=tuple(reader.repairs),
        skeleton=_skeleton(tree, base, on_chain, set(excluded), reader.values),
        **_friction_read(tuple(j.name for j in path if j.name in moving), out),
    )
    return robot, record


def _tips(tips, tip_link: str | None):
    """tips checked: None, "all", or a tuple of link names."""
    if tips is None:
        return None
    if tip_link is not None:
        raise URDFError(
            f"tips={tips!r} and tip_link={tip_link!r} together: tips chooses every moving joint (tips='all') or the "
            "chains to several links, tip_link one chain; give one of them",
            f"--tips and --tip {tip_link} together: give one of them",
        )
    if isinstance(tips, str):
        if tips == "all":
            return tips
        raise URDFError(
            f"tips={tips!r}: expected 'all' or a list of link names (one chain: tips=[{tips!r}] or tip_link={tips!r})",
            f"--tips {tips}: expected all or LINK,LINK,…",
        )
    try:
        names = tuple(tips)
    except TypeError:
        raise URDFError(f"tips must be 'all' or a list of link names, got {type(tips).__name__} {tips!r}") from None
    if not names or not all(isinstance(n, str) and n for n in names):
        raise URDFError(f"tips must be 'all' or a non-empty list of link names, got {tips!r}")
    return tuple(dict.fromkeys(names))


def _read_tree(
    *, tree, urdf, text, xacro, base_link, tip_link, tips, base_joint, locked, exclude, snap, name, inertia, massless
) -> tuple[Robot, UrdfRecord]:
    """The robot and record of a tree (tips) or a floating base (`from_urdf` with tips or base_joint):
    every joint of the moving set moves (`branches`), in Pinocchio's depth-first order."""
    source = urdf.source
    carrier = branches.file_base_joint(tree, source, base_joint, base_link)
    if carrier is not None:  # the file's own floating joint under a dummy root: its child floats
        base_link = carrier.find("child").attrib["link"]
    if tips is None and tip_link is None and _nothing_moves(tree, base_link):
        tips = "all"  # no joint below moves: the body alone, whatever its leaves (a drone's rotors)
    if tips is None:  # one chain on a floating base
        base, tip, _ = tree.chain(base_link, tip_link)
        tip_list = (tip,)
    else:
        base, _, _ = tree.chain(base_link, base_link or tree.root)  # base_link checked
        tip_list = tips
    below_base = tree.below(base)
    for tip in () if tip_list == "all" else tip_list:
        said = f"{source}: tip {tip!r}"
        if tip not in tree.links:
            links = f"is not a link of robot {tree.robot.name!r}; its links are {sorted(tree.links)}"
            raise URDFError(f"{said} {links}", f"{source}: --tips {tip} {links}")
        if tip not in below_base or tip == base:
            raise URDFError(
                f"{said} is not below base_link {base!r}", f"{source}: --tips {tip} is not below --base {base}"
            )
    given = dict(locked or {})
    excluded_names = [exclude] if isinstance(exclude, str) else list(exclude)
    out_of = set().union(*(tree.below(e) for e in excluded_names if e in tree.links))
    for tip in () if tip_list == "all" else tip_list:
        if tip in out_of:
            raise URDFError(
                f"{source}: tip {tip!r} is excluded (it is in the subtree of an excluded link): choose other tips",
                f"{source}: --tips {tip} is excluded (it is in the subtree of an excluded link): choose other tips",
            )
    moving, on_chain = branches.moving_set(tree, base, tip_list, out_of, given, source)
    free_mimics = sorted(n for n in moving if tree.named[n].find("mimic") is not None)
    for tip in () if tip_list == "all" else tip_list:
        name_ = tip
        while name_ != base:
            on_chain.add(name_)
            name_ = tree.parent(name_)
    excluded = _excluded(tree, exclude, on_chain, below_base)
    reader = _Reader(tree, urdf.file, snap, inertia == "balance", frozenset(on_chain))
    reader.values = tree.values(tree.below(base, set(excluded)) - {base}, moving, given)
    would_move = {
        tree.joints[c].name
        for c in on_chain - {base}
        if tree.joints[c].attrib.get("type") in MOVING and tree.joints[c].name in given
    }
    if tip_list == "all":
        would_move = {n for n in given if tree.named[n].attrib.get("type") in MOVING}
    base_segment, segments, frames = branches.walk(
        reader, tree, base, moving, out_of, would_move, base_moves=base_joint is not None
    )
    reader.raise_refusals()
    if not segments and base_joint is None:  # on a base joint, the body alone (a drone) moves
        where_to = "to the tips" if tip_list != "all" else "below it"
        raise URDFError(f"{source}: no joint moves from {base!r} {where_to}: every one is fixed, locked or excluded")
    links = [branches.link_of(reader, seg, seg.parent) for seg in segments]
    names = [seg.joint.name for seg in segments]
    parents = tuple(seg.parent for seg in segments)
    dead = branches.massless_joints(names, links, parents)
    if dead and not massless:
        empty = _massless_words(tree, dead)
        raise URDFError(
            f"{source}: {empty}; to read it for its kinematics alone, pass massless=True",
            f"{source}: {empty}; `symdyn print` and `symdyn show` read it nonetheless",
        )
    reader.warnings += [_massless_words(tree, dead)] if dead else []
    if free_mimics:  # a change of the mechanism: stated, with the way back
        reader.warnings.append(
            f"{source}: mimic joints {', '.join(free_mimics)} move on their own (tips='all' reads them as "
            f"Pinocchio's URDF parser does: {len(free_mimics)} more degrees of freedom than the mechanism "
            "the file describes); lock their leaders (locked={leader: value}) to have them follow"
        )
    tool = IDENTITY
    if tip_list != "all" and len(tip_list) == 1:  # one chain: the tool is the tip's frame
        tool = frames[tip_list[0]][1]
    base_T = IDENTITY
    if carrier is not None:
        base_T = reader.origin(carrier, f"joint {carrier.name!r} origin")
    body = base_segment.body
    base_body = None
    if base_joint is not None:
        base_body = Link(
            m=link_number(body.m),
            r=tuple(link_number(x) for x in body.r),
            I=tuple(tuple(link_number(x) for x in row) for row in body.I),
            name=base,
        )
    robot = Robot(
        name or _file_name(text) or tree.robot.name or "urdf",
        tuple(links),
        convention="general",
        base=tuple(tuple(link_number(x) for x in row) for row in base_T),
        tool=tuple(tuple(link_number(x) for x in row) for row in tool),
        base_joint=base_joint,
        base_body=base_body,
        source=f"{'xacro' if xacro else 'URDF'} {text.file} (sha256 {text.sha256[:16]}…)",
        frame_catalog=_catalog(frames),
    )
    record = UrdfRecord(
        text.file,
        text.sha256,
        base,
        tip_list[0] if tips is None else "",
        tuple(names),
        tuple(reader.locked),
        excluded,
        tuple(reader.snaps),
        snap,
        tuple(reader.warnings),
        robot.fingerprint(),
        **(xacro.record_fields() if xacro is not None else {}),
        repairs=tuple(reader.repairs),
        skeleton=_skeleton(tree, tree.root if carrier is not None else base, on_chain, set(excluded), reader.values),
        **_friction_read(tuple(names), links),
        tips=() if tips is None else ("all",) if tips == "all" else tuple(tips),
        base_joint=base_joint,
        file_base_joint=carrier.name if carrier is not None else "",
        parents=parents,
    )
    return robot, record


def _catalog(frames: dict) -> tuple[Frame, ...]:
    """The file's links as frames (`Robot.frame_catalog`), in the order they were reached."""
    return tuple(
        Frame(name, seg, tuple(tuple(link_number(x) for x in row) for row in T)) for name, (seg, T) in frames.items()
    )


def _massless_words(tree: Tree, joints: list) -> str:
    """What is wrong with joints that move no mass (`branches.massless_joints`)."""
    if not any(el.find("inertial") is not None for el in tree.links.values()):
        head = "no link of this file has an <inertial> (a description written for kinematics only)"
    else:
        links = [tree.named[j].find("child").attrib["link"] for j in joints]
        head = (
            f"the moving link{'s' if len(links) > 1 else ''} {', '.join(links)} "
            f"ha{'ve' if len(links) > 1 else 's'} no <inertial> (nor anything with mass riding on or below "
            f"{'them' if len(links) > 1 else 'it'})"
        )
    return (
        f"{head}: joint{'s' if len(joints) > 1 else ''} {', '.join(joints)} move{'' if len(joints) > 1 else 's'} "
        "no mass, so M(q) is singular for every q and forward dynamics is undefined "
        "(M, C, G are zero where the file gives no mass)"
    )


def _file_name(text: Text) -> str:
    """A file's name without .xacro and .urdf (arm.urdf.xacro, arm.xacro, arm.urdf: arm); '' for text."""
    if text.source == "<urdf string>":
        return ""
    name = text.file
    for suffix in (".xacro", ".urdf"):
        if name.lower().endswith(suffix) and len(name) > len(suffix):
            name = name[: -len(suffix)]
    return name


def _massless(tree: Tree, moving_links: list, links: list) -> str | None:
    """What is wrong with moving links that carry nothing (None when none): joint k moves no mass
    and no inertia when link k and every link after it have neither; M(q) is singular for every q."""
    empty = [link.m == 0 and all(x == 0 for row in link.I for x in row) for link in links]
    tail = len(links)
    while tail and empty[tail - 1]:
        tail -= 1
    if tail == len(links):
        return None
    names = moving_links[tail:]
    if not any(el.find("inertial") is not None for el in tree.links.values()):
        head = "no link of this file has an <inertial> (a description written for kinematics only, e.g. franka_ros's with gazebo:=false)"
    else:
        head = f"the moving link{'s' if len(names) > 1 else ''} {', '.join(names)} ha{'ve' if len(names) > 1 else 's'} no <inertial> (nor anything with mass riding on {'them' if len(names) > 1 else 'it'})"
    joints = f"joint {tail + 1} moves" if len(names) == 1 else f"joints {tail + 1}-{len(links)} move"
    return (
        f"{head}: {joints} no mass, so M(q) is singular for every q and forward dynamics is undefined "
        "(M, C, G are zero where the file gives no mass)"
    )


def _friction_read(joints: tuple, links: list) -> dict:
    """The record's `viscous` and `coulomb`: the chain joints whose `<dynamics damping>` and
    `<dynamics friction>` are not 0 (one link per joint, in order)."""
    return {
        "viscous": tuple(j for j, link in zip(joints, links) if link.B != 0),
        "coulomb": tuple(j for j, link in zip(joints, links) if link.Tc != (0, 0)),
    }


def _float_motion(kind: str, axis: np.ndarray, value: float) -> np.ndarray:
    T = np.eye(4)
    if kind == "prismatic":
        T[:3, 3] = axis * value
    else:
        K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        T[:3, :3] = np.eye(3) + math.sin(value) * K + (1 - math.cos(value)) * K @ K
    return T


def _axis(tree: Tree, joint: Element) -> np.ndarray:
    a = np.array(numbers(tree.source, joint.find("axis"), "xyz", 3, (1, 0, 0)), dtype=float)
    return a / (np.linalg.norm(a) or 1.0)


def _skeleton(tree: Tree, base: str, on_chain: set, excluded: set, values: dict) -> tuple:
    """Every link's frame in the root's (floats), the chain at 0 and locked joints at their values."""
    out_of = set().union(*(tree.below(name) for name in excluded))
    below_base = tree.below(base)
    bones, todo = [], [(tree.root, np.eye(4))]
    while todo:
        name, T = todo.pop(0)
        joint = tree.joints.get(name)
        role = "chain" if name in on_chain else "excluded" if name in out_of else "riding"
        role = role if name in below_base else "above"
        kind = joint.attrib.get("type", "") if joint is not None else ""
        axis = tuple((T[:3, :3] @ _axis(tree, joint)).tolist()) if kind in MOVING else (0.0, 0.0, 0.0)
        bones.append(
            Bone(
                name,
                tree.parent(name) if joint is not None else "",
                joint.name if joint is not None else "",
                kind,
                tuple(tuple(float(x) for x in row) for row in T),
                axis,
                role,
            )
        )
        for child in tree.children.get(name, []):
            j = tree.joints[child]
            origin = j.find("origin")
            P = np.eye(4)
            if origin is not None:
                P[:3, :3] = np.array(rpy_rotation(numbers(tree.source, origin, "rpy", 3, (0, 0, 0))), dtype=float)
                P[:3, 3] = numbers(tree.source, origin, "xyz", 3, (0, 0, 0))
            if j.attrib.get("type") in MOVING:
                value = values.get(j.name, (0.0, ""))[0]
                P = P @ _float_motion(MOVING[j.attrib["type"]], _axis(tree, j), value)
            todo.append((child, T @ P))
    return tuple(bones)
