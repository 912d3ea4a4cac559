"""What `from_urdf` did to a file: the chain chosen, what was locked where, excluded, snapped
(and how far the snaps move the dynamics), the friction read from the file.

Kept on the robot (`robot.urdf`), shown by `print(robot)`, written into
generated headers, and turned back into the command that rebuilds the robot.
"""

from __future__ import annotations

import dataclasses
import shlex
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Bone", "Locked", "Snap", "Repair", "UrdfRecord", "friction_lines", "snap_lines"]


@dataclass(frozen=True)
class Locked:
    """A joint held at `value` (rad or m): its subtree rides on link `into` as one body.

    why: "default" (0, or the limit nearest 0 when 0 is outside the limits),
    "given" (from `locked=`), or "mimic of J" (multiplier·J + offset).
    moves: whether `into` moves (False: the body rides on the fixed base and
    does not enter the dynamics).  on_chain: a chain joint made fixed.
    """

    joint: str
    value: float
    into: str
    why: str
    moves: bool
    on_chain: bool = False


@dataclass(frozen=True)
class Snap:
    """A number of the file replaced by an exact neighbour (`symdyn.model.snapping`)."""

    where: str
    value: str
    snapped: str
    change: float


@dataclass(frozen=True)
class Repair:
    """An impossible inertia made physical on request (`inertia="balance"`): the nearest
    physical inertia in the Frobenius norm, same principal axes (`bodies.balanced`).

    before, after: the principal moments (kg·m²), ascending; change: the Frobenius norm
    of the change relative to the largest moment's magnitude."""

    link: str
    where: str
    before: tuple
    after: tuple
    change: float

    def line(self) -> str:
        """One line a person reads: which moments changed, by how much."""
        moved = [f"I{k + 1} {a:.6g} -> {b:.6g}" for k, (a, b) in enumerate(zip(self.before, self.after)) if a != b]
        return f"{self.where} link {self.link!r}: {', '.join(moved)} kg*m^2 (change {self.change:.2e} relative)"


@dataclass(frozen=True)
class Bone:
    """One link of the file's whole tree as read, for pictures (`symdyn.presentation.picture`): its
    frame in the root link's frame with the chain at q = 0 and every locked joint at its value.

    joint: the joint above it ('' for the root), `kind` its URDF type, `axis` its unit axis in
    the root frame.  role: "chain" (base to tip), "riding" (merged into a moving link or resting
    on the base: locked or fixed), "excluded" (left out by exclude=), "above" (above base_link).
    """

    link: str
    parent: str
    joint: str
    kind: str
    T: tuple
    axis: tuple
    role: str


class FileRecord:
    """What the records of every file format answer alike (they have `fingerprint` and `snaps`)."""

    fingerprint: str
    snaps: tuple

    def describes(self, robot) -> bool:
        """Whether `robot` is still the robot as read (not changed since by payload, subs, replace …),
        its chosen frames and contact set aside (`Robot.dynamics_fingerprint`)."""
        return robot.dynamics_fingerprint() == self.fingerprint

    @property
    def max_snap(self) -> float:
        """The largest change a snap made (0 when none)."""
        return max((s.change for s in self.snaps), default=0.0)


@dataclass(frozen=True)
class UrdfRecord(FileRecord):
    """The provenance of a robot read from a URDF (see the module docstring)."""

    file: str
    sha256: str
    base_link: str
    tip_link: str
    joints: tuple
    locked: tuple = ()
    excluded: tuple = ()
    snaps: tuple = ()
    snap: bool = True
    warnings: tuple = ()
    fingerprint: str = ""
    #: The two readings of the file, as read and as written (`symdyn.model.snapping.Snapping`),
    #: where snaps changed a number: `lines()` states how far they move the dynamics.
    snapping: Any = field(default=None, compare=False, repr=False)
    #: The chain joints whose `<dynamics damping>` (viscous) and `<dynamics friction>` (Coulomb)
    #: are not 0, and which of them the robot leaves out since: "" (none: τ includes them),
    #: "coulomb" (`robot.nofriction()`), "all" (`--no-friction`, `robot.nofriction(all=True)`).
    viscous: tuple = ()
    coulomb: tuple = ()
    friction_left_out: str = ""
    coulomb_free: str = ""  # the fingerprint of the robot `nofriction()` made ("coulomb")
    #: For a xacro file (`file`, `sha256` are the xacro file's): the arguments given, as
    #: (name, value) pairs, the packages `$(find)`/`package://` named (by name, never by
    #: folder), and the sha256 of the URDF text it expanded to (its includes change it too).
    xacro_args: tuple = ()
    packages: tuple = ()
    expanded_sha256: str = ""
    #: Impossible inertias repaired on request (`inertia="balance"`, `--balance-inertia`): `Repair`s.
    repairs: tuple = ()
    #: The whole tree as read (`Bone`s, root first), for `symdyn show` / `robot.plot()`.
    skeleton: tuple = ()
    #: A tree (`from_urdf(tips=…)`): ("all",) or the tip links (`tip_link` is then ""); () for a chain.
    tips: tuple = ()
    #: The joint that carries the whole robot: None (a fixed base), "free" or "planar"; the body it
    #: moves is `base_link` with everything fixed or locked to it (`Robot.base_body`).
    base_joint: str | None = None
    #: The file's own floating (planar) joint under a dummy root, read as the base joint ("" if none).
    file_base_joint: str = ""
    #: Each moving joint's parent (an index into `joints`, -1: the base), as `robot.parents`.
    parents: tuple = ()

    @property
    def is_xacro(self) -> bool:
        """Whether the file was xacro, expanded before reading."""
        return bool(self.expanded_sha256)

    def command_args(self) -> str:
        """The `symdyn generate`/`print` arguments that read the same robot from the same file
        (a xacro file's arguments as --xacro-arg; its package folders are the reader's, not
        the model's, and are found again from the file's place or --package-path)."""
        args = [self.file] + (["--base", self.base_link] if not self.file_base_joint else [])
        args += ["--tips", ",".join(self.tips)] if self.tips else ["--tip", self.tip_link]
        args += ["--base-joint", self.base_joint] if self.base_joint else []
        args += [f"--xacro-arg={key}:={value}" for key, value in self.xacro_args]
        args += [f"--lock={lock.joint}={lock.value!r}" for lock in self.locked if lock.why == "given"]
        args += [f"--exclude={link}" for link in self.excluded]
        args += [] if self.snap else ["--no-snap"]
        args += ["--no-friction"] if self.friction_left_out == "all" else []
        args += ["--balance-inertia"] if self.repairs else []
        return shlex.join(args)

    def without_friction(self, before, robot, all: bool = True) -> "UrdfRecord":  # noqa: A002 (as nofriction)
        """The record of `robot`, which `before.nofriction(all)` made: what it left out."""
        return without_friction(self, before, robot, all)

    def friction_report(self) -> list[str]:
        """The friction read from the file (`<dynamics damping friction>`) and whether tau includes
        it, in a line (none for a file without)."""
        return friction_lines(self.viscous, self.coulomb, self.friction_left_out, ("damping", "friction"))

    def lines(self) -> list[str]:
        """A summary a person reads: the chain, each lock, exclusion and snap (and what the snaps
        do to tau, M and qdd), the friction read from the file."""
        kind = f"{'xacro' if self.is_xacro else 'URDF'} {self.file} (sha256 {self.sha256}): "
        if not self.tips:
            out = [
                kind
                + f"chain {self.base_link} -> {self.tip_link}, joints {', '.join(self.joints) or 'none (one body)'}"
            ]
        else:
            to = "every joint" if self.tips == ("all",) else f"the chains to {', '.join(self.tips)}"
            out = [
                kind
                + f"tree from {self.base_link}, {to}: {f'{len(self.joints)} moving joints (depth first)' if self.joints else 'no moving joint (one body)'}"
            ]
            names = {-1: self.base_link, **dict(enumerate(self.joints))}
            hung = [f"{j} (on {names[p]})" for j, p in zip(self.joints, self.parents or [-1] * len(self.joints))]
            out += ["  moving: " + ", ".join(hung)] if hung else []
        if self.base_joint:
            coordinates = {
                "free": "x y z qx qy qz qw (Pinocchio's free-flyer)",
                "planar": "x y yaw in the plane of its frame",
            }[self.base_joint]
            by = f", the file's joint {self.file_base_joint}" if self.file_base_joint else ""
            out.append(
                f"base joint: {self.base_joint}{by} ({coordinates}, before the joints in q); the floating body is "
                f"link {self.base_link} with everything fixed or locked to it"
            )
        if self.is_xacro:
            args = " ".join(f"{key}:={value}" for key, value in self.xacro_args) or "none (the defaults)"
            out.append(
                f"expanded by xacro with arguments {args}; packages {', '.join(self.packages) or 'none'}; "
                f"the URDF it expanded to has sha256 {self.expanded_sha256}"
            )
        out += lock_lines(self.locked, "link")
        if self.excluded:
            out.append(f"excluded with their subtrees: {', '.join(self.excluded)}")
        out += snap_lines(self, "numbers as written (snap=False)")
        out += self.friction_report()
        if self.repairs:
            out.append(
                f"impossible inertias made physical on request (inertia='balance', --balance-inertia), "
                f"each the nearest physical one ({len(self.repairs)}):"
            )
            out += [f"  {r.line()}" for r in self.repairs]
        out += [f"warning: {w}" for w in self.warnings]
        return out


def lock_lines(locked: tuple, part: str) -> list[str]:
    """The summary lines of the locked joints: those merged into a moving `part` (link, body)
    one a line, those resting on the fixed base on one."""
    moving = [lock for lock in locked if lock.moves]
    resting = [lock for lock in locked if not lock.moves]
    out = []
    if moving:
        out.append(f"locked ({len(moving)}), merged into the moving {part} named:")
        out += [
            f"  {lock.joint} = {lock.value!r} -> {lock.into} ({lock.why}{', a chain joint' if lock.on_chain else ''})"
            for lock in moving
        ]
    if resting:
        out.append(
            f"locked on the fixed base, no effect on the dynamics ({len(resting)}): "
            + ", ".join(f"{lock.joint} = {lock.value!r}" for lock in resting)
        )
    return out


def snap_lines(record, as_written: str) -> list[str]:
    """A record's snaps, one line each, then how far they move the dynamics (`record.snapping`);
    `as_written` where the record's reading did not snap (`UrdfRecord`, `MjcfRecord`)."""
    if not record.snap:
        return [as_written]
    if not record.snaps:
        return []
    out = [f"snapped to exact values ({len(record.snaps)}, largest change {record.max_snap:.2e}):"]
    out += [f"  {s.where}: {s.value} -> {s.snapped}" for s in record.snaps]
    return out + ([record.snapping.effect.line()] if record.snapping is not None else [])


def friction_lines(viscous: tuple, coulomb: tuple, left_out: str, words: tuple[str, str]) -> list[str]:
    """The line that says which friction the file gave how many joints, and whether tau includes
    it: viscous on the joints `viscous` (the file's `words[0]`), Coulomb on `coulomb`
    (`words[1]`); `left_out` "" (tau includes both), "coulomb" (`robot.nofriction()`) or "all"
    (`--no-friction`, `robot.nofriction(all=True)`).  No line for a file without friction."""
    kinds = [
        (kind, names, word)
        for kind, names, word in (("viscous", viscous, words[0]), ("Coulomb", coulomb, words[1]))
        if names
    ]
    if not kinds:
        return []
    joints = lambda count: f"{count} joint{'s' if count != 1 else ''}"  # noqa: E731
    parts = [
        f"{kind} on {joints(len(names)) if i == 0 else len(names)} ({word})"
        for i, (kind, names, word) in enumerate(kinds)
    ]
    both = ", ".join(parts)
    if left_out == "all" or (left_out == "coulomb" and not viscous):
        how = "--no-friction, robot.nofriction(all=True)" if left_out == "all" else "robot.nofriction()"
        return [f"friction read from the file, left out ({how}): {both}; tau has none"]
    if left_out == "coulomb":
        return [
            f"friction read from the file: {parts[0]}: tau includes it; Coulomb on {len(coulomb)} ({words[1]}) "
            "left out (robot.nofriction()); --no-friction leaves out both"
        ]
    them = "them" if len(kinds) > 1 else "it"
    return [
        f"friction read from the file: {both}: tau includes {them}; --no-friction (robot.nofriction(all=True)) leaves {them} out"
    ]


def without_friction(record, before, robot, all: bool):  # noqa: A002 (as nofriction)
    """`record` (a `UrdfRecord` or `MjcfRecord`) of `robot`, which `before.nofriction(all)` made:
    what is left out, and `robot`'s fingerprint where `--no-friction` rebuilds it.  A record that
    no longer describes `before` (a payload, new parameters) is kept as it is: it says so."""
    if before.fingerprint() not in (record.fingerprint, record.coulomb_free):
        return record
    if record.friction_left_out == "all" or not (record.viscous or record.coulomb):
        return record  # nothing more to leave out: the same robot
    if all or not record.viscous:  # what --no-friction rebuilds
        return dataclasses.replace(record, friction_left_out="all", fingerprint=robot.fingerprint(), coulomb_free="")
    if not record.coulomb or record.friction_left_out == "coulomb":
        return record
    # Coulomb left out, viscous kept: no option rebuilds it, so the fingerprint stays that of the file's
    return dataclasses.replace(record, friction_left_out="coulomb", coulomb_free=robot.fingerprint())
