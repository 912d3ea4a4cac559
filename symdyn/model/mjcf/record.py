"""What `from_mjcf` did to a file: the chain chosen, what was locked, excluded, snapped,
stripped, and what the file's joints and actuators became (friction, rotor inertia, limits).

Kept on the robot (`robot.mjcf`), shown by `print(robot)`, and turned back into
the command that rebuilds the robot; the same shape as `symdyn.model.urdf.UrdfRecord`.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass, field
from typing import Any

from ..urdf.record import FileRecord, friction_lines, lock_lines, snap_lines, without_friction

__all__ = ["MjcfRecord"]


@dataclass(frozen=True)
class MjcfRecord(FileRecord):
    """The provenance of a robot read from an MJCF file.

    joints: the chain's moving joints, in order (one link each).  locked,
    snaps: `symdyn.model.urdf.Locked` and `Snap` records.  read: one line per
    chain joint that brought motor terms (armature → Jm, damping → B,
    frictionloss → Tc) or an effort limit (actuator gear × force or control
    range).  stripped: mesh and texture files that are absent, left out
    before MuJoCo compiled the file (no body's inertia depends on them).
    left_out: bodies that do not enter the dynamics (they rest on the fixed
    base, or float freely).  gravity: the file's `<option gravity>` (MuJoCo's
    sign: the acceleration of a falling body).  snapping: both readings of
    the file where snaps changed a number (`symdyn.model.snapping.Snapping`):
    `lines()` states how far they move the dynamics.  rotor, viscous, coulomb:
    the chain joints with armature, damping, frictionloss; friction_left_out:
    "" (tau includes the friction), "coulomb" (`robot.nofriction()`) or "all"
    (`--no-friction`, `robot.nofriction(all=True)`); the rotor inertia stays.
    """

    file: str
    sha256: str
    base_body: str
    tip_body: str
    joints: tuple
    locked: tuple = ()
    excluded: tuple = ()
    snaps: tuple = ()
    snap: bool = True
    read: tuple = ()
    stripped: tuple = ()
    left_out: tuple = ()
    gravity: tuple = (0.0, 0.0, -9.81)
    warnings: tuple = ()
    fingerprint: str = ""
    snapping: Any = field(default=None, compare=False, repr=False)
    rotor: tuple = ()
    viscous: tuple = ()
    coulomb: tuple = ()
    friction_left_out: str = ""
    coulomb_free: str = ""
    #: A tree (`from_mjcf(tips=…)`): ("all",) or the tip bodies (`tip_body` is then ""); () for a chain.
    tips: tuple = ()
    #: None (a fixed base), "free" or "planar": the joint that carries `base_body` and all below it.
    base_joint: str | None = None
    #: The file's free joint (`<freejoint/>`) read as the base joint ("" if none).
    free_joint: str = ""
    #: Each moving joint's parent (an index into `joints`, -1: the base), as `robot.parents`.
    parents: tuple = ()
    #: Where MuJoCo keeps each moving joint's coordinate and velocity (qpos, qvel addresses), the
    #: free joint's first ones (-1: none), the file's nq and nv, and its qpos with every locked
    #: joint at its value (`symdyn.model.mjcf.state`: MuJoCo's states and symdyn's).
    qpos_address: tuple = ()
    qvel_address: tuple = ()
    free_address: tuple = (-1, -1)
    file_nq: int = 0
    file_nv: int = 0
    qpos_locked: tuple = ()

    def command_args(self) -> str:
        """The `symdyn generate`/`print` arguments that read the same robot from the same file."""
        args = [self.file] + (["--base", self.base_body] if not self.free_joint else [])
        args += ["--tips", ",".join(self.tips)] if self.tips else ["--tip", self.tip_body]
        args += ["--base-joint", self.base_joint] if self.base_joint and not self.free_joint else []
        args += [f"--lock={lock.joint}={lock.value!r}" for lock in self.locked if lock.why == "given"]
        args += [f"--exclude={body}" for body in self.excluded]
        args += [] if self.snap else ["--no-snap"]
        args += ["--no-friction"] if self.friction_left_out == "all" else []
        return shlex.join(args)

    def without_friction(self, before, robot, all: bool = True) -> "MjcfRecord":  # noqa: A002 (as nofriction)
        """The record of `robot`, which `before.nofriction(all)` made: what it left out."""
        return without_friction(self, before, robot, all)

    def friction_report(self) -> list[str]:
        """The rotor inertia (armature) and friction (damping, frictionloss) read from the file, and
        whether M and tau include them, in a line each (none for a file without)."""
        count = len(self.rotor)
        rotor = (
            [
                f"rotor inertia read from the file: armature on {count} joint{'s' if count != 1 else ''} (Jm, G = 1): "
                "M includes it on its diagonal; --no-friction keeps it"
            ]
            if count
            else []
        )
        return rotor + friction_lines(self.viscous, self.coulomb, self.friction_left_out, ("damping", "frictionloss"))

    def lines(self) -> list[str]:
        """A summary a person reads: the chain, what became friction and rotor inertia, each
        lock, exclusion, snap and stripped file."""
        gravity = f"gravity {list(self.gravity)} (MuJoCo's sign)"
        if not self.tips:
            out = [
                f"MJCF {self.file} (sha256 {self.sha256}): chain {self.base_body} -> {self.tip_body}, "
                f"joints {', '.join(self.joints) or 'none (one body)'}; {gravity}"
            ]
        else:
            to = "every hinge and slide joint" if self.tips == ("all",) else f"the chains to {', '.join(self.tips)}"
            out = [
                f"MJCF {self.file} (sha256 {self.sha256}): tree from {self.base_body}, {to}: "
                f"{f'{len(self.joints)} moving joints (depth first)' if self.joints else 'no moving joint (one body)'}; {gravity}"
            ]
            names = {-1: self.base_body, **dict(enumerate(self.joints))}
            hung = [f"{j} (on {names[p]})" for j, p in zip(self.joints, self.parents or [-1] * len(self.joints))]
            out += ["  moving: " + ", ".join(hung)] if hung else []
        if self.base_joint:
            by = f", the file's free joint {self.free_joint}" if self.free_joint else ""
            out.append(
                f"base joint: {self.base_joint}{by} (Pinocchio's q and v, not MuJoCo's: robot.from_mujoco_state "
                "and to_mujoco_state convert them); "
                f"the floating body is {self.base_body} with everything welded or locked to it"
            )
        out += self.friction_report()
        if self.read:
            out.append("read from the file's joints and actuators:")
            out += [f"  {line}" for line in self.read]
        out += lock_lines(self.locked, "body")
        if self.left_out:
            out.append(f"left out, no effect on the dynamics: {', '.join(self.left_out)}")
        if self.excluded:
            out.append(f"excluded with their subtrees: {', '.join(self.excluded)}")
        if self.stripped:
            out.append(
                f"absent files left out before compiling (no inertia depends on them): {', '.join(self.stripped)}"
            )
        out += snap_lines(self, "numbers as compiled by MuJoCo (snap=False)")
        out += [f"warning: {w}" for w in self.warnings]
        return out
