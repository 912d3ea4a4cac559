"""The model stage: `Link`, `Robot` and the conventions — standard and modified DH,
and general (URDF-like) joints (`robot`, `placement`); URDF input and output (`urdf`,
also `Robot.from_urdf` and `robot.to_urdf`); MJCF input (`mjcf`, also `Robot.from_mjcf`); the shipped arms with their sources (`arms`, also `symdyn.models`)."""

from .placement import placement
from .robot import CONVENTIONS, IDENTITY, JOINT_TYPES, Link, Robot, exact_cos_sin, rotx, roty, rotz, transl
from .mjcf import MJCFError, MJCFWarning, from_mjcf  # noqa: F401 (the errors: symdyn.model.mjcf's names)
from .mjcf.state import from_mujoco_state, to_mujoco_state
from .urdf import URDFError, URDFWarning, from_urdf, to_urdf
from .urdf.xacro import expand_xacro

#: `Robot.from_urdf(path_or_xml, *, base_link=…, tip_link=…, locked=…, exclude=…, snap=…)`: defined in `urdf`, which builds on `robot`.
Robot.from_urdf = staticmethod(from_urdf)
#: `Robot.from_mjcf(path, *, base_body=…, tip_body=…, locked=…, exclude=…, snap=…)`: defined in `mjcf` (MuJoCo compiles the file).
Robot.from_mjcf = staticmethod(from_mjcf)
#: `robot.to_urdf(path=None, *, source=…)`: the URDF text with the robot's inertials (`urdf.writer`).
Robot.to_urdf = to_urdf
#: `robot.from_mujoco_state(qpos, qvel[, qacc])` and `robot.to_mujoco_state(q, v[, a])`: MuJoCo's
#: states and symdyn's (Pinocchio's) for a robot read by `from_mjcf` (`mjcf.state`).
Robot.from_mujoco_state = from_mujoco_state
Robot.to_mujoco_state = to_mujoco_state

__all__ = [
    "Link",
    "Robot",
    "CONVENTIONS",
    "JOINT_TYPES",
    "IDENTITY",
    "exact_cos_sin",
    "rotx",
    "roty",
    "rotz",
    "transl",
    "placement",
    "from_urdf",
    "to_urdf",
    "URDFError",
    "URDFWarning",
    "from_mjcf",
    "expand_xacro",
]
