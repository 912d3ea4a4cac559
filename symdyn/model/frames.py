"""Named frames on a robot: where the task space is measured (a hand, a foot, a sole, the tool).

Part of the model stage.  A `Frame` rides on one link (or on the base: link -1, the body a
base joint moves or, on a fixed base, the world's frame {0}) at a constant placement in
that link's own frame.  A robot knows every frame of the file it was read from (each link
of the file, moving, locked or merged by a fixed joint; each MJCF body and site:
`Robot.frame_catalog`) and, always, "tool" (the tool on the last link) and, where no file
names them, "base" and "link1", "link2", … (the links' own frames).  `Robot.frames` selects
the frames the generated task-space functions serve, in order; by default the tool of a
chain, the tips a tree was read with, or each leaf link of a tree.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass

__all__ = [
    "Frame",
    "known_frames",
    "resolve",
    "default_names",
    "served",
    "contact_set",
    "baumgarte_gains",
    "CONTACT_KINDS",
]

#: The kinds of contact (`Robot.with_contacts`) and the rows each constrains.
CONTACT_KINDS = {"point": 3, "surface": 6}

IDENTITY = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))


@dataclass(frozen=True)
class Frame:
    """A frame `name` fixed to link `link` (its index in `robot.links`; -1: the base) at
    `placement`, a 4×4 homogeneous transform in that link's frame (exact numbers or floats)."""

    name: str
    link: int
    placement: tuple = IDENTITY

    def key(self) -> tuple:
        """What identifies the frame in a fingerprint: name, link, placement."""
        return (self.name, self.link, self.placement)


def _implicit(robot) -> dict[str, Frame]:
    """The frames every robot has: the tool on the last link, and where no file names its
    links, "base" (link -1) and link1 … linkn (each link's own frame)."""
    out: dict[str, Frame] = {}
    if not robot.frame_catalog:
        out["base"] = Frame("base", -1)
        out.update((f"link{k + 1}", Frame(f"link{k + 1}", k)) for k in range(robot.n))
    out["tool"] = Frame("tool", robot.n - 1, robot.tool)
    return out


def known_frames(robot) -> dict[str, Frame]:
    """Every frame a user may ask for, by name: the file's (`robot.frame_catalog`), then the
    implicit ones (`_implicit`; the file's own name wins)."""
    out = {f.name: f for f in robot.frame_catalog}
    for name, frame in _implicit(robot).items():
        out.setdefault(name, frame)
    return out


def default_names(robot) -> tuple[str, ...]:
    """The frames served when none are chosen: the tool of a chain (on any base); each leaf
    link of a tree (a link no other hangs on), named as the file names its frame (else
    link<k>); the body of a robot without joints.  (A tree read with named tips serves those
    tips: the readers choose them.)"""
    if robot.n and all(link.parent is None for link in robot.links):
        return ("tool",)
    if robot.n == 0:  # a single body on its base joint (a drone): the body's own frame
        own = [f.name for f in robot.frame_catalog if f.link == -1 and _is_identity(f)]
        return (own[0] if own else "base",)
    parents = set(robot.parents)
    leaves = [k for k in range(robot.n) if k not in parents]
    own = {f.link: f.name for f in reversed(robot.frame_catalog) if _is_identity(f)}
    return tuple(own.get(k, f"link{k + 1}") for k in leaves)


def served(robot, names, tips: tuple):
    """A file reader's robot serving the frames `names`, or by default the tips it was read with
    when it names several (one tip makes a chain, whose tool is that tip; "all" names none:
    `default_names`).  tips: the tip names as read, each once, or ("all",) or ()."""
    if names is None and len(tips) > 1:
        names = tips
    return robot if names is None else robot.with_frames(names)


def _is_identity(frame: Frame) -> bool:
    return all(float(frame.placement[i][j]) == float(i == j) for i in range(4) for j in range(4))


def resolve(robot, names) -> tuple[Frame, ...]:
    """The frames called `names`, in order.

    Raises:
        ValueError: names that is a bare string or empty; a repeated name; a name the robot
            does not know (the closest known names are given).
    """
    if isinstance(names, str):
        raise ValueError(f"frames must be a list of frame names, got the string {names!r} (frames=[{names!r}])")
    names = tuple(names)
    if not names:
        raise ValueError(f"frames of robot {robot.name!r}: give at least one frame name")
    known = known_frames(robot)
    out = []
    for name in names:
        if not isinstance(name, str) or name not in known:
            close = _closest(str(name), list(known))
            if close or len(known) > 40:
                hint = f"; the closest known are {', '.join(close)}" if close else ""
                hint += f" (robot.frame_names lists all {len(known)})"
            else:
                hint = f"; its frames are {', '.join(known)}"
            raise ValueError(f"robot {robot.name!r} has no frame {name!r}{hint}")
        out.append(known[name])
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"frames of robot {robot.name!r}: {', '.join(map(repr, repeated))} given more than once")
    return tuple(out)


def _closest(name: str, known: list[str]) -> list[str]:
    """Up to five known names near `name`: those containing it (any case), then the most alike."""
    lower = {k.lower(): k for k in known}
    within = [k for k in known if name and name.lower() in k.lower()]
    alike = [lower[k] for k in difflib.get_close_matches(name.lower(), list(lower), n=5, cutoff=0.4)]
    return list(dict.fromkeys(within + alike))[:5]


def contact_set(robot, contacts) -> tuple:
    """((frame name, kind), …) checked: known frames, each once, kinds of `CONTACT_KINDS`.

    Raises:
        ValueError: contacts not pairs, an unknown frame (closest named), a kind that is
            neither "point" nor "surface", a frame given twice.
    """
    try:
        pairs = tuple((str(name), kind) for name, kind in contacts)
    except (TypeError, ValueError):
        raise ValueError(f"contacts must be {{frame: 'point' or 'surface'}}, got {contacts!r}") from None
    for name, kind in pairs:
        if kind not in CONTACT_KINDS:
            raise ValueError(
                f"contact {name!r} of robot {robot.name!r}: kind {kind!r} is neither 'point' (3 rows: the "
                "origin's linear acceleration) nor 'surface' (6 rows: the frame's spatial acceleration)"
            )
    if pairs:
        resolve(robot, [name for name, _ in pairs])  # known, each once
    return pairs


def baumgarte_gains(robot, gains) -> tuple:
    """(kp, kd) as floats, checked: finite, ≥ 0, and only with a contact set.

    Raises:
        ValueError: a gain negative, not a number or not finite; gains without contacts.
    """
    try:
        kp, kd = (float(g) for g in gains)
    except (TypeError, ValueError):
        raise ValueError(
            f"Baumgarte gains of robot {robot.name!r} must be two numbers (kp, kd), got {gains!r}"
        ) from None
    for name, g in (("kp", kp), ("kd", kd)):
        if not (math.isfinite(g) and g >= 0.0):
            raise ValueError(f"Baumgarte gain {name} of robot {robot.name!r} must be finite and >= 0, got {g!r}")
    if (kp or kd) and not robot.contacts:
        raise ValueError(f"Baumgarte gains of robot {robot.name!r} (kp={kp}, kd={kd}) need a contact set")
    return (kp, kd)
