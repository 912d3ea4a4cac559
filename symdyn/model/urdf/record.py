"""What `from_urdf` did to a file: the chain chosen, what was locked where, excluded, snapped.

Kept on the robot (`robot.urdf`), shown by `print(robot)`, written into
generated headers, and turned back into the command that rebuilds the robot.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass

__all__ = ["Locked", "Snap", "UrdfRecord"]


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
class UrdfRecord:
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
    #: For a xacro file (`file`, `sha256` are the xacro file's): the arguments given, as
    #: (name, value) pairs, the packages `$(find)`/`package://` named (by name, never by
    #: folder), and the sha256 of the URDF text it expanded to (its includes change it too).
    xacro_args: tuple = ()
    packages: tuple = ()
    expanded_sha256: str = ""

    @property
    def is_xacro(self) -> bool:
        """Whether the file was xacro, expanded before reading."""
        return bool(self.expanded_sha256)

    def describes(self, robot) -> bool:
        """Whether `robot` is still the robot as read (not changed since by payload, subs, replace …)."""
        return robot.fingerprint() == self.fingerprint

    @property
    def max_snap(self) -> float:
        """The largest change a snap made (0 when none)."""
        return max((s.change for s in self.snaps), default=0.0)

    def command_args(self) -> str:
        """The `symdyn generate`/`print` arguments that read the same robot from the same file
        (a xacro file's arguments as --xacro-arg; its package folders are the reader's, not
        the model's, and are found again from the file's place or --package-path)."""
        args = [self.file, "--base", self.base_link, "--tip", self.tip_link]
        args += [f"--xacro-arg={key}:={value}" for key, value in self.xacro_args]
        args += [f"--lock={lock.joint}={lock.value!r}" for lock in self.locked if lock.why == "given"]
        args += [f"--exclude={link}" for link in self.excluded]
        args += [] if self.snap else ["--no-snap"]
        return shlex.join(args)

    def lines(self) -> list[str]:
        """A summary a person reads: the chain, each lock, exclusion and snap."""
        out = [
            f"{'xacro' if self.is_xacro else 'URDF'} {self.file} (sha256 {self.sha256}): "
            f"chain {self.base_link} -> {self.tip_link}, joints {', '.join(self.joints)}"
        ]
        if self.is_xacro:
            args = " ".join(f"{key}:={value}" for key, value in self.xacro_args) or "none (the defaults)"
            out.append(
                f"expanded by xacro with arguments {args}; packages {', '.join(self.packages) or 'none'}; "
                f"the URDF it expanded to has sha256 {self.expanded_sha256}"
            )
        moving = [lock for lock in self.locked if lock.moves]
        resting = [lock for lock in self.locked if not lock.moves]
        if moving:
            out.append(f"locked ({len(moving)}), merged into the moving link named:")
            out += [
                f"  {lock.joint} = {lock.value!r} -> {lock.into} ({lock.why}"
                f"{', a chain joint' if lock.on_chain else ''})"
                for lock in moving
            ]
        if resting:
            out.append(
                f"locked on the fixed base, no effect on the dynamics ({len(resting)}): "
                + ", ".join(f"{lock.joint} = {lock.value!r}" for lock in resting)
            )
        if self.excluded:
            out.append(f"excluded with their subtrees: {', '.join(self.excluded)}")
        if not self.snap:
            out.append("numbers as written (snap=False)")
        elif self.snaps:
            out.append(f"snapped to exact values ({len(self.snaps)}, largest change {self.max_snap:.2e}):")
            out += [f"  {s.where}: {s.value} -> {s.snapped}" for s in self.snaps]
        out += [f"warning: {w}" for w in self.warnings]
        return out
