"""symdyn: symbolic rigid-body dynamics of robot arms, and fast model code.

Flow: model → derive (Lagrange, Newton–Euler) → simplify → program → emit
(NumPy, C, CasADi), every stage checked against `symdyn.reference`.  One
sub-package per stage, imports only downhill: model ← derivation ← codegen ←
numeric ← apps ← bench ← cli (docs/architecture.md).
Entry points: `models.load`, `derive`, `generate`, `load`.
"""

__version__ = "0.1.0"

from .model import Link, Robot  # noqa: E402
from . import models  # noqa: E402


def derive(robot, method="newton-euler", **options):
    """Closed-form dynamics of `robot`: see `symdyn.derivation.entry.derive`."""
    from .derivation.entry import derive as _derive

    return _derive(robot, method, **options)


def generate(robot, target="all", out_dir=None, **options):
    """Write model code for `robot`: see `symdyn.codegen.entry.generate`."""
    from .codegen.entry import generate as _generate

    return _generate(robot, target, out_dir, **options)


def load(name_or_robot, target="c", **options):
    """Generated model functions (tau, M, C, Cqd, G, F, fdyn, Y): see `symdyn.codegen.entry.load`."""
    from .codegen.entry import load as _load

    return _load(name_or_robot, target, **options)


__all__ = ["Link", "Robot", "models", "derive", "generate", "load", "__version__"]
