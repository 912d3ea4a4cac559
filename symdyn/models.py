"""The shipped arms under their documented name, `symdyn.models`: `load`
and `NAMES` of `symdyn.model.arms`, where the arms and their data live."""

from .model.arms import NAMES, load

__all__ = ["NAMES", "load"]
