"""xacro in front of the URDF reader: a `.xacro` file expanded in-process, without ROS.

`expand(path, xacro_args=…, package_paths=…)` gives the URDF text that
`from_urdf` then reads like any URDF; `Packages` finds the folders that
`$(find pkg)` and `package://pkg/` name.  The expander is ROS's own xacro
(the PyPI package `xacro`, the optional extra `symdyn[xacro]`).
"""

import os
from typing import Iterable, Mapping

from .expand import Expansion, XacroError, expand, is_xacro
from .packages import PackageNotFound, Packages

__all__ = ["expand", "expand_xacro", "is_xacro", "Expansion", "XacroError", "PackageNotFound", "Packages"]


def expand_xacro(
    path: str | os.PathLike[str],
    *,
    xacro_args: Mapping[str, object] | None = None,
    package_paths: Iterable[str | os.PathLike[str]] = (),
) -> str:
    """The URDF text a xacro file expands to — what `Robot.from_urdf` reads — for other tools
    (`symdyn expand FILE.xacro --xacro-arg k:=v > robot.urdf` on the command line).

    Raises:
        XacroError: as `expand` (the xacro package missing, an argument without a value, a
            package found nowhere, any other xacro error), or a file that is not xacro.
    """
    if not is_xacro(path, open(path, encoding="utf-8", errors="replace").read()):
        raise XacroError(f"{path} is not a xacro file (no .xacro suffix, no xacro namespace): it is read as it is")
    return expand(path, xacro_args=xacro_args, package_paths=package_paths).text
