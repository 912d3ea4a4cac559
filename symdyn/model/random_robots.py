"""Random trees and floating-base robots in Python, for property tests against Pinocchio.

`random_tree_robot(seed)` takes the links of a random general arm
(`random_arm`: random origins, axes, full inertias, rotors) and hangs each
on a random earlier link or on the base, so chains, branches at the base
and branches of branches all occur; `base_joint` puts the tree on a free or
planar base carrying a random body.
"""

from __future__ import annotations

import dataclasses
import random

from .random_arms import ArmOptions, _inertia, random_arm
from .robot import Link, Robot

__all__ = ["random_tree_robot"]

_LINKS = ArmOptions(n_min=2, n_max=8, massless=0.0, point_mass=0.1, motor=0.5, symbolic=0.0, general=1.0)


def _depth_first(parents: list[int]) -> list[int]:
    """The links in depth-first order, children in index order (as a URDF parser meets them)."""
    order: list[int] = []

    def visit(i: int) -> None:
        for child in (k for k, p in enumerate(parents) if p == i):
            order.append(child)
            visit(child)

    visit(-1)
    return order


def random_tree_robot(seed: int, *, n: int | None = None, base_joint: str | None = None) -> Robot:
    """A random numeric tree of n links (default 2…8) in the general convention, its
    parents drawn uniformly among the earlier links and the base, on `base_joint`.

    Raises:
        ValueError: a base_joint that is not None, "free" or "planar" (the `Robot`'s).
    """
    rng = random.Random(seed)
    arm = random_arm(seed, _LINKS, n=n)
    drawn = [rng.randrange(-1, i) for i in range(arm.n)]
    order = _depth_first(drawn)  # Pinocchio's order (its CRBA reads each subtree as one block)
    new = {old: k for k, old in enumerate(order)}
    links = tuple(dataclasses.replace(arm.links[old], parent=new.get(drawn[old], -1)) for old in order)
    body = None
    if base_joint is not None:
        m = rng.uniform(0.5, 5.0)
        body = Link(m=m, r=tuple(rng.uniform(-0.2, 0.2) for _ in range(3)), I=_inertia(rng, m))
    return dataclasses.replace(arm, name=f"tree{seed}", links=links, poses={}, base_joint=base_joint, base_body=body)
