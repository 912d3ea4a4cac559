"""URDF in: `from_urdf(path_or_xml, base_link=…, tip_link=…, locked=…, exclude=…, snap=…)` → a `Robot`.

xml (the text, its elements and lines) → tree (links, joints, the chain,
each locked joint's value) → bodies (inertials read, checked, merged) →
reader (the robot and its record, `robot.urdf`).
"""

from .reader import from_urdf
from .record import Locked, Snap, UrdfRecord
from .xml import URDFError, URDFWarning

__all__ = ["from_urdf", "URDFError", "URDFWarning", "UrdfRecord", "Locked", "Snap"]
