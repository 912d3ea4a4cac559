"""Where a ROS package is, without ROS: the folder `$(find pkg)` and `package://pkg/` name.

Looked for, in this order: the `package_paths` given (`--package-path`), the
folders of `ROS_PACKAGE_PATH` (ROS 1), the prefixes of `AMENT_PREFIX_PATH`
(ROS 2: `PREFIX/share/pkg`), then the folders above the xacro file and their
children (a description beside the packages it uses, as in a workspace's
`src/`).  A folder is package `pkg` when it is named `pkg` (as
`share/pkg` is, whatever its package.xml says: example-robot-data's names
itself example_robot_descriptions) or its `package.xml` says `<name>pkg</name>`.  A package that is nowhere is an error listing every place
looked in, so the user sees which folder to add.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Iterable

from ..xml import URDFError

__all__ = ["PackageNotFound", "Packages"]

#: How deep a package path is searched below each folder given (a workspace's src/REPO/PKG is 2).
DEPTH = 3
_NAME = re.compile(r"<name>\s*([^<\s]+)\s*</name>")


class PackageNotFound(URDFError):
    """`$(find pkg)` or `package://pkg/` names a package found nowhere; `package` is its name and
    `looked` every place looked in."""

    def __init__(self, message: str, package: str, looked: tuple):
        super().__init__(message)
        self.package, self.looked = package, looked


def _declared(folder: Path) -> str | None:
    """The `<name>` in folder's package.xml (None without a readable one)."""
    try:
        match = _NAME.search((folder / "package.xml").read_text(errors="replace"))
    except OSError:
        return None
    return match.group(1) if match else None


def _is(folder: Path, package: str) -> bool:
    return folder.name == package and folder.is_dir() or _declared(folder) == package


def _crawl(folder: Path, package: str, depth: int) -> Path | None:
    """`package` in `folder` or below it (at most `depth` levels, not inside another package)."""
    if _is(folder, package):
        return folder
    if depth == 0 or _declared(folder) is not None:
        return None
    try:
        children = sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
    except OSError:
        return None
    for child in children:
        found = _crawl(child, package, depth - 1)
        if found is not None:
            return found
    return None


class Packages:
    """The package folders one expansion may use (see the module docstring); `found` keeps
    each package resolved, by name, for the record.

    Raises:
        URDFError: a package path that is not a folder (it is named).
    """

    def __init__(self, package_paths: Iterable[str | os.PathLike[str]] = (), start: Path | None = None):
        given = tuple(Path(p) for p in package_paths)
        for path in given:
            if not path.is_dir():
                raise URDFError(f"package path {str(path)!r} is not a folder")
        # absolute, from the working folder: a relative folder found by $(find pkg) would be read
        # again relative to the including file's folder (ws/src/pkg/urdf/ws/src/…)
        self.paths = tuple(path.resolve() for path in given)
        self.start = start.resolve() if start is not None else Path.cwd()
        self.found: dict[str, Path] = {}

    def _places(self) -> list[tuple[str, Path, int]]:
        """(why, folder, depth) in the order looked in; depth -1: the prefix's share/<pkg>;
        depth -2: the folder and its children only."""
        places = [("package path", p, DEPTH) for p in self.paths]
        places += [("ROS_PACKAGE_PATH", Path(p), DEPTH) for p in _env("ROS_PACKAGE_PATH")]
        places += [("AMENT_PREFIX_PATH", Path(p), -1) for p in _env("AMENT_PREFIX_PATH")]
        places += [("above the file", p, -2) for p in (self.start, *self.start.parents)]
        return places

    def find(self, package: str) -> Path:
        """The folder of `package`.

        Raises:
            PackageNotFound: (a `URDFError`) it is in none of the places looked in (all named).
        """
        if package in self.found:
            return self.found[package]
        looked = []
        for why, folder, depth in self._places():
            if depth == -1:
                candidate = folder / "share" / package
                found = candidate if candidate.is_dir() else None
                looked.append(f"{candidate} ({why})")
            elif depth == -2:
                found = _crawl(folder, package, 1)
                looked.append(f"{folder} and its subfolders ({why})")
            else:
                found = _crawl(folder, package, depth)
                looked.append(f"{folder} ({why}, {DEPTH} levels deep)")
            if found is not None:
                self.found[package] = found
                return found
        unset = [v for v in ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH") if not _env(v)]
        raise PackageNotFound(
            f"ROS package {package!r} not found (a folder named so, or with a package.xml naming it); looked in:\n  "
            + "\n  ".join(looked)
            + (f"\n({' and '.join(unset)} not set)" if unset else ""),
            package,
            tuple(looked),
        )

    def resolve_uri(self, text: str) -> str:
        """`package://pkg/rest` as the path of rest in pkg's folder; any other text unchanged.

        Raises:
            PackageNotFound: (a `URDFError`) pkg is found nowhere.
        """
        if not text.startswith("package://"):
            return text
        package, _, rest = text[len("package://") :].partition("/")
        return str(self.find(package) / rest)


def _env(name: str) -> list[str]:
    return [p for p in os.environ.get(name, "").split(os.pathsep) if p]
