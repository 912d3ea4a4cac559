"""How the command line names a model: a shipped arm's name, or a URDF file and its chain.

Part of the model stage, for `symdyn generate` and `symdyn print` (and any
command that takes a MODEL): `add_arguments` declares MODEL with the URDF
options (--tip, --base, --lock JOINT=VALUE, --exclude LINK, --no-snap,
--no-friction, --name, and for a xacro file --xacro-arg NAME:=VALUE, --package-path DIR),
`load` turns them into a `Robot` through `arms.load` or `Robot.from_urdf`
(a tree with --tips all|LINK,LINK, a floating base with --base-joint free|planar).
A robot file's robot is named after the file (not the URDF's <robot name=…>,
which three unrelated files may share; arm.urdf.xacro's is arm), as
`Robot.from_urdf` names it from Python, so `symdyn generate arm.urdf` writes
arm.c, arm.py, … beside the other outputs named after their files; --name
overrides it.  Errors of the readers are shown in the command line's words
(`--tip LINK`, not `tip_link=…`: `URDFError.command_line`).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from . import arms
from .robot import Robot
from .urdf.xml import URDFError

__all__ = [
    "add_arguments",
    "add_urdf_options",
    "load",
    "from_args",
    "urdf_options",
    "is_urdf",
    "parse_locks",
    "parse_tips",
    "parse_xacro_args",
    "URDF_OPTIONS",
]

#: The options that only a URDF file takes (argparse dest → option).
URDF_OPTIONS = {
    "tip": "--tip",
    "tips": "--tips",
    "base_joint": "--base-joint",
    "base": "--base",
    "lock": "--lock",
    "exclude": "--exclude",
    "no_snap": "--no-snap",
    "name": "--name",
    "xacro_arg": "--xacro-arg",
    "package_path": "--package-path",
    "balance_inertia": "--balance-inertia",
    "no_friction": "--no-friction",
}
#: The options an MJCF file does not take (it has no xacro): refused by name.
NOT_MJCF = ("--xacro-arg", "--package-path")


def add_arguments(p: argparse.ArgumentParser, *, nargs: str | None = None) -> None:
    """MODEL (a shipped name, or a .urdf or .xacro file) and the URDF options."""
    p.add_argument(
        "model",
        nargs=nargs,
        metavar="MODEL",
        help=f"a shipped model ({', '.join(arms.NAMES)}) or a robot file: URDF (.urdf, or any existing "
        "file) or xacro (.xacro, .urdf.xacro: expanded in-process, no ROS needed)",
    )
    p.add_argument(
        "--frames",
        nargs="*",
        metavar="FRAME",
        default=None,
        help="the frames the task-space functions serve, in order: any link of the file (moving, locked or "
        "merged by a fixed joint), an MJCF body or site, tool, or for a robot without a file base, link1 … "
        "(default: the tool of a chain, the tips of --tips A,B,…, else each leaf link of a tree); "
        "`symdyn print --frames` prints their "
        "forward kinematics and Jacobians",
    )
    add_urdf_options(p)


def add_urdf_options(p: argparse.ArgumentParser) -> None:
    """--tip, --base, --lock, --exclude, --no-snap, --name, --xacro-arg, --package-path:
    how a URDF or xacro file becomes a chain."""
    urdf = p.add_argument_group("URDF files", "how a URDF MODEL becomes a chain (a shipped model takes none of these)")
    urdf.add_argument(
        "--tip", metavar="LINK", help="the chain's last link (an MJCF file's: BODY) (default: the tree's only leaf)"
    )
    urdf.add_argument(
        "--tips",
        metavar="all|LINK,LINK",
        help="a tree instead of one chain: 'all' moves every revolute, continuous and prismatic joint "
        "(an MJCF file's hinge and slide joints), LINK,LINK the joints on the way to each listed link "
        "(BODY,BODY); the rest is locked and merged as for a chain (not with --tip)",
    )
    urdf.add_argument(
        "--base", metavar="LINK", help="the chain's first link (an MJCF file's: BODY), fixed (default: the root)"
    )
    urdf.add_argument(
        "--base-joint",
        choices=("free", "planar"),
        help="the base floats: free (6 DOF, Pinocchio's free-flyer: q = x y z qx qy qz qw, then the joints) or "
        "planar (x y yaw); --base (default: the root) with what is fixed to it is the floating body "
        "(default: a fixed base; an MJCF file's <freejoint/> on its root body is read as free)",
    )
    urdf.add_argument(
        "--lock",
        metavar="JOINT=VALUE",
        action="append",
        default=[],
        help="hold an off-chain or chain joint at VALUE (rad or m), its subtree merged into the "
        "link it rides on; repeatable (default: 0, or the limit nearest 0)",
    )
    urdf.add_argument(
        "--exclude",
        metavar="LINK",
        action="append",
        default=[],
        help="leave LINK and its subtree out (a gripper, a camera); repeatable",
    )
    urdf.add_argument(
        "--no-snap",
        action="store_true",
        help="keep the file's numbers as written (default: snap 1.5708 to pi/2 and the like; the generated "
        "files' header says how far the snaps move tau, M and qdd): to compare with a peer that reads the file "
        "literally (Pinocchio)",
    )
    urdf.add_argument(
        "--no-friction",
        action="store_true",
        help="leave out the friction the file gives (URDF <dynamics damping friction>, MJCF damping and "
        "frictionloss: viscous and Coulomb), as robot.nofriction(all=True): to compare tau with a peer that "
        "has none (Pinocchio's rnea); rotor inertia (MJCF armature) stays (default: tau includes it, as said "
        "on stderr)",
    )
    urdf.add_argument(
        "--balance-inertia",
        action="store_true",
        help="replace each impossible inertia of a moving body (principal moments against the triangle "
        "inequality) by the nearest physical one, each repair reported (default: refuse it)",
    )
    urdf.add_argument("--name", help="the model's name, which names the generated files (default: the file's stem)")
    urdf.add_argument(
        "--xacro-arg",
        metavar="NAME:=VALUE",
        action="append",
        default=[],
        help="a xacro file's argument, as xacro's NAME:=VALUE (e.g. ur_type:=ur5e); repeatable",
    )
    urdf.add_argument(
        "--package-path",
        metavar="DIR",
        action="append",
        default=[],
        help="a folder holding (or being) the ROS packages a xacro file's $(find PKG) and package://PKG/ "
        "name; searched before ROS_PACKAGE_PATH, AMENT_PREFIX_PATH and the folders above the file; repeatable",
    )


def is_urdf(model: str) -> bool:
    """Whether MODEL names a URDF file: it ends in .urdf or .xacro (expanded before reading),
    or it is a file that exists."""
    return model.lower().endswith((".urdf", ".xacro")) or Path(model).is_file()


def _model_name(path: Path) -> str:
    """The file's name without .xacro and .urdf: arm.urdf.xacro, arm.xacro and arm.urdf name arm."""
    name = path.name
    for suffix in (".xacro", ".urdf"):
        if name.lower().endswith(suffix) and len(name) > len(suffix):
            name = name[: -len(suffix)]
    return name


def parse_xacro_args(items) -> dict:
    """{"name": "value"} from ["name:=value", …] (xacro's own syntax).

    Raises:
        ValueError: an item that is not NAME:=VALUE (it is named), or a name given
            twice with different values.
    """
    args: dict = {}
    for item in items:
        key, sep, value = item.partition(":=")
        key = key.strip()
        if not sep or not key:
            raise ValueError(
                f"--xacro-arg {item}: expected NAME:=VALUE, as xacro takes it, e.g. --xacro-arg ur_type:=ur5e"
            )
        if key in args and args[key] != value:
            raise ValueError(f"--xacro-arg {item}: argument {key!r} is already given as {args[key]!r}")
        args[key] = value
    return args


def parse_tips(text: str | None):
    """--tips: None, "all", or the link (body) names of LINK,LINK,….

    Raises:
        ValueError: an empty name among them (`--tips a,,b`, `--tips ,`).
    """
    if text is None or text == "all":
        return text
    names = [name.strip() for name in text.split(",")]
    if not all(names):
        raise ValueError(f"--tips {text}: expected all or LINK,LINK,… (link or body names, no empty ones)")
    return names


def parse_locks(items) -> dict:
    """{"joint": value} from ["joint=value", …]; a ValueError naming the item that is not JOINT=VALUE."""
    locks = {}
    for item in items:
        joint, eq, text = item.partition("=")
        joint, text = joint.strip(), text.strip()
        try:
            value = float(text) if eq and joint else None
        except ValueError:
            value = None
        if value is None or not math.isfinite(value):
            raise ValueError(
                f"--lock {item}: expected JOINT=VALUE with VALUE a finite number in rad or m, "
                f"e.g. --lock {joint or 'finger_joint'}=0.02"
            )
        if joint in locks and locks[joint] != value:
            raise ValueError(f"--lock {item}: joint {joint!r} is already locked at {locks[joint]!r}")
        locks[joint] = value
    return locks


def load(
    model: str,
    *,
    symbolic: bool = False,
    tip: str | None = None,
    tips: str | None = None,
    base: str | None = None,
    base_joint: str | None = None,
    lock=(),
    exclude=(),
    no_snap: bool = False,
    name: str | None = None,
    xacro_arg=(),
    package_path=(),
    balance_inertia: bool = False,
    massless: bool = False,
    no_friction: bool = False,
) -> Robot:
    """The robot MODEL names: a shipped arm (its symbolic variant where it has one and `symbolic`),
    or the chain of a URDF or xacro file read by `Robot.from_urdf` with the URDF options
    (`xacro_arg`: ["NAME:=VALUE", …], `package_path`: [DIR, …]; `massless`: read a chain without
    mass, for printing and pictures, with a warning; `no_friction`: `robot.nofriction(all=True)`).
    A file's friction and rotor inertia are said on stderr: they are in tau and M unless left out.

    Raises:
        ValueError: an unknown model; URDF options for a shipped model, or xacro options
            for an MJCF file; a malformed --lock or --xacro-arg; a missing file.
        URDFError: the file cannot become a robot, in the command line's words.
        MJCFError: an MJCF file that cannot become a robot.
    """
    values = {"tip": tip, "base": base, "lock": lock, "exclude": exclude, "no_snap": no_snap, "name": name}
    values |= {"tips": tips, "base_joint": base_joint}
    values |= {"xacro_arg": xacro_arg, "package_path": package_path, "balance_inertia": balance_inertia}
    values |= {"no_friction": no_friction}
    given = {opt for dest, opt in URDF_OPTIONS.items() if values[dest]}
    locks = parse_locks(lock)
    xacro_args = parse_xacro_args(xacro_arg)
    if not is_urdf(model):
        if model not in arms.NAMES:
            raise ValueError(
                f"unknown model {model!r}: it is neither a shipped model ({', '.join(arms.NAMES)}) "
                "nor a robot file (a path ending in .urdf or .xacro, or an existing file)"
            )
        if given:
            raise ValueError(f"{', '.join(sorted(given))} apply to a URDF file, not to the shipped model {model!r}")
        if symbolic:
            try:
                return arms.load(model, symbolic=True)
            except ValueError:  # numeric only (read from its URDF)
                pass
        return arms.load(model)
    path = Path(model)
    if not path.is_file():
        raise ValueError(
            f"no URDF file {model}" + (": it is a folder" if path.is_dir() else f" (looked in {path.resolve().parent})")
        )
    if path.suffix.lower() == ".xml" and _is_mjcf(path):  # MuJoCo's MJCF: --base and --tip name bodies
        wrong = [opt for opt in NOT_MJCF if opt in given]
        if wrong:
            raise ValueError(f"{' and '.join(wrong)} apply to a xacro file, not to the MJCF file {model}")
        if balance_inertia:
            raise ValueError(
                f"--balance-inertia applies to a URDF or xacro file; for the MJCF file {model}, set MuJoCo's "
                "<compiler balanceinertia='true'/> in the file"
            )
        robot = _load_mjcf(
            path,
            base=base,
            tip=tip,
            locks=locks,
            exclude=exclude,
            no_snap=no_snap,
            name=name,
            tips=parse_tips(tips),
            base_joint=base_joint,
        )
        return _friction_as_asked(robot, no_friction)
    options = {"base_link": base, "tip_link": tip}
    if tips:
        options["tips"] = parse_tips(tips)
    if base_joint:
        options["base_joint"] = base_joint
    # only what was asked for, so that a reader without an option still reads the plain chain
    if locks:
        options["locked"] = locks
    if exclude:
        options["exclude"] = list(exclude)
    if no_snap:
        options["snap"] = False
    if xacro_args:
        options["xacro_args"] = xacro_args
    if package_path:
        options["package_paths"] = list(package_path)
    if balance_inertia:
        options["inertia"] = "balance"
    if massless:
        options["massless"] = True
    try:
        robot = Robot.from_urdf(path, name=name or _model_name(path), **options)
    except URDFError as exc:  # in the command line's words (--tip, --exclude, --xacro-arg, --package-path)
        raise type(exc)(exc.command_line) from None
    return _friction_as_asked(robot, no_friction)


def _friction_as_asked(robot: Robot, no_friction: bool) -> Robot:
    """A file's robot without its friction for --no-friction; the friction and rotor inertia the
    file gave said on stderr either way (tau against a peer without them, such as Pinocchio's rnea,
    differs by them: nobody should find out by comparing)."""
    if no_friction:
        robot = robot.nofriction(all=True)
    record = robot.urdf if robot.urdf is not None else robot.mjcf
    for line in record.friction_report() if record is not None else ():
        print(f"symdyn: {line}", file=sys.stderr)
    return robot


def _is_mjcf(path: Path) -> bool:
    from .mjcf import is_mjcf  # the MJCF reader needs MuJoCo only when a file is read

    return is_mjcf(path)


def _load_mjcf(
    path: Path, *, base, tip, locks: dict, exclude, no_snap: bool, name, tips=None, base_joint=None
) -> Robot:
    """The chain (or tree, --tips) of an MJCF file (root `<mujoco>`) by `Robot.from_mjcf`: --base,
    --tip and --tips name bodies, --lock hinge and slide joints, --exclude bodies."""
    options: dict = {"base_body": base, "tip_body": tip, "locked": locks, "exclude": list(exclude)}
    if tips is not None:
        options["tips"] = tips
    if base_joint is not None:
        options["base_joint"] = base_joint
    return Robot.from_mjcf(path, snap=not no_snap, name=name or path.stem, **options)


def urdf_options(args: argparse.Namespace) -> dict:
    """The URDF options `add_urdf_options` declared, as `load`'s keywords."""
    defaults = {
        "lock": (),
        "exclude": (),
        "no_snap": False,
        "xacro_arg": (),
        "package_path": (),
        "balance_inertia": False,
        "no_friction": False,
    }
    return {dest: getattr(args, dest, None) or defaults.get(dest) for dest in URDF_OPTIONS}


def from_args(args: argparse.Namespace, *, symbolic: bool = False, massless: bool = False) -> Robot:
    """`load` with the MODEL and URDF options `add_arguments` declared (`massless`: see `load`).

    Raises:
        ValueError: as `load`.
    """
    robot = load(args.model, symbolic=symbolic, massless=massless, **urdf_options(args))
    frames = getattr(args, "frames", None)
    return robot.with_frames(frames) if frames else robot
