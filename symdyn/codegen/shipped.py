"""The models whose code symdyn ships in generated/, and whether a robot is one of them."""

from __future__ import annotations

import functools

from ..model import Robot, arms

__all__ = ["SHIPPED", "is_shipped"]

SHIPPED = ("twolink", "puma560", "panda", "iiwa14", "ur5")


def is_shipped(robot: Robot) -> bool:
    """Whether robot is one of the models whose code lives in generated/ (name and parameters)."""
    return robot.name in SHIPPED and robot.fingerprint() == _fingerprint(robot.name)


@functools.lru_cache(maxsize=None)
def _fingerprint(name: str) -> str:
    """A shipped arm's fingerprint, read once (reading the Panda's URDF takes 35 ms)."""
    return arms.load(name).fingerprint()
