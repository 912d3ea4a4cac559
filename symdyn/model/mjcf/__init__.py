"""MJCF in: `from_mjcf(path, base_body=…, tip_body=…, locked=…, exclude=…, snap=…)` → a `Robot`.

compile (MuJoCo's own parser and compiler, absent mesh files left out where
no inertia depends on them) → reader (the compiled model's bodies, joints and
actuators as links; branches merged by `symdyn.model.urdf.bodies`) → the
robot and its record, `robot.mjcf`.  Needs the optional `mujoco` package
(`pip install 'symdyn[mjcf]'`), imported only when a file is read.
"""

from .compile import MJCFError, MJCFWarning, is_mjcf
from .reader import from_mjcf
from .record import MjcfRecord

__all__ = ["from_mjcf", "is_mjcf", "MJCFError", "MJCFWarning", "MjcfRecord"]
