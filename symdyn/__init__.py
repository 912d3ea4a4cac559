"""symdyn: symbolic rigid-body dynamics of robot arms, and fast model code.

Flow: model → derive (Lagrange, Newton–Euler) → simplify → program → emit
(NumPy, C, CasADi), every stage checked against `symdyn.reference`.
"""

__version__ = "0.1.0"

from .model import Link, Robot  # noqa: E402
from . import models  # noqa: E402

__all__ = ["Link", "Robot", "models", "__version__"]
