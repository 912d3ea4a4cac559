"""URDF out: `to_urdf(robot, path=None, *, source=None)` → the URDF text with the robot's inertials.

The way back from a model whose parameters changed (identified, perturbed)
to the user's other tools (Pinocchio, MuJoCo, Gazebo).  Two modes:

- **splice** — the robot was read from a URDF (`robot.urdf`) and that file
  is at hand (`source`, the record's file, or a shipped arm's file with the
  same sha256): the original text is kept byte for byte except the
  `<inertial>` of each moving link whose body changed (and its joint's
  `<dynamics>` when the friction changed).  A moving link's body in symdyn
  is the link *plus everything riding on it* (fixed-joint children, locked
  branches, merged exactly by the reader); those riders keep their own
  inertials as the file has them, and the moving link's own `<inertial>`
  becomes the difference, body − riders (linear in mass, first moment and
  inertia about the link origin), so that reading the file back merges to
  the new body.  Where that difference is not a physical body (the new body
  is lighter than its riders), the riders' inertials are removed and the
  whole body goes to the moving link (an XML comment says so).  An inertia
  that `inertia="balance"` repaired on reading is written repaired, a comment
  saying what changed: the file holds the bodies symdyn computes with.
- **fresh** — otherwise: a chain base_link → link1 … linkN (→ tool) with
  the robot's joint placements (modified-DH frames for a DH robot, the
  joint origins and axes for a general one), limits and inertials.

URDF has no rotor inertia, gear ratio or asymmetric Coulomb friction:
`<dynamics damping=G²B friction=|G|(Tc⁺ − Tc⁻)/2>` is written, and what
cannot be said is named in a comment (and in a warning).
"""

from __future__ import annotations

import math
import os
import tempfile
import warnings
from importlib import resources
from pathlib import Path
from xml.parsers import expat

import numpy as np

from .. import inertia
from ..placement import exact_cos_sin
from ..robot import IDENTITY, Robot
from .bodies import balanced
from .reader import from_urdf
from .tree import Tree
from .xml import URDFError, URDFWarning, parse, read

__all__ = ["to_urdf"]


def _f(x) -> str:
    """A float as the shortest decimal that reads back to the same double."""
    x = float(x)
    return repr(0.0 if x == 0 else x)


# --------------------------------------------------------------------------- bodies as 10-vectors


def _about_origin(m: float, r, I) -> tuple:
    """(m, h = m·r, I_o) of a body with COM r and COM inertia I (link axes)."""
    r = np.asarray(r, dtype=float)
    I = np.asarray(I, dtype=float)
    return float(m), m * r, I + m * (r @ r * np.eye(3) - np.outer(r, r))


def _about_com(body: tuple) -> tuple:
    m, h, Io = body
    if m == 0:
        return 0.0, np.zeros(3), Io
    r = h / m
    return m, r, Io - m * (r @ r * np.eye(3) - np.outer(r, r))


def _physical(body: tuple) -> bool:
    m, _, I = _about_com(body)
    eig = np.linalg.eigvalsh((I + I.T) / 2)
    return m >= 0 and inertia.semidefinite(eig) and inertia.obeys_triangle(eig)


def _inertial_xml(m, r, I, indent: str) -> str:
    """An <inertial> of mass m, COM r and inertia I about the COM (link axes), as given."""
    m = float(m)
    r = [float(x) for x in r]
    I = np.array([[float(x) for x in row] for row in I])
    return (
        f"{indent}<inertial>\n"
        f'{indent}  <origin xyz="{_f(r[0])} {_f(r[1])} {_f(r[2])}" rpy="0 0 0"/>\n'
        f'{indent}  <mass value="{_f(m)}"/>\n'
        f'{indent}  <inertia ixx="{_f(I[0, 0])}" ixy="{_f(I[0, 1])}" ixz="{_f(I[0, 2])}" '
        f'iyy="{_f(I[1, 1])}" iyz="{_f(I[1, 2])}" izz="{_f(I[2, 2])}"/>\n'
        f"{indent}</inertial>"
    )


def _link_body(link) -> tuple:
    return _about_origin(float(link.m), [float(x) for x in link.r], [[float(x) for x in row] for row in link.I])


def _friction(link) -> tuple[float, float, list]:
    """damping, friction for a joint's <dynamics>, and what URDF cannot say."""
    G = float(link.G)
    tp, tn = (float(x) for x in link.Tc)
    lost = []
    if float(link.Jm) != 0:
        lost.append(f"rotor inertia Jm={_f(link.Jm)} (G={_f(G)})")
    if tp + tn != 0:
        lost.append(f"asymmetric Coulomb friction Tc=({_f(tp)}, {_f(tn)}) (written as its mean magnitude)")
    return G * G * float(link.B), abs(G) * (tp - tn) / 2, lost


# --------------------------------------------------------------------------- splice


def _spans(text: str) -> dict:
    """Byte spans of each link's start tag, <inertial> and its <inertia>, and of each joint's
    <dynamics>: {("link", name): {"start": (a, b), "inertial": (a, b), "inertia": (a, b),
    "empty": bool}, ("joint", name): …}."""
    data = text.encode()
    parser = expat.ParserCreate()
    stack: list = []
    spans: dict = {}

    def close(at: int) -> int:
        """The byte after the tag that starts at `at` (a '>' inside a quoted value is not its end)."""
        quote = None
        for k in range(at, len(data)):
            c = data[k : k + 1]
            if quote:
                quote = None if c == quote else quote
            elif c in (b'"', b"'"):
                quote = c
            elif c == b">":
                return k + 1
        raise URDFError("a tag without its '>'")

    def finish(at: int, begin: int) -> int:
        """The byte after the element that started at `begin`; expat reports a self-closing
        element's end at the next token, an element with content's at its end tag."""
        head = close(begin)
        return head if data[head - 2 : head] == b"/>" else close(at)

    def start(tag, attrib):
        at = parser.CurrentByteIndex
        stack.append((tag, attrib, at))
        if len(stack) == 2 and tag in ("link", "joint"):
            end = close(at)
            spans[(tag, attrib.get("name"))] = {"start": (at, end), "empty": data[end - 2 : end] == b"/>"}
        if len(stack) == 3 and stack[1][0] in ("link", "joint") and tag in ("inertial", "dynamics"):
            spans[(stack[1][0], stack[1][1].get("name"))][tag] = [at, None]
        if len(stack) == 4 and stack[1][0] == "link" and stack[2][0] == "inertial" and tag == "inertia":
            spans[("link", stack[1][1].get("name"))][tag] = [at, None]

    def end(tag):
        at = parser.CurrentByteIndex
        _, attrib, begin = stack.pop()
        if len(stack) == 2 and stack[1][0] in ("link", "joint") and tag in ("inertial", "dynamics"):
            key = (stack[1][0], stack[1][1].get("name"))
            spans[key][tag][1] = finish(at, begin)
        if len(stack) == 3 and stack[1][0] == "link" and stack[2][0] == "inertial" and tag == "inertia":
            spans[("link", stack[1][1].get("name"))][tag][1] = finish(at, begin)
        if len(stack) == 1 and tag in ("link", "joint"):
            spans[(tag, attrib.get("name"))]["end"] = finish(at, begin)

    parser.StartElementHandler, parser.EndElementHandler = start, end
    parser.Parse(data, True)
    return spans


def _original_text(robot: Robot, source) -> str | None:
    record = robot.urdf
    if source is not None:
        text = read(source)
        if text.sha256 != record.sha256:
            raise URDFError(
                f"source {text.source} is not the file robot {robot.name!r} was read from: its sha256 is "
                f"{text.sha256}, the robot's record says {record.sha256}"
            )
        return text.text
    candidates = [Path(record.file)] if record.file and "<" not in record.file else []
    data = resources.files("symdyn.model.arms").joinpath("data")
    candidates += [Path(str(p)) for p in data.iterdir() if str(p).endswith(".urdf")]
    for path in candidates:
        try:
            text = read(path)
        except URDFError:
            continue
        if text.sha256 == record.sha256:
            return text.text
    return None


def _repaired(text: str, repairs: tuple) -> str:
    """The file with each inertia that `inertia="balance"` repaired on reading replaced by the
    repair (same `<inertial>` frame, mass and origin), a comment saying what changed: the file
    then holds the bodies symdyn computes with and reads back with nothing to repair."""
    tree = Tree.of("<source>", parse(text, "<source>"))
    spans = _spans(text)
    edits = []
    for repair in repairs:
        tensor = tree.links[repair.link].find("inertial").find("inertia")
        k = {key: float(tensor.attrib.get(key, 0)) for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        I = ((k["ixx"], k["ixy"], k["ixz"]), (k["ixy"], k["iyy"], k["iyz"]), (k["ixz"], k["iyz"], k["izz"]))
        J = np.array(balanced(I)[0], dtype=float)
        a, b = spans[("link", repair.link)]["inertia"]
        indent = _indent(text, a)
        edits.append(
            (
                a,
                b,
                f"<!-- symdyn: impossible inertia made physical (inertia='balance'): {repair.line()} -->\n{indent}"
                f'<inertia ixx="{_f(J[0, 0])}" ixy="{_f(J[0, 1])}" ixz="{_f(J[0, 2])}" '
                f'iyy="{_f(J[1, 1])}" iyz="{_f(J[1, 2])}" izz="{_f(J[2, 2])}"/>',
            )
        )
    return _edited(text, edits)


def _edited(text: str, edits: list) -> str:
    """`text` with each (start byte, end byte, replacement) applied; the spans do not overlap."""
    data = text.encode()
    for a, b, replacement in sorted(edits, reverse=True):
        data = data[:a] + replacement.encode() + data[b:]
    return data.decode()


def _splice(robot: Robot, text: str) -> str:
    record = robot.urdf
    text = _repaired(text, getattr(record, "repairs", ()))
    given = {lock.joint: lock.value for lock in record.locked if lock.why == "given"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", URDFWarning)
        original = from_urdf(
            text,
            base_link=record.base_link,
            tip_link=record.tip_link or None,
            tips=None if not getattr(record, "tips", ()) else "all" if record.tips == ("all",) else list(record.tips),
            base_joint=getattr(record, "base_joint", None),
            locked=given or None,
            exclude=record.excluded,
            snap=record.snap,
            inertia="check",  # repairs are written: the file as it now reads
            massless=True,  # the file as read before; its mass, or lack of it, is the robot's to replace
        )
    if original.n != robot.n:
        raise URDFError(f"robot {robot.name!r} has {robot.n} joints, its URDF chain {original.n}")
    tree = Tree.of("<source>", parse(text, "<source>"))
    chain = {record.base_link}
    for name in record.joints:
        chain.add(tree.named[name].find("child").attrib["link"])

    def riders(link: str) -> list:
        out = []
        for child in tree.children.get(link, []):
            if child in chain or child in record.excluded:
                continue
            out += [child] + riders(child)
        return out

    def own(link: str) -> tuple:
        """The link's own <inertial> as written, in its frame (floats)."""
        element = tree.links[link].find("inertial")
        if element is None or element.find("mass") is None:
            return 0.0, np.zeros(3), np.zeros((3, 3))
        m = float(element.find("mass").attrib.get("value", 0))
        tensor = element.find("inertia")
        k = {
            key: float(tensor.attrib.get(key, 0)) if tensor is not None else 0.0
            for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        }
        I = np.array([[k["ixx"], k["ixy"], k["ixz"]], [k["ixy"], k["iyy"], k["iyz"]], [k["ixz"], k["iyz"], k["izz"]]])
        origin = element.find("origin")
        xyz = [float(v) for v in origin.attrib.get("xyz", "0 0 0").split()] if origin is not None else [0, 0, 0]
        rpy = [float(v) for v in origin.attrib.get("rpy", "0 0 0").split()] if origin is not None else [0, 0, 0]
        R = _rpy_matrix(rpy)
        return _about_origin(m, xyz, R @ I @ R.T)

    spans = _spans(text)
    edits = []  # (start, end, replacement)
    for j, (new, old, joint_name) in enumerate(zip(robot.links, original.links, record.joints)):
        joint = tree.named[joint_name]
        link_name = joint.find("child").attrib["link"]
        if (new.m, new.r, new.I) != (old.m, old.r, old.I):
            body, total, mine = _link_body(new), _link_body(old), own(link_name)
            write = tuple(b - t + o for b, t, o in zip(body, total, mine))
            note = ""
            if not riders(link_name):  # the link alone: its numbers as they are (they read back exactly)
                write = (new.m, new.r, new.I)
            elif _physical(write):
                write = _about_com(write)
            else:  # lighter than what rides on it: everything to the moving link
                write, note = (
                    (new.m, new.r, new.I),
                    (
                        f"symdyn: the identified body of link {link_name!r} could not be split from "
                        f"what rides on it ({', '.join(riders(link_name))}); their inertials were "
                        "removed and the whole body is here"
                    ),
                )
                for rider in riders(link_name):
                    span = spans[("link", rider)]
                    if "inertial" in span and (own(rider)[0] != 0 or np.any(own(rider)[2])):
                        a, b = span["inertial"]
                        edits.append((a - len(_indent(text, a)) - 1, b, ""))  # with its line
            span = spans[("link", link_name)]
            indent = _indent(text, span["start"][0]) + "  "
            block = (f"<!-- {note} -->\n{indent}" if note else "") + _inertial_xml(*write, indent).lstrip()
            if "inertial" in span:
                edits.append((*span["inertial"], block))
            elif span["empty"]:
                a, b = span["start"]
                tag = text.encode()[a : b - 2].decode().rstrip()
                edits.append((a, b, f"{tag}>\n{indent}{block}\n{indent[:-2]}</link>"))
            else:
                a, b = span["start"]
                edits.append((b, b, f"\n{indent}{block}"))
        if (new.B, new.Tc, new.Jm, new.G) != (old.B, old.Tc, old.Jm, old.G):
            damping, friction, lost = _friction(new)
            span = spans[("joint", joint_name)]
            indent = _indent(text, span["start"][0]) + "  "
            block = f'<dynamics damping="{_f(damping)}" friction="{_f(friction)}"/>'
            if lost:
                block = f"<!-- symdyn: not expressible in URDF: {'; '.join(lost)} -->\n{indent}" + block
                _warn_lost(joint_name, lost)
            if "dynamics" in span:
                edits.append((*span["dynamics"], block))
            else:
                a = span["end"]
                close = text.encode().rindex(b"</joint>", 0, a)
                edits.append((close, close, f"  {block}\n{indent[:-2]}"))
    return _edited(text, edits)


def _warn_lost(joint: str, lost: list) -> None:
    warnings.warn(
        f"joint {joint!r}: not expressible in URDF (written as a comment): {'; '.join(lost)}", URDFWarning, stacklevel=4
    )


def _indent(text: str, at_byte: int) -> str:
    data = text.encode()
    line_start = data.rfind(b"\n", 0, at_byte) + 1
    prefix = data[line_start:at_byte].decode()
    return prefix if not prefix.strip() else ""


# --------------------------------------------------------------------------- fresh


def _rpy_matrix(rpy) -> np.ndarray:
    r, p, y = (float(a) for a in rpy)
    cr, sr, cp, sp_, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp_], [0, 1, 0], [-sp_, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _rpy(R: np.ndarray) -> tuple:
    """roll, pitch, yaw with R = Rz(yaw)·Ry(pitch)·Rx(roll)."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if abs(abs(pitch) - math.pi / 2) < 1e-12:  # gimbal lock: yaw 0
        return math.atan2(-R[1, 2], R[1, 1]), pitch, 0.0
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def _origin_xml(T: np.ndarray) -> str:
    r, p, y = _rpy(T[:3, :3])
    return f'<origin xyz="{_f(T[0, 3])} {_f(T[1, 3])} {_f(T[2, 3])}" rpy="{_f(r)} {_f(p)} {_f(y)}"/>'


def _matrix(T) -> np.ndarray:
    return np.array([[float(x) for x in row] for row in T])


def _rot(axis: str, angle) -> np.ndarray:
    c, s = (float(v) for v in exact_cos_sin(angle))
    T = np.eye(4)
    i, j = {"x": (1, 2), "z": (0, 1)}[axis]
    T[i, i], T[i, j], T[j, i], T[j, j] = c, -s, s, c
    return T


def _trans(x, y, z) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = [float(x), float(y), float(z)]
    return T


def _fresh(robot: Robot) -> str:
    if tuple(float(g) for g in robot.gravity) != (0.0, 0.0, 9.81):
        warnings.warn(
            f"robot {robot.name!r} has gravity {robot.gravity}; URDF assumes 9.81 m/s² along the "
            "base's −z, which the file's readers will use",
            URDFWarning,
            stacklevel=3,
        )
    model = robot.to_modified() if robot.convention == "standard" else robot
    width = len(str(model.n))  # joint1 … joint9, joint01 … joint12: siblings read back in this order
    lines = [
        '<?xml version="1.0"?>',
        f'<robot name="{robot.name}">',
        f"  <!-- written by symdyn from the {robot.convention} model {robot.name!r}; "
        f"fingerprint {robot.fingerprint()} -->",
    ]
    base = _matrix(model.base)
    if model.base_joint is not None:  # the file's own floating joint carries base_link (its body's inertial)
        kind = "floating" if model.base_joint == "free" else "planar"
        body = model.base_body
        lines += [
            '  <link name="world"/>',
            f'  <joint name="root_joint" type="{kind}">',
            '    <parent link="world"/>',
            '    <child link="base_link"/>',
            f"    {_origin_xml(base)}",
            *(['    <axis xyz="0 0 1"/>'] if kind == "planar" else []),
            "  </joint>",
            '  <link name="base_link">',
            *([_inertial_xml(body.m, body.r, body.I, "    ")] if body is not None else []),
            "  </link>",
        ]
        base = np.eye(4)
    else:
        lines.append('  <link name="base_link"/>')
    names = [f"link{j + 1:0{width}d}" for j in range(model.n)]
    for j, link in enumerate(model.links):
        name = names[j]
        parent = model.parents[j]
        previous = "base_link" if parent < 0 else names[parent]
        if model.convention == "general":
            T = _matrix(link.origin or IDENTITY)
            axis = np.array([float(a) for a in link.axis])
            if float(link.offset) != 0:
                if link.is_revolute:
                    u = axis
                    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
                    a = float(link.offset)
                    R = np.eye(4)
                    R[:3, :3] = np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K
                    T = T @ R
                else:
                    T = T @ _trans(*(axis * float(link.offset)))
        else:  # modified DH: Rx(α) Tx(a) then Rz(θ) Tz(d), the joint's variable part moved out
            axis = np.array([0.0, 0.0, 1.0])
            T = _rot("x", link.alpha) @ _trans(link.a, 0, 0)
            if link.is_revolute:
                T = T @ _trans(0, 0, link.d) @ _rot("z", link.offset)
            else:
                T = T @ _rot("z", link.theta) @ _trans(0, 0, link.offset)
        if parent < 0:
            T = base @ T
        damping, friction, lost = _friction(link)
        kind = "prismatic" if not link.is_revolute else ("revolute" if link.qlim is not None else "continuous")
        limit = ""
        if link.qlim is not None or link.effort_limit or link.velocity_limit:
            bounds = f'lower="{_f(link.qlim[0])}" upper="{_f(link.qlim[1])}" ' if link.qlim is not None else ""
            limit = (
                f'\n    <limit {bounds}effort="{_f(link.effort_limit or 0)}" '
                f'velocity="{_f(link.velocity_limit or 0)}"/>'
            )
        joint = link.name or f"joint{j + 1:0{width}d}"
        if lost:
            lines.append(f"  <!-- symdyn: not expressible in URDF: {'; '.join(lost)} -->")
            _warn_lost(joint, lost)
        lines += [
            f'  <joint name="{joint}" type="{kind}">',
            f'    <parent link="{previous}"/>',
            f'    <child link="{name}"/>',
            f"    {_origin_xml(T)}",
            f'    <axis xyz="{_f(axis[0])} {_f(axis[1])} {_f(axis[2])}"/>{limit}',
            f'    <dynamics damping="{_f(damping)}" friction="{_f(friction)}"/>',
            "  </joint>",
            f'  <link name="{name}">',
            _inertial_xml(link.m, link.r, link.I, "    "),
            "  </link>",
        ]
    tool = _matrix(model.tool)
    if not np.array_equal(tool, np.eye(4)):
        lines += [
            '  <joint name="tool_joint" type="fixed">',
            f'    <parent link="{names[-1]}"/>',
            '    <child link="tool"/>',
            f"    {_origin_xml(tool)}",
            "  </joint>",
            '  <link name="tool"/>',
        ]
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- entry point


def to_urdf(
    robot: Robot, path: str | os.PathLike[str] | None = None, *, source: str | os.PathLike[str] | None = None
) -> str:
    """The URDF text of `robot` with its inertials (module docstring); written to `path`
    (atomically) when given.  source: the URDF the robot was read from (path or text),
    when `robot.urdf` names a file that is not at hand.

    Raises:
        ValueError: a symbolic robot, or `source` for a robot not read from a URDF.
        URDFError: (a `ValueError`) a `source` that cannot be read or is not the file
            the robot was read from (its sha256 differs), or whose chain has another
            number of joints than the robot.
        OSError: `path` cannot be written.

    Warns:
        URDFWarning: the robot's URDF is not at hand, or was xacro (a fresh URDF of the
            chain is written instead); a gravity other than URDF's 9.81 m/s² along −z; a
            joint parameter URDF cannot express (written as a comment).
    """
    robot.require_numeric("to_urdf")
    text = None
    if robot.urdf is not None and getattr(robot.urdf, "is_xacro", False):
        warnings.warn(  # its links live in macros: there is no URDF text to splice into
            f"the robot {robot.name!r} was read from the xacro file {robot.urdf.file!r}: "
            "writing a fresh URDF of the model (its tree, its floating body) instead",
            URDFWarning,
            stacklevel=2,
        )
    elif robot.urdf is not None:
        original = _original_text(robot, source)
        if original is None:
            warnings.warn(
                f"the URDF robot {robot.name!r} was read from {robot.urdf.file!r}, which is not at hand "
                "(pass source=…): writing a fresh URDF of the model (its tree, its floating body) instead",
                URDFWarning,
                stacklevel=2,
            )
        else:
            text = _splice(robot, original)
    elif source is not None:
        raise ValueError(f"robot {robot.name!r} was not read from a URDF: source= has nothing to splice into")
    if text is None:
        text = _fresh(robot)
    if path is not None:
        path = Path(path)
        fd, tmp = tempfile.mkstemp(dir=path.parent or ".", prefix=path.name, suffix=".tmp")
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
        os.replace(tmp, path)
    return text
