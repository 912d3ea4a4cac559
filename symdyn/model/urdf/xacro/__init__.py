"""xacro in front of the URDF reader: a `.xacro` file expanded in-process, without ROS.

`expand(path, xacro_args=…, package_paths=…)` gives the URDF text that
`from_urdf` then reads like any URDF; `Packages` finds the folders that
`$(find pkg)` and `package://pkg/` name.  The expander is ROS's own xacro
(the PyPI package `xacro`, the optional extra `symdyn[xacro]`).
"""

from .expand import Expansion, XacroError, expand, is_xacro
from .packages import PackageNotFound, Packages

__all__ = ["expand", "is_xacro", "Expansion", "XacroError", "PackageNotFound", "Packages"]
