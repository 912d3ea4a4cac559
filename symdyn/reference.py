"""The numeric reference under its documented name, `symdyn.reference`: the
public functions of `symdyn.numeric.reference`, where the recursion lives."""

from .numeric.reference import *  # noqa: F403
from .numeric.reference import __all__  # noqa: F401
