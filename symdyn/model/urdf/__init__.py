"""URDF in: `from_urdf(path_or_xml, base_link=…, tip_link=…, locked=…, exclude=…, snap=…)` → a `Robot`.

xml (the text, its elements and lines) → tree (links, joints, the chain,
each locked joint's value) → bodies (inertials read, checked, merged) →
reader (the robot and its record, `robot.urdf`); and back out: `to_urdf(robot)`
(writer: the source file with the robot's inertials, or a fresh chain).
"""

from .reader import from_urdf
from .record import Bone, Locked, Repair, Snap, UrdfRecord
from .writer import to_urdf
from .xml import URDFError, URDFWarning

__all__ = ["from_urdf", "to_urdf", "URDFError", "URDFWarning", "UrdfRecord", "Locked", "Snap", "Repair", "Bone"]
