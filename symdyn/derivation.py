"""`derive(robot, method)`: the one entry point to both derivations, cached.

Dispatches to `symdyn.lagrange` or `symdyn.newton_euler`, records timing
and keeps the result on disk (see `symdyn.cache`) so a second run of the
same derivation is a load, not a derivation.
"""

from __future__ import annotations

import dataclasses
import time

from . import __version__
from .cache import cached, key
from .dynamics import METHODS, Dynamics
from .model import Robot

#: Bump when Dynamics or a derivation changes shape, so old cache entries are not reused.
SCHEMA = 3


def derive(robot: Robot, method: str = "newton-euler", *, cache: bool = True,
           progress: bool = False) -> Dynamics:
    """Closed-form M, C, G, F and τ of `robot` by `method` ("lagrange" or "newton-euler")."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}: expected one of {', '.join(METHODS)}")
    if not isinstance(robot, Robot):
        raise ValueError(f"derive needs a symdyn Robot, got {type(robot).__name__}")

    def build() -> Dynamics:
        start = time.perf_counter()
        if method == "lagrange":  # well under a second for the Puma: no progress needed
            from .lagrange import derive as lagrange

            dyn = lagrange(robot)
        else:
            from .newton_euler import derive as newton_euler

            dyn = newton_euler(robot, progress=progress)
        dyn.stats["derive_seconds"] = time.perf_counter() - start
        return dyn

    entry = key(robot.fingerprint(), method, __version__, str(SCHEMA))
    dyn, hit = cached(f"derive-{method}", entry, build, use_cache=cache)
    dyn = dataclasses.replace(dyn, robot=robot)  # the caller's name and poses
    dyn.stats["from_cache"] = hit
    return dyn
