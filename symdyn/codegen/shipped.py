"""The models whose code symdyn ships in generated/, and whether a robot is one of them."""

from __future__ import annotations

from ..model import Robot, arms

__all__ = ["SHIPPED", "is_shipped"]

SHIPPED = ("twolink", "puma560", "panda", "iiwa14", "ur5")


def is_shipped(robot: Robot) -> bool:
    """Whether robot is one of the models whose code lives in generated/ (name and parameters)."""
    return robot.name in SHIPPED and robot.fingerprint() == arms.load(robot.name).fingerprint()
