"""The numeric dynamics of an arm, from whichever implementation is fastest.

Where it sits: after the flow model → derive → … → emit, between its
products (generated C or NumPy code, `symdyn.codegen`), the plain CasADi
RNEA (`symdyn.numeric.casadi_rnea`) and the numeric reference (`symdyn.reference`)
on one side and their numeric consumers (analyses, forward simulation,
controllers) on the other.  `model(robot, backend)` returns a `Model`: τ, M,
C·q̇, G, F and forward dynamics as NumPy functions batched over leading axes,
with the attribute names of generated code.  Every backend agrees with the
reference to rounding (tested); the choice changes speed only.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..model import Robot, arms
from . import reference as ref

__all__ = ["Model", "BACKENDS", "FALLBACKS", "model", "refriction"]

BACKENDS = ("auto", "reference", "casadi", "c", "numpy")
FALLBACKS = ("casadi", "reference")


@dataclass(frozen=True)
class Model:
    """The dynamics functions of one arm, batched over leading axes, with the
    attribute names of generated code (`symdyn.load(robot, target=...)`):
    tau(q, q̇, q̈), M(q), Cqd(q, q̇) (the vector C·q̇), G(q), F(q̇), fdyn(q, q̇, τ) → q̈.
    τ = M q̈ + C q̇ + G + F (Corke's convention, rotor inertia in M)."""

    n: int
    tau: Callable
    M: Callable
    Cqd: Callable
    G: Callable
    F: Callable
    fdyn: Callable
    source: str


def _reference_model(robot: Robot) -> Model:
    return Model(
        n=robot.n,
        tau=lambda q, qd, qdd: ref.rne(robot, q, qd, qdd),
        M=lambda q: ref.inertia(robot, q),
        Cqd=lambda q, qd: (
            ref.rne(robot, q, qd, np.zeros_like(np.asarray(q, float)), gravity=(0, 0, 0)) - ref.friction(robot, qd)
        ),
        G=lambda q: ref.gravload(robot, q),
        F=lambda qd: ref.friction(robot, qd),
        fdyn=lambda q, qd, tau: ref.accel(robot, q, qd, tau),
        source=f"symdyn.reference ({robot.name})",
    )


def _batched_casadi(fn, n: int) -> Callable:
    """A casadi.Function of n-vectors as a NumPy function batched over leading
    axes (CasADi maps a call with N columns over the columns)."""

    def call(*args):
        arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
        batch = arrays[0].shape[:-1]
        N = int(np.prod(batch, dtype=int))
        out = np.array(fn(*(a.reshape(N, n).T for a in arrays)))
        if out.shape[1] == N:  # a vector per state
            return out.T.reshape(batch + (out.shape[0],))
        rows, cols = out.shape[0], out.shape[1] // N  # a matrix per state
        return out.reshape(rows, N, cols).transpose(1, 0, 2).reshape(batch + (rows, cols))

    return call


def _broadcasting(fn) -> Callable:
    """fn with its array arguments broadcast against each other and made
    contiguous (the generated C target takes equal leading shapes only)."""

    def call(*args):
        arrays = [np.asarray(a, dtype=float) for a in args]
        if any(a.shape != arrays[0].shape for a in arrays):
            arrays = np.broadcast_arrays(*arrays)
        return fn(*(np.ascontiguousarray(a) for a in arrays))

    return call


def _wrap(functions, n: int, source: str) -> Model:
    """A `Model` from an object with attributes tau, M, Cqd, G, F, fdyn: batched
    NumPy callables (generated code) or casadi.Functions."""
    import casadi as ca

    def get(name):
        fn = getattr(functions, name)
        return _batched_casadi(fn, n) if isinstance(fn, ca.Function) else _broadcasting(fn)

    return Model(n=n, source=source, **{k: get(k) for k in ("tau", "M", "Cqd", "G", "F", "fdyn")})


def _shipped_generated(robot: Robot) -> Model | None:
    """Generated C (else NumPy) code for `robot` if it is a shipped model, or
    one with friction removed (`nofriction()`, then `refriction`), and the
    checked-in code exists; None otherwise (nothing is derived here)."""
    try:
        from ..codegen import entry as codegen
    except ImportError:
        return None
    for name in codegen.SHIPPED:
        shipped = arms.load(name)
        variants = (shipped, shipped.nofriction(), shipped.nofriction(all=True))
        if robot.fingerprint() in {v.fingerprint() for v in variants} and (codegen.GENERATED / name).is_dir():
            break
    else:
        return None
    for target in ("c", "numpy"):
        try:
            base = _wrap(codegen.load(name, target), robot.n, f"generated {target} ({name})")
        except (RuntimeError, ValueError, OSError, ImportError) as exc:
            warnings.warn(f"symdyn.numeric.backend: generated {target} code for {name} unavailable: {exc}")
            continue
        return base if robot.fingerprint() == shipped.fingerprint() else refriction(base, robot)
    return None


@functools.lru_cache(maxsize=32)
def model(robot: Robot, backend: str = "auto", *, fallback: str = "casadi") -> Model:
    """The dynamics of `robot` as a `Model` (cached per robot and backend).

    backend "reference": `symdyn.reference` (slow per call, nearly free to
    batch); "casadi": the plain CasADi recursive Newton–Euler
    (`symdyn.numeric.casadi_rnea`, built in 0.4 s for two links, 2 s for the Puma);
    "c" or "numpy": generated code via `symdyn.codegen.entry.load(robot, target)`
    (derived and compiled on first use for a robot that is not shipped);
    "auto": the checked-in generated C (else NumPy) code of a shipped model,
    else `fallback` ("casadi" for many small calls, "reference" for a few
    large batches).  Puma fdyn per call: reference 2.7 ms, CasADi 0.2 ms,
    generated C 5 µs.
    """
    if fallback not in FALLBACKS:
        raise ValueError(f"unknown fallback {fallback!r}: expected one of {', '.join(map(repr, FALLBACKS))}")
    if backend == "reference":
        return _reference_model(robot)
    if backend == "casadi":
        from . import casadi_rnea

        return _wrap(casadi_rnea.functions(robot), robot.n, f"plain CasADi RNEA ({robot.name})")
    if backend == "auto":
        return _shipped_generated(robot) or model(robot, fallback)
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}: expected one of {', '.join(map(repr, BACKENDS))}")
    from ..codegen import entry as codegen

    return _wrap(codegen.load(robot, backend), robot.n, f"generated {backend} ({robot.name})")


def refriction(base: Model, robot: Robot) -> Model:
    """`base`, the model of an arm that differs from `robot` in friction only,
    with `robot`'s friction F(q̇) (`symdyn.reference.friction`): e.g. the
    generated Puma with the Coulomb friction removed, `robot = puma.nofriction()`.
    Forward dynamics through base.fdyn with τ − F + F_base, so M⁻¹(τ − C q̇ − G − F)."""
    F = ref.friction_law(robot)

    def swap(qd, tau):
        return np.asarray(tau, float) - F(qd) + base.F(qd)

    return Model(
        n=base.n,
        tau=lambda q, qd, qdd: base.tau(q, qd, qdd) - base.F(qd) + F(qd),
        M=base.M,
        Cqd=base.Cqd,
        G=base.G,
        F=F,
        fdyn=lambda q, qd, tau: base.fdyn(q, qd, swap(qd, tau)),
        source=f"{base.source}, friction of {robot.name}",
    )
