"""`derive(robot, method)`: the one entry point to both derivations, cached.

Dispatches to `lagrange` (expanded trigonometric polynomials up to six
joints, `lagrange_dag` beyond) or `newton_euler`, records timing and keeps the
result on disk (see `cache`) so a second run of the same derivation is a
load, not a derivation.  The key covers the model, the method, symdyn's
version and the source of the model and derivation stages.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import time
from pathlib import Path

from .. import __version__
from .cache import cached, key
from .dynamics import METHODS, Dynamics
from ..model import Robot

#: Up to this many joints Lagrange expands trigonometric polynomials (closed forms a reader
#: can fold and print); beyond, they grow to 10⁴–10⁶ terms and it works on named intermediates.
EXPANDED_MAX_JOINTS = 6

#: The stages whose code decides a derivation's result: their source is part of the cache key.
_SOURCES = (Path(__file__).parent, Path(__file__).parent.parent / "model")


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """Hash of the model and derivation code (every module, by path and content),
    so an edited derivation never reuses old cache entries."""
    digest = hashlib.sha256()
    for folder in _SOURCES:
        for path in sorted(folder.rglob("*.py")):
            digest.update(path.relative_to(folder.parent).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def derive(
    robot: Robot, method: str = "newton-euler", *, regroup: bool = False, cache: bool = True, progress: bool = False
) -> Dynamics:
    """Closed-form M, C, G, F and τ of `robot` by `method` ("lagrange" or "newton-euler").

    regroup=True (Newton–Euler, numeric robots): run the recursion on the
    regrouped base parameters (`regressor`), which gives the same
    joint-space dynamics with about a quarter fewer operations — the form
    code generation wants.  It leaves out the n(n + 1)/2 Christoffel
    recursions, the one part that grows like n³: code generation takes C
    as ½ ∂(C q̇)/∂q̇ (fewer operations on every shipped arm and on random arms
    of 3–7 joints: 3289 against 7840 on a 7-joint one), and so does `Dynamics.C`.

    A tree (links whose parent is not the link before) is derived as a chain is, each
    recursion running through the parents; M's entries between branches are exact zeros.
    A floating base: q = (base coordinates, joints), v and τ = (base, joints)
    (`symdyn.derivation.floating`), C with its velocities' brackets; regroup=True regroups the base
    body's parameters with the links' (`regressor.base_parameters`).  Lagrange derives it on
    named intermediates at any size (`lagrange_dag`: Hamel's equations in the base's velocities).

    Raises:
        ValueError: an unknown method, something that is not a `Robot`, or regroup=True
            for Lagrange or a symbolic robot.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}: expected one of {', '.join(METHODS)}")
    if not isinstance(robot, Robot):
        raise ValueError(f"derive needs a symdyn Robot, got {type(robot).__name__}")
    if regroup and (method != "newton-euler" or robot.is_symbolic):
        raise ValueError(
            "regroup=True needs method='newton-euler' and a numeric robot "
            f"(got {method!r}, symbols {sorted(map(str, robot.free_symbols))})"
        )

    def build() -> Dynamics:
        start = time.perf_counter()
        expanded = robot.n <= EXPANDED_MAX_JOINTS and robot.base_joint is None
        if method == "lagrange" and expanded:  # under a second for the Puma
            from .lagrange import derive as lagrange

            dyn = lagrange(robot)
        elif method == "lagrange":  # the same method on named intermediates: seconds, not minutes
            from .lagrange_dag import derive as lagrange_dag

            dyn = lagrange_dag(robot)
        else:
            from .newton_euler import derive as newton_euler

            inertias = body = None
            if regroup:
                from .regressor import base_parameters, regrouped_base_body, regrouped_inertias

                base = base_parameters(robot)
                inertias = regrouped_inertias(robot, base)
                if robot.base_joint is not None:  # the base body takes what the links on it cannot move
                    body = regrouped_base_body(robot, base)
            dyn = newton_euler(robot, inertias, progress=progress, christoffel=not regroup, body=body)
            dyn.stats["regrouped"] = regroup
        dyn.stats["derive_seconds"] = time.perf_counter() - start
        return dyn

    # keyed without the task frames and contact set: every contact set of a robot shares this derivation
    entry = key(robot.dynamics_fingerprint(), method, __version__, code_fingerprint(), f"regroup={regroup}")
    kind = f"derive-{method}" + ("-regrouped" if regroup else "")
    dyn, hit = cached(kind, entry, build, use_cache=cache)
    dyn = dataclasses.replace(dyn, robot=robot)  # the caller's name and poses
    dyn.stats["from_cache"] = hit
    return dyn
