"""symdyn: symbolic rigid-body dynamics of robot arms, and fast model code.

Flow: model → derive (Lagrange, Newton–Euler) → simplify → program → emit
(NumPy, C, CasADi, array API), every stage checked against `symdyn.reference`.
One sub-package per stage, imports only downhill: model ← derivation ←
codegen ← numeric ← presentation ← apps ← bench ← cli (docs/architecture.md).
Entry points: `models.load`, `derive`, `generate`, `load`.
"""

from __future__ import annotations

from os import PathLike
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

from .model import Link, Robot  # noqa: E402
from .model import robot as _robot_module  # noqa: E402
from .model import snapping as _snapping  # noqa: E402
from . import models  # noqa: E402


def _snap_effect(snapped: Robot, literal: Robot) -> Any:
    """`symdyn.numeric.snap_effect.snap_effect`, imported when a snap's effect is first asked for:
    the model states what its snaps do, the reference (a later stage) measures it."""
    from .numeric.snap_effect import snap_effect

    return snap_effect(snapped, literal)


_snapping.set_effect_measure(_snap_effect)


def _draw(robot: Robot, q: Any = None, *, ax: Any = None, title: str | None = None) -> Any:
    """`symdyn.presentation.picture.plot`, imported when a robot is first drawn (`Robot.plot`)."""
    from .presentation.picture import plot

    return plot(robot, q, ax=ax, title=title)


_robot_module.set_drawing(_draw)

if TYPE_CHECKING:  # the stages below are imported when first used: `import symdyn` stays quick
    from pathlib import Path

    from .codegen.entry import GeneratedModel
    from .derivation.dynamics import Dynamics


def derive(
    robot: Robot, method: str = "newton-euler", *, regroup: bool = False, cache: bool = True, progress: bool = False
) -> Dynamics:
    """Closed-form dynamics of `robot`: M(q), C(q, q̇), G(q), F(q̇) and τ as sympy matrices.

    The two methods are independent derivations of the same dynamics and agree
    exactly: "newton-euler", a customized recursion (Khalil's form) in named
    intermediates, and "lagrange", the energy method on exact trigonometric
    polynomials (named intermediates beyond six joints).  Results are cached on
    disk, keyed by the model, the method, the options and symdyn's own source.

    Args:
        robot: the arm (numeric or symbolic parameters).
        method: "newton-euler" or "lagrange".
        regroup: Newton–Euler on the regrouped base parameters (numeric robots only):
            the same joint torques with about a quarter fewer operations.
        cache: read and write the disk cache.
        progress: report the steps of a long derivation on stderr.

    Returns:
        A `symdyn.derivation.dynamics.Dynamics`: `M`, `C`, `G`, `F`, `tau` (sympy
        matrices in `q`, `qd`, `qdd`), the named intermediates (`definitions`,
        `named`) and `stats`.

    Raises:
        ValueError: an unknown method, something other than a `Robot`, or
            `regroup=True` with Lagrange or a symbolic robot.
    """
    from .derivation.entry import derive as _derive

    return _derive(robot, method, regroup=regroup, cache=cache, progress=progress)


def generate(
    robot: Robot | str, target: str = "all", out_dir: str | PathLike | None = None, *, casadi_c: bool = False
) -> list[Path]:
    """Write the model code of `robot` for `target` into `out_dir`.

    Every target prints the same straight-line program (one joint CSE over all
    outputs), so they compute the same operations.  Files are written
    atomically: a reader sees the old set or the new one, never a mix.

    Args:
        robot: a `Robot`, or a shipped model's name (`symdyn.models.NAMES`).
        target: "numpy", "c", "casadi", "array-api" or "all".
        out_dir: the folder to write; default, for the shipped models in a source
            checkout only, `generated/<name>`.
        casadi_c: also write CasADi's own C code (target "casadi").

    Returns:
        The paths written.

    Raises:
        ValueError: an unknown target or model, an arm code cannot be generated
            for, or no `out_dir` where one is needed (an arm that is not shipped,
            or an installed symdyn, which never writes beside its package).
    """
    from .codegen.entry import generate as _generate

    return _generate(robot, target, out_dir, casadi_c=casadi_c)


def load(name_or_robot: Robot | str, target: str = "c", **options: Any) -> GeneratedModel:
    """The generated functions of a model: tau, M, C, Cqd, G, F, fdyn, Y, tau_derivatives,
    fdyn_derivatives, Minv, following one contract on every target (docs/functions.md).

    A shipped model's name loads its checked-in code (`generated/<name>`); a
    `Robot` loads it too when it is that model, else its code is generated once
    into the cache folder.  The C target is compiled on first load (cached).

    Args:
        name_or_robot: a shipped model's name or a `Robot`.
        target: "c", "numpy", "casadi", "array-api", "jax" or "torch".
        **options: `folder=` (load the files `generate` wrote there), `options=`
            (a `symdyn.codegen.emit.clib.CompileOptions` for C), `compiled=`
            (CasADi: evaluate these functions by compiled code, for Opti and
            nlpsol), `jit=` (JAX: `jax.jit` each function, default True); see
            `symdyn.codegen.entry.load`.

    Returns:
        A `GeneratedModel` with the functions as attributes, and `name`, `n`,
        `target`, `fingerprint`, `folder` and `functions` (name → callable).

    Raises:
        ValueError: an unknown target or model, or an option of another target.
        FileNotFoundError: `folder` lacks the target's files.
        RuntimeError: generated files that are stale or were edited after
            generation (the message gives the command that regenerates them).
    """
    from .codegen.entry import load as _load

    return _load(name_or_robot, target, **options)


__all__ = ["Link", "Robot", "models", "derive", "generate", "load", "__version__"]
