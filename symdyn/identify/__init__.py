"""Identification: a user's arm's parameters from its measured motion (issue 24).

A pipeline of plain steps (FIGAROH's shape), after the model → derive → program
→ emit flow it consumes: excitation design (`excitation`) → measured or
simulated data (`load_data`, `simulate`) → the exact base regressor
(derivation's regrouping, codegen's batched `Y`) → least squares
(`fit` → `Identification`) → physically consistent standard parameters
(`consistent`) → validation and report (`Identification.write`).
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any, NoReturn

from .data import Data, load_data
from .estimate import Identification, fit
from .simulate import simulate

if TYPE_CHECKING:
    from ..model import Robot

try:  # excitation design lives in its own module (CasADi); re-exported once it is there
    excitation = import_module(f"{__name__}.excitation").excitation
except ModuleNotFoundError as exc:
    if exc.name != f"{__name__}.excitation":
        raise

    def excitation(robot: Robot, **options: Any) -> NoReturn:
        """Excitation design (symdyn.identify.excitation) is not part of this installation yet.

        Raises:
            RuntimeError: always: the excitation module is not installed.
        """
        raise RuntimeError("symdyn.identify.excitation is not available in this installation")


__all__ = ["excitation", "load_data", "Data", "fit", "Identification", "simulate"]
