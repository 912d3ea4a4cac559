"""The model stage: `Link`, `Robot` and the DH conventions (`robot`), and the
shipped arms with their sources (`arms`, also `symdyn.models`)."""

from .robot import CONVENTIONS, IDENTITY, JOINT_TYPES, Link, Robot, exact_cos_sin, rotx, roty, rotz, transl

__all__ = ["Link", "Robot", "CONVENTIONS", "JOINT_TYPES", "IDENTITY", "exact_cos_sin", "rotx", "roty", "rotz",
           "transl"]
