"""Optimal control under its documented name, `symdyn.ocp`: the public names
of `symdyn.apps.ocp`, where the transcriptions live."""

from .apps.ocp import *  # noqa: F403
from .apps.ocp import __all__  # noqa: F401
