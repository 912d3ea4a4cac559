"""An MJCF file compiled by MuJoCo itself, so that every convention of the format holds.

The first step of `from_mjcf`: read the file (or its text) into an `MjSpec`
(MuJoCo's parser: `<include>`, `<default>` classes, `childclass`, compiler
`angle`/`eulerseq`, every orientation form), leave out mesh and texture files
that are absent where no inertia depends on them, and compile it into an
`MjModel` whose numbers (body frames, inertials — from the geoms where a
body has no `<inertial>` —, joint anchors and axes, armature, damping,
limits, actuators, gravity) the reader then turns into a `Robot`.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

__all__ = ["MJCFError", "MJCFWarning", "Compiled", "compile_mjcf", "is_mjcf", "mujoco_module"]


class MJCFError(ValueError):
    """An MJCF file that cannot become a robot; the message names the file and the body or joint."""


class MJCFWarning(UserWarning):
    """Something of an MJCF file that symdyn does not model (it is listed in the record too)."""


@dataclass(frozen=True)
class Compiled:
    """The compiled model, the spec it came from, the file's name and sha256, the files left out,
    and the equality constraints that vanished with the excluded bodies (`describe_equality`)."""

    model: object  # mujoco.MjModel
    spec: object  # mujoco.MjSpec
    file: str
    sha256: str
    stripped: tuple
    vanished: tuple = ()


def describe_equality(kind, name: str, first: str, second: str) -> str:
    """An equality constraint as a person names it: "connect 'hand'–'handle'", "joint 'couple'
    ('j1'–'j2')" (MuJoCo's type without its prefix, the name where the file gives one)."""
    label = str(getattr(kind, "name", kind)).removeprefix("mjEQ_").lower()
    objects = "–".join(repr(x) for x in (first, second) if x)
    return f"{label} {name!r} ({objects})" if name else f"{label} {objects}"


def mujoco_module():
    """The `mujoco` package, or an MJCFError that says how to install it.

    Raises:
        MJCFError: `mujoco` is not installed.
    """
    try:
        import mujoco
    except ImportError:
        raise MJCFError(
            "reading MJCF files needs MuJoCo's compiler: pip install 'symdyn[mjcf]' (the mujoco package)"
        ) from None
    return mujoco


def is_mjcf(path: str | os.PathLike[str]) -> bool:
    """Whether `path` is a file whose root element is `<mujoco>` (read from its first 4 kB).

    Raises:
        OSError: never for a missing or unreadable file (that is False).
    """
    try:
        with open(path, "rb") as f:
            head = f.read(4096).decode("utf-8", "replace")
    except OSError:
        return False
    body = head
    while True:  # skip the declaration, comments and processing instructions
        body = body.lstrip()
        if body.startswith("<?"):
            body = body.partition("?>")[2]
        elif body.startswith("<!--"):
            body = body.partition("-->")[2]
        else:
            break
    return body.startswith("<mujoco") and (len(body) == 7 or not body[7].isalnum())


def _resolve(spec, directory: str, file: str) -> Path:
    """Where MuJoCo looks for an asset `file` (absolute, or under the model's folder and `directory`)."""
    if os.path.isabs(file):
        return Path(file)
    if os.path.isabs(directory):
        return Path(directory) / file
    return Path(spec.modelfiledir or ".") / directory / file


def _strip_absent_files(mujoco, spec, label: str) -> tuple:
    """Delete mesh geoms and meshes whose files are absent, and absent textures (their materials
    keep their colour), where no inertia depends on them; else an MJCFError naming the body."""
    stripped = []
    geom_inertia = spec.compiler.inertiafromgeom
    absent = {}
    for mesh in list(spec.meshes):
        if mesh.file and not _resolve(spec, spec.meshdir, mesh.file).is_file():
            absent[mesh.name] = mesh
    if absent:
        for geom in list(spec.geoms):
            if geom.type != mujoco.mjtGeom.mjGEOM_MESH or geom.meshname not in absent:
                continue
            body = geom.parent
            needs = geom_inertia == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE or (
                geom_inertia == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_AUTO and not body.explicitinertial
            )
            if needs:
                where = f" ({body.info})" if body.info else ""
                why = "" if body.explicitinertial else " and it has no <inertial>"
                raise MJCFError(
                    f"{label}: body {body.name or '#' + str(body.id)!r}{where} gets its inertia from mesh "
                    f"{geom.meshname!r}, whose file {absent[geom.meshname].file!r} is absent "
                    f"(looked in {_resolve(spec, spec.meshdir, '.').resolve()}){why}: give the mesh files, "
                    "an <inertial> for the body, or exclude= it when it is off the chain"
                )
            spec.delete(geom)
        for name, mesh in absent.items():
            stripped.append(f"mesh {name!r} ({mesh.file})")
            spec.delete(mesh)
    for texture in list(spec.textures):
        if texture.file and not _resolve(spec, spec.texturedir, texture.file).is_file():
            for material in spec.materials:
                names = list(material.textures)
                if texture.name in names:
                    material.textures = ["" if t == texture.name else t for t in names]
            stripped.append(f"texture {texture.name!r} ({texture.file})")
            spec.delete(texture)
    return tuple(stripped)


def _ancestors(body) -> list[str]:
    """The names of `body` and the bodies above it, up to the world."""
    out = []
    while body is not None:
        out.append(body.name)
        body = body.parent  # the world's is None
    return out


def _check_excluded(spec, label: str, exclude: tuple, base: str | None, tip: str | None) -> None:
    base = base or "world"
    for name in exclude:
        body = spec.body(name)
        if body is None:
            names = [b.name for b in spec.bodies if b.name]
            raise MJCFError(f"{label}: excluded body {name!r} is not a body of the file; its bodies are {names}")
        if base not in _ancestors(body)[1:]:
            raise MJCFError(f"{label}: excluded body {name!r} is not below base_body {base!r}: it is out already")
        for end in (base, tip):
            held = spec.body(end) if end else None
            if held is not None and name in _ancestors(held):
                raise MJCFError(
                    f"{label}: excluded body {name!r} is on the chain from base to tip (it holds {end!r}); "
                    "choose another base_body or tip_body instead"
                )


def compile_mjcf(
    path_or_xml: str | os.PathLike[str], exclude: tuple = (), base: str | None = None, tip: str | None = None
) -> Compiled:
    """Parse and compile an MJCF file (or its text) with MuJoCo, absent mesh and texture
    files left out where no inertia depends on them, the bodies in `exclude` (names, below
    the body `base` and off the chain to `tip`) deleted with their subtrees.

    Raises:
        MJCFError: `mujoco` is not installed; an unreadable file, or one MuJoCo refuses
            (its message, prefixed by the file); a body whose inertia depends on an
            absent mesh file; an excluded body the file does not have, that is not below
            the base, or that holds the base or the tip.
    """
    mujoco = mujoco_module()
    text_given = isinstance(path_or_xml, str) and path_or_xml.lstrip().startswith("<")
    if text_given:
        data, label = path_or_xml.encode(), "<string>"
    else:
        path = Path(path_or_xml)
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise MJCFError(f"cannot read MJCF file {path}: {exc.strerror or exc}") from None
        label = path.name
    try:
        spec = mujoco.MjSpec.from_string(data.decode()) if text_given else mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise MJCFError(f"{label}: MuJoCo cannot read it: {str(exc).strip()}") from None
    _check_excluded(spec, label, exclude, base, tip)
    equalities = lambda: [describe_equality(e.type, e.name, e.name1, e.name2) for e in spec.equalities]  # noqa: E731
    before = equalities()
    for name in exclude:
        spec.delete(spec.body(name))
    after = equalities()
    vanished = tuple(e for e in before if e not in after)
    stripped = _strip_absent_files(mujoco, spec, label)
    try:
        model = spec.compile()
    except ValueError as exc:
        raise MJCFError(f"{label}: MuJoCo cannot compile it: {str(exc).strip()}") from None
    return Compiled(model, spec, label, hashlib.sha256(data).hexdigest(), stripped, vanished)
