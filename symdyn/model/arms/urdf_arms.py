"""The arms people use today, read from the mesh-free URDFs in `data/`.

Each URDF's header comment names where its numbers come from:
- `panda`: Franka Emika Panda (7 joints), franka_ros via example-robot-data
  6.0.0; link inertias of Gaz et al., RA-L 2019; the hand is part of link 7,
  the fingers are left out.
- `iiwa14`: KUKA LBR iiwa 14 R820 (7 joints), Drake's iiwa14 model.
- `ur5`: Universal Robots UR5 (6 joints), ROS-Industrial's ur_description via
  example-robot-data 6.0.0; the chain ends at the flange frame `tool0`.
Joint damping becomes viscous friction B (gear ratio 1); poses: `qz` (zero)
and `qr`, a ready pose inside the limits.
"""

from __future__ import annotations

import dataclasses
from importlib import resources

from ..robot import Robot
from ..urdf import from_urdf

#: name → (URDF file, tip link, ready pose)
ARMS = {
    "panda": ("panda.urdf", None, (0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398)),
    "iiwa14": ("iiwa14.urdf", None, (0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0)),
    "ur5": ("ur5.urdf", "tool0", (0.0, -1.570796, 1.570796, -1.570796, -1.570796, 0.0)),
}


def build(name: str, symbolic: bool = False) -> Robot:
    """The shipped URDF arm `name` (numeric only: its data are numbers)."""
    if symbolic:
        raise ValueError(f"the {name} arm is numeric (read from its URDF); it has no symbolic variant")
    file, tip, ready = ARMS[name]
    path = resources.files(__package__).joinpath("data", file)
    robot = from_urdf(path.read_text(), tip_link=tip, name=name)
    return dataclasses.replace(
        robot,
        poses={"qz": (0.0,) * robot.n, "qr": ready},
        source=f"URDF symdyn/model/arms/data/{file} (its header names the source)",
    )
