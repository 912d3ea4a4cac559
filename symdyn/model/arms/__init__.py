"""Shipped arms: data with its source, loaded by name (also as `symdyn.models`).

`load("puma560")`, `load("twolink", symbolic=True)`, `load("panda")`; every
arm module has a `build(symbolic=False, …)` that returns a `symdyn.model.Robot`.
"""

from __future__ import annotations

from importlib import import_module

from ..robot import Robot

_MODULES = {
    "twolink": ("twolink", {}),
    "puma560": ("puma560", {}),
    "puma560_mdh": ("puma560", {"modified": True}),
    "rrp": ("rrp", {}),
    "panda": ("urdf_arms", {"name": "panda"}),
    "iiwa14": ("urdf_arms", {"name": "iiwa14"}),
    "ur5": ("urdf_arms", {"name": "ur5"}),
}

NAMES = tuple(_MODULES)


def load(name: str, symbolic: bool = False) -> Robot:
    """The shipped robot called `name` (one of `NAMES`), with its source in `robot.source`.

    Args:
        name: "twolink", "puma560", "puma560_mdh", "rrp", "panda", "iiwa14" or "ur5".
        symbolic: the symbolic variant (the two-link arm's a1, a2, c1, c2, m1, m2, g).

    Returns:
        The `Robot`.

    Raises:
        KeyError: an unknown name (the message lists the known ones).
    """
    if not isinstance(name, str) or name not in _MODULES:
        raise KeyError(f"unknown model {name!r}: known models are {', '.join(NAMES)}")
    module, options = _MODULES[name]
    return import_module(f"{__name__}.{module}").build(symbolic=symbolic, **options)
