"""Estimation: base parameters by least squares on the exact base regressor, and their report.

The estimate step of identify (excitation → data → base regressor →
**estimate** → consistent → validate).  The generated regressor Y (C target,
batched, in chunks into one buffer) gives the columns of the exact base
parameters (`parameters.base_map`): τ = Y_b(q, q̇, q̈)·β.  One pass over the
samples accumulates each joint's Gram matrix of [Y_b,j  τ_j] (large BLAS
products, never the whole regressor in memory); ordinary least squares,
each joint's residual variance σ_j² and the weighted least squares of
Gautier & Khalil (rows of joint j divided by σ_j, each joint's noise
estimated from its own equations) follow from those alone,
and a second pass computes the residuals exactly and takes one step of
iterative refinement, which wins back the accuracy the normal equations
lose (noise-free data give β to rounding):

    β̂ = argmin Σ_j ‖Y_b,j β − τ_j‖² / σ_j²,   cov β̂ = s² (Y_wᵀ Y_w)⁻¹,
    s² = Σ_j ‖Y_b,j β̂ − τ_j‖²/σ_j² / (nN − b).

`fit` returns an `Identification`: the estimates with σ and relative σ %,
the condition number, the residual RMS per joint, a `Robot` that reproduces
the estimate (physically consistent through `consistent.physical`, or the
prior moved least), `predict`, `validate` and `write` (summary, JSON,
URDF, figures).
"""

from __future__ import annotations

import functools
import json
import os
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..model import Robot
from .data import Data, parallel_decimate
from .parameters import BaseMap, base_map, robot_names, standard_vector, with_standard

__all__ = ["fit", "Identification", "BaseEstimate", "Validation", "regressor_rows", "METHODS"]

METHODS = ("wls", "ols")
#: States per call of the generated Y (its buffer stays in cache-friendly size; ~2 MB for 7 joints).
CHUNK = 2048
#: A base regressor up to this size is kept between the two passes (10⁴ Panda samples: 39 MB), a larger
#: one evaluated again.
KEEP_BYTES = 1 << 27
#: `fit`'s rest_speed where q̇ was differentiated from q (rad/s, m/s); with q̇ given, every equation is kept.
REST_SPEED = 0.02
#: The data do not separate the base parameters where the smallest eigenvalue of the Gram matrix with
#: unit columns falls below this fraction of the largest (a condition number with unit columns above
#: ~3·10⁶, where the Gram matrix's rounding, ~1e-16 of the largest, would decide the estimate).
RANK_TOL = 1e-13


@dataclass(frozen=True)
class BaseEstimate:
    """Base parameters: names (each its pivot standard parameter, e.g. ZZ1), values, standard
    deviations std, relative σ in % (100·std/|value|), their covariance, and the regrouping
    each stands for (`expressions`, in the standard parameters)."""

    names: tuple
    values: np.ndarray
    std: np.ndarray
    relative: np.ndarray
    covariance: np.ndarray
    expressions: tuple

    def __len__(self) -> int:
        return len(self.names)

    def table(self) -> str:
        lines = [f"{'parameter':>10} {'value':>14} {'σ':>11} {'σ %':>9}  stands for"]
        for k, name in enumerate(self.names):
            lines.append(
                f"{name:>10} {self.values[k]:>14.6g} {self.std[k]:>11.3g} {self.relative[k]:>9.3g}  "
                f"{self.expressions[k]}"
            )
        return "\n".join(lines)


@dataclass(frozen=True)
class Validation:
    """Predicted against measured torque on one trajectory: rms (n,) of the error per joint,
    relative (n,) = rms error / rms measured torque, and the time series."""

    source: str
    t: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    rms: np.ndarray
    relative: np.ndarray

    def lines(self) -> list[str]:
        return [
            f"validation on {self.source} ({len(self.t)} samples):",
            "  rms error per joint: " + ", ".join(f"{x:.4g}" for x in self.rms),
            "  relative error per joint (rms error / rms torque): "
            + ", ".join(f"{100 * x:.2f} %" for x in self.relative),
        ]


class _Regressor:
    """The base regressor Y_b(q, q̇, q̈) of a robot's geometry, evaluated in chunks by generated code."""

    def __init__(self, robot: Robot, bmap: BaseMap, target: str):
        from ..codegen.entry import load

        source = _geometry(robot)
        entry = (source if isinstance(source, str) else source.fingerprint(), target)
        if entry not in _MODELS:  # loaded once per process (a NumPy module compiles its source on import)
            _MODELS[entry] = load(source, target)
        self.model = _MODELS[entry]
        self.target = target
        self.columns = np.asarray(bmap.columns)
        self.n, self.p = robot.nv, len(bmap.P[0])  # rows: τ's (a floating base's first); every standard column

    def chunks(self, q, qd, qdd, chunk: int = CHUNK):
        """(start, Y_b (m, nv, b)) for consecutive chunks of the states (N, nq), (N, nv), (N, nv)."""
        N = len(q)
        q, qd, qdd = (np.ascontiguousarray(x, dtype=float) for x in (q, qd, qdd))
        buffer = np.empty((min(chunk, N), self.n, self.p)) if self.target == "c" else None
        for s in range(0, N, chunk):
            e = min(s + chunk, N)
            if buffer is not None:
                Y = self.model.Y(q[s:e], qd[s:e], qdd[s:e], out=buffer[: e - s])
            else:
                Y = np.asarray(self.model.Y(q[s:e], qd[s:e], qdd[s:e]), dtype=float)
            yield s, np.take(Y, self.columns, axis=2)

    def full(self, q, qd, qdd) -> np.ndarray:
        out = np.empty((len(q), self.n, len(self.columns)))
        for s, Yb in self.chunks(q, qd, qdd):
            out[s : s + len(Yb)] = Yb
        return out

    def predict(self, beta, q, qd, qdd) -> np.ndarray:
        out = np.empty((len(q), self.n))
        for s, Yb in self.chunks(q, qd, qdd):
            out[s : s + len(Yb)] = Yb @ beta
        return out


_MODELS: dict = {}


def _geometry(robot: Robot):
    """The model whose generated code serves Y.  Y depends on the geometry (and gravity) alone, not on
    masses, inertias or motors, so a robot with a shipped model's geometry — the model itself, or one
    with a payload or other parameters — is served by that model's checked-in code by name (no
    compilation); any other robot by its own code, generated once into the cache."""
    from ..codegen.entry import SHIPPED
    from ..model import arms

    key = _geometry_key(robot)
    for name in SHIPPED:
        if name not in _GEOMETRY:
            _GEOMETRY[name] = _geometry_key(arms.load(name))
        if _GEOMETRY[name] == key:
            return name
    return robot


_GEOMETRY: dict = {}


def _geometry_key(robot: Robot) -> str:
    import dataclasses

    bare = tuple(
        dataclasses.replace(
            link, m=0, r=(0, 0, 0), I=((0, 0, 0),) * 3, Jm=0, B=0, Tc=(0, 0), G=1, qlim=None, physical=True
        )
        for link in robot.links
    )
    return dataclasses.replace(
        robot, links=bare, tool=((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1)), urdf=None
    ).fingerprint()


def regressor_rows(robot: Robot, q, qd, qdd, *, target: str = "c") -> np.ndarray:
    """The base regressor Y_b (N, n, b) of `robot` at the states (N, n) (`base_map(robot).names`)."""
    return _Regressor(robot, base_map(robot), target).full(*(np.atleast_2d(x) for x in (q, qd, qdd)))


def _gram(blocks, n: int, b: int) -> np.ndarray:
    """Per joint, the Gram matrix (n, b+1, b+1) of the rows [Y_b,j  τ_j] of all blocks (Y_b (m, n, b),
    τ (m, n)); each joint's rows Y_b[:, j] are a strided matrix BLAS reads in place."""
    G = np.zeros((n, b + 1, b + 1))
    for Y, tau in blocks:
        for j in range(n):
            Yj, tj = Y[:, j, :], tau[:, j]
            G[j, :b, :b] += Yj.T @ Yj
            G[j, :b, b] += Yj.T @ tj
            G[j, b, b] += tj @ tj
    G[:, b, :b] = G[:, :b, b]
    return G


def _solve(G: np.ndarray, w: np.ndarray, names):
    """β minimising Σ_j ‖Y_b,j β − τ_j‖² / w_j² from the Gram matrices, (Σ_j Y_b,jᵀY_b,j / w_j²)⁻¹, and
    the singular values of the weighted regressor with unit columns; a ValueError naming the base
    parameters the data do not excite or do not separate."""
    b = G.shape[1] - 1
    Gw = np.tensordot(1 / w**2, G, axes=1)
    A, g = Gw[:b, :b], Gw[:b, b]
    scale = np.sqrt(np.diag(A))
    if np.any(scale == 0):
        dead = [names[k] for k in np.flatnonzero(scale == 0)]
        raise ValueError(
            f"the data do not excite the base parameter(s) {', '.join(dead)}: their regressor "
            "columns are zero along the whole motion (does every joint move, both ways?)"
        )
    lam, V = np.linalg.eigh(A / np.outer(scale, scale))
    if lam[0] < RANK_TOL * lam[-1]:
        v = V[:, 0]
        worst = [names[k] for k in np.argsort(-np.abs(v))[:4] if abs(v[k]) > 0.1]
        raise ValueError(
            f"the data do not separate the base parameters {', '.join(worst)} (condition number "
            f"{np.sqrt(lam[-1] / max(lam[0], 1e-300)):.3g} with unit columns): a richer motion is "
            "needed (does every joint move, both ways, with varied speed?)"
        )
    inv = (V / lam) @ V.T / np.outer(scale, scale)
    return inv @ g, inv, np.sqrt(np.maximum(lam[::-1], 0))


def _rss(G: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """‖Y_b,j β − τ_j‖² per joint from the Gram matrices (≥ 0; cancellation leaves ~1e-16 of ‖τ_j‖²)."""
    x = np.append(beta, -1.0)
    return np.maximum(np.einsum("i,jik,k->j", x, G, x), 0.0)


def _residuals(blocks, beta: np.ndarray, n: int):
    """One pass over the samples at β: per joint the residual sum of squares ‖r_j‖² and Y_b,jᵀ r_j,
    r_j = τ_j − Y_b,j β computed exactly (not from the Gram matrices, which lose the square of the
    condition number): what one step of iterative refinement and each joint's noise need."""
    b = len(beta)
    rss = np.zeros(n)
    h = np.zeros((n, b))
    for Y, tau in blocks:
        r = tau - Y @ beta
        rss += np.sum(r * r, axis=0)
        for j in range(n):
            h[j] += Y[:, j, :].T @ r[:, j]
    return rss, h


def _joint_noise(G: np.ndarray, N) -> np.ndarray:
    """Each joint's noise σ_j from its own equations alone (Gautier & Khalil): the least squares of
    τ_j = Y_b,j β over the columns joint j sees, σ_j² = ‖τ_j − Y_b,j β̂_j‖² / (N − rank Y_b,j).
    (The joint's residual under the joint OLS estimate would carry the other joints' noise through
    β̂: a quiet wrist joint then looks four times noisier than it is and its parameters' σ inflate.)"""
    n, b = G.shape[0], G.shape[1] - 1
    sigma = np.zeros(n)
    for j in range(n):
        A, g = G[j, :b, :b], G[j, :b, b]
        scale = np.sqrt(np.diag(A))
        seen = scale > 0
        if not seen.any():
            sigma[j] = np.sqrt(G[j, b, b] / max(N[j], 1))
            continue
        As = A[np.ix_(seen, seen)] / np.outer(scale[seen], scale[seen])
        lam, V = np.linalg.eigh(As)
        keep = lam > 1e-12 * lam[-1]
        x = V[:, keep] @ ((V[:, keep].T @ (g[seen] / scale[seen])) / lam[keep])
        beta = np.zeros(b)
        beta[seen] = x / scale[seen]
        rss = _rss(G[j : j + 1], beta)[0]
        sigma[j] = np.sqrt(rss / max(N[j] - int(keep.sum()), 1))
    return sigma


def _step(G: np.ndarray, rss: np.ndarray, h: np.ndarray, delta: np.ndarray):
    """Moving β by δ: each joint's ‖r_j‖² and Y_b,jᵀ r_j at β + δ (r_j − Y_b,j δ)."""
    Gb = G[:, :-1, :-1]
    Gd = Gb @ delta
    return rss - 2 * h @ delta + Gd @ delta, h - Gd


@functools.lru_cache(maxsize=1)
def _openblas() -> tuple:
    """(get, set) thread-count functions of every OpenBLAS this process has loaded (Linux)."""
    found = []
    try:
        import ctypes

        with open("/proc/self/maps") as maps:
            paths = sorted(
                {line.split()[-1] for line in maps if "openblas" in line.lower() and line.split()[-1].startswith("/")}
            )
        for path in paths:
            lib = ctypes.CDLL(path)
            for prefix, suffix in (
                ("scipy_openblas", "64_"),
                ("scipy_openblas", ""),
                ("openblas", "64_"),
                ("openblas", ""),
            ):
                get = getattr(lib, f"{prefix}_get_num_threads{suffix}", None)
                put = getattr(lib, f"{prefix}_set_num_threads{suffix}", None)
                if get is not None and put is not None:
                    found.append((get, put))
                    break
    except OSError:
        pass
    return tuple(found)


@contextmanager
def _blas_threads(count: int | None):
    """NumPy's OpenBLAS limited to `count` threads inside the block, as threadpoolctl does (Linux;
    another BLAS or system, or count None, leaves everything as it is)."""
    restore = []
    if count is not None:
        for get, put in _openblas():
            restore.append((put, get()))
            put(int(count))
    try:
        yield
    finally:
        for put, old in restore:
            put(old)


def fit(
    robot: Robot,
    data: Data,
    method: str = "wls",
    consistent: bool = True,
    *,
    target: str = "c",
    blas_threads: int | None = 1,
    consistent_options: dict | None = None,
    rest_speed: float | None = None,
) -> "Identification":
    """Identify the base parameters of `robot`'s geometry from `data` (a `Data`, or a CSV/NPZ file
    read by `load_data` with its defaults; see the module docstring).  A floating base: its body's
    parameters with the links', from its rows of τ (the force and moment on it) and the joints'.

    method: "wls" (weighted by each joint's residual variance, Gautier & Khalil) or "ols".
    consistent: also find physically consistent standard parameters (`consistent.physical`,
    regularised towards `robot`'s values); False: `.robot` is `robot` moved least to reproduce
    the estimate.  target: the generated code that evaluates Y ("c", "numpy", "casadi").
    blas_threads: NumPy's BLAS threads for the least squares (default 1: the Gram products are
    many mid-sized ones, and on a busy machine OpenBLAS's waiting threads cost 5-10× the time they
    save — 10⁵ Panda samples took 7-20 s with two threads on two shared cores, 1.3 s with one;
    None leaves BLAS as it is).  The generated C regressor runs on its own threads regardless.
    rest_speed: on an arm with Coulomb friction, joint j's equation at a sample where |q̇_j| is below
    this (rad/s or m/s) is left out: at rest Coulomb friction is anything within ±Tc, not the model's
    sign(q̇)·Tc, and a q̇ differentiated from q gives that sign at random there (0: keep every equation;
    default: REST_SPEED where `load_data` differentiated q, else 0 — leaving out the rest samples of
    exact model data would lose what separates the Coulomb offset FO from a constant torque).
    Measured: the Puma, q-only data with a 0.5 s hold, 17-bit encoder: joint 1's residual 4.5 → 0.17 N·m.

    Returns:
        The `Identification`.

    Raises:
        ValueError: an unknown method; something other than a `Robot`, or a symbolic
            one; data that is neither `Data` nor a file (a file: `load_data`'s
            errors), or with another joint count or base joint than the robot; a negative
            rest_speed; an unknown target; fewer equations than base parameters; a
            motion that does not excite or does not separate the base parameters.
        RuntimeError: consistent=True where this installation lacks
            `symdyn.identify.consistent`; target "c" without a C compiler.

    Warns:
        RuntimeWarning: the physically consistent step fails; the least-squares
            estimate stands (`consistent_error` says why).
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}: expected one of {', '.join(METHODS)}")
    if not isinstance(robot, Robot):
        raise ValueError(f"expected a symdyn Robot, got {type(robot).__name__}")
    robot.require_numeric("identification")
    if isinstance(data, (str, Path)):
        from .data import load_data

        data = load_data(data, joints=robot)
    if not isinstance(data, Data):
        raise ValueError(f"expected identify.Data (load_data, simulate) or a data file, got {type(data).__name__}")
    data.check_joints(robot)
    physical = None
    if consistent:
        physical = _consistent_module()
    if rest_speed is None:
        rest_speed = REST_SPEED if data.differentiated else 0.0
    if not rest_speed >= 0:
        raise ValueError(f"rest_speed must be a speed >= 0, got {rest_speed!r}")
    with _blas_threads(blas_threads):
        result = _fit(robot, data, method, target, rest_speed)
    if physical is not None:
        options = dict(consistent_options or {})
        started = time.perf_counter()
        # residuals at rounding level (exact data): the covariance is rounding noise and weighs nothing
        scale = max(np.sqrt(np.mean(data.tau**2)), 1e-300)
        cov = None if np.all(result.rms <= 1e-9 * scale) else result.base.covariance
        try:
            result.consistent = physical.physical(
                robot, result.base.names, result.base.values, cov, prior=robot, base=result.map.exact, **options
            )
        except Exception as exc:  # noqa: BLE001 (a solver's failure must not lose the estimate)
            import warnings

            result.consistent_error = f"{type(exc).__name__}: {exc}"
            warnings.warn(
                f"no physically consistent parameters ({result.consistent_error}); the least-squares estimate stands",
                RuntimeWarning,
                stacklevel=2,
            )
        result.consistent_seconds = time.perf_counter() - started
    return result


def _moving(robot: Robot, data: Data, rest_speed: float) -> np.ndarray | None:
    """(N, n) True where joint j's equation is kept: everywhere, unless the arm has Coulomb friction
    and the joint is slower than rest_speed there (then None: keep all)."""
    if rest_speed == 0 or not any(float(t) != 0 for link in robot.links for t in link.Tc):
        return None
    moving = np.abs(data.qd) >= rest_speed
    moving[:, : robot.nv - robot.n] = True  # a floating base's rows have no joint friction
    return moving


def _fit(robot: Robot, data: Data, method: str, target: str, rest_speed: float = 0.0) -> "Identification":
    start = time.perf_counter()
    bmap = base_map(robot)
    reg = _Regressor(robot, bmap, target)
    n, b = robot.nv, len(bmap.names)  # n rows per sample: τ's, a floating base's first
    keep = _moving(robot, data, rest_speed)
    if data.decimate > 1:
        Yb, tau, _ = parallel_decimate(reg.full(data.q, data.qd, data.qdd), data.tau, data.decimate, data.t)
        keep = keep[:: data.decimate][: len(tau)] if keep is not None else None  # the decimated samples' speeds
    elif data.N * n * b * 8 <= KEEP_BYTES:  # evaluated once, read by both passes
        Yb, tau = reg.full(data.q, data.qd, data.qdd), data.tau
    else:  # evaluated again for the second pass, never all in memory
        Yb, tau = None, data.tau
    if keep is not None:  # a joint's equations at rest become zero rows, which no sum sees
        tau = np.where(keep, tau, 0.0)
        if Yb is not None:
            Yb[~keep] = 0.0
    if Yb is not None:

        def blocks():
            return ((Yb[s : s + CHUNK], tau[s : s + CHUNK]) for s in range(0, len(tau), CHUNK))
    else:

        def blocks():
            for s, Y in reg.chunks(data.q, data.qd, data.qdd):
                if keep is not None:
                    Y[~keep[s : s + len(Y)]] = 0.0
                yield Y, tau[s : s + len(Y)]

    N = len(tau)
    counts = keep.sum(axis=0) if keep is not None else np.full(n, N)
    if counts.sum() <= b:
        raise ValueError(
            f"{N} samples of {n} joints give {counts.sum()} equations (joints at rest left out) "
            f"for {b} base parameters; record a longer motion"
        )
    G = _gram(blocks(), n, b)
    names = bmap.names
    ones = np.ones(n)
    beta, inv, S = _solve(G, ones, names)
    rss, h = _residuals(blocks(), beta, n)
    delta = inv @ h.sum(axis=0)  # refinement: ordinary least squares to rounding
    beta = beta + delta
    rss, h = _step(G, rss, h, delta)
    rss = np.maximum(rss, 0.0)
    sigma = _joint_noise(G, counts)
    if method == "wls":
        # the noise of joint j, floored where the data are exact (the weights do not matter there)
        floor = 1e-8 * max(np.sqrt(np.mean(tau**2, axis=0)).max(), 1e-300)
        w = np.maximum(sigma, floor)
        _, inv, S = _solve(G, w, names)
        delta = inv @ (h / (w**2)[:, None]).sum(axis=0)
        beta = beta + delta
        rss, h = _step(G, rss, h, delta)
        rss = np.maximum(rss, 0.0)
    else:
        w = ones
    s2 = float(np.sum(rss / w**2) / max(counts.sum() - b, 1))
    cov = s2 * inv
    std = np.sqrt(np.diag(cov))
    with np.errstate(divide="ignore", invalid="ignore"):
        relative = np.where(beta != 0, 100 * std / np.abs(beta), np.inf)
    ev = np.linalg.eigvalsh(np.tensordot(1 / w**2, G, axes=1)[:b, :b])
    estimate = BaseEstimate(
        names=names, values=beta, std=std, relative=relative, covariance=cov, expressions=bmap.expressions
    )
    seconds = time.perf_counter() - start
    result = Identification(
        prior=robot,
        base=estimate,
        condition=float(np.sqrt(ev[-1] / max(ev[0], 1e-300))),
        scaled_condition=float(S[0] / S[-1]),
        rms=np.sqrt(rss / np.maximum(counts, 1)),
        sigma=w if method == "wls" else sigma,
        method=method,
        samples=N,
        data=data,
        seconds=seconds,
        target=target,
        map=bmap,
    )
    return result


def _consistent_module():
    try:
        from . import consistent
    except ModuleNotFoundError as exc:
        if exc.name != f"{__package__}.consistent":
            raise
        raise RuntimeError(
            "consistent=True needs symdyn.identify.consistent (physically consistent "
            "parameters), which this installation lacks; fit(..., consistent=False) gives the "
            "least-squares estimate alone"
        ) from None
    return consistent


@dataclass
class Identification:
    """The result of `fit`: `.base` (names, values, std, relative σ %), `.condition` (of the
    weighted base regressor; `.scaled_condition` with its columns scaled to unit length), `.rms`
    (n,) residual per joint, `.sigma` (n,) each joint's noise level (the WLS weights are 1/σ_j),
    `.robot`, `.predict`, `.validate`, `.write`."""

    prior: Robot
    base: BaseEstimate
    condition: float
    scaled_condition: float
    rms: np.ndarray
    sigma: np.ndarray
    method: str
    samples: int
    data: Data
    seconds: float
    target: str
    map: BaseMap
    consistent: object = None
    consistent_seconds: float = 0.0
    consistent_error: str | None = None
    _regressor: object = field(default=None, repr=False)

    # ---- the model that reproduces the estimate
    @property
    def robot(self) -> Robot:
        """A Robot whose joint-space dynamics reproduce the estimate: the physically consistent one
        (`consistent.physical`) when fit with consistent=True, else the prior's standard parameters
        moved least (minimum norm) so that P·π = β̂ — a ValueError where that is no physical body.

        Raises:
            ValueError: the consistent step failed (`consistent_error`), or (fit with
                consistent=False) the moved parameters are no physical robot.
        """
        if self.consistent is not None:
            return self.consistent.robot
        if self.consistent_error is not None:
            raise ValueError(
                f"the physically consistent step failed ({self.consistent_error}); the least-squares "
                "estimate (.base) stands"
            )
        pi = self.standard()
        try:
            return with_standard(self.prior, pi, name=f"{self.prior.name}_identified")
        except ValueError as exc:
            raise ValueError(
                f"the least-squares estimate is no physical robot ({exc}); fit with consistent=True "
                "for physically consistent parameters"
            ) from None

    def standard(self) -> np.ndarray:
        """Standard parameters π (14n,) reproducing β̂: the consistent ones, else the prior's
        moved by the minimum-norm correction π₀ + P⁺(β̂ − P·π₀)."""
        if self.consistent is not None:
            return np.array([self.consistent.standard[k] for k in robot_names(self.prior)])
        pi0 = standard_vector(self.prior)
        P = self.map.P
        return pi0 + np.linalg.lstsq(P, self.base.values - P @ pi0, rcond=None)[0]

    # ---- predictions
    def _reg(self) -> _Regressor:
        if self._regressor is None:
            self._regressor = _Regressor(self.prior, self.map, self.target)
        return self._regressor

    def predict(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> np.ndarray:
        """Joint torques Y_b(q, q̇, q̈)·β̂, (N, n) for states (N, n) ((n,) for one state).

        Raises:
            ValueError: a state that is not finite or not of shape (N, n).
        """
        single = np.ndim(q) == 1
        q, qd, qdd = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, qd, qdd))
        for name, x, size in (("q", q, self.prior.nq), ("qd", qd, self.prior.nv), ("qdd", qdd, self.prior.nv)):
            if x.shape[-1] != size or not np.all(np.isfinite(x)):
                raise ValueError(f"predict(): {name} must be finite with shape (N, {size}), got {x.shape}")
        out = self._reg().predict(self.base.values, q, qd, qdd)
        return out[0] if single else out

    def validate(self, data: Data) -> Validation:
        """Predicted against measured torque on (held-out) data.

        Raises:
            ValueError: data with another joint count than the model's, or states that are not finite.
        """
        data.check_joints(self.prior)
        predicted = self.predict(data.q, data.qd, data.qdd)
        rms = np.sqrt(np.mean((predicted - data.tau) ** 2, axis=0))
        scale = np.sqrt(np.mean(data.tau**2, axis=0))
        with np.errstate(divide="ignore", invalid="ignore"):
            relative = np.where(scale > 0, rms / scale, np.inf)
        return Validation(
            source=data.source, t=data.t, measured=data.tau, predicted=predicted, rms=rms, relative=relative
        )

    # ---- report
    def summary(self, validation: Validation | None = None) -> str:
        d = self.data
        floating = self.prior.base_joint
        on = f" on a {floating} base" if floating else ""
        rows = (
            f"{self.prior.nv} equations (the base's {self.prior.nv - self.prior.n} first)"
            if floating
            else f"{self.prior.n} joints"
        )
        lines = [
            f"identification of {self.prior.name} ({self.prior.n} joints{on}) by {self.method.upper()}",
            *(f"  {note}" for note in d.notes),
            f"{self.samples} samples × {rows}, {len(self.base)} base parameters, least squares in {self.seconds:.3f} s",
            f"condition number of the {'weighted ' if self.method == 'wls' else ''}base regressor: "
            f"{self.condition:.4g} ({self.scaled_condition:.4g} with unit columns)",
            "residual rms per joint: " + ", ".join(f"{x:.4g}" for x in self.rms),
            ("noise σ per joint (WLS weights 1/σ): " if self.method == "wls" else "noise σ per joint: ")
            + ", ".join(f"{x:.4g}" for x in self.sigma),
            "",
            "base parameters (σ from the estimate's covariance):",
            self.base.table(),
        ]
        if self.consistent is not None:
            c = self.consistent
            lines += [
                "",
                f"physically consistent standard parameters ({getattr(c, 'method', '?')}, "
                f"{self.consistent_seconds:.2f} s): the base parameters moved by {c.moved:.3g} (relative)"
                + (f", {c.sigmas:.3g} σ" if getattr(c, "sigmas", None) is not None else ""),
                "smallest eigenvalue of each link's pseudo-inertia: " + ", ".join(f"{x:.3g}" for x in c.margins),
            ]
            if hasattr(c, "table"):
                lines.append(c.table())
        if self.consistent_error is not None:
            lines += ["", f"physically consistent standard parameters: failed ({self.consistent_error})"]
        if validation is not None:
            lines += [""] + validation.lines()
        return "\n".join(lines)

    def parameters(self) -> dict:
        """What parameters.json holds: base parameters with σ, standard parameters, fit facts."""
        out = {
            "model": self.prior.name,
            "method": self.method,
            "samples": self.samples,
            "condition": self.condition,
            "scaled_condition": self.scaled_condition,
            "rms": self.rms.tolist(),
            "sigma": self.sigma.tolist(),
            "base": [
                {"name": k, "value": float(v), "std": float(s), "relative_std_percent": float(r), "stands_for": e}
                for k, v, s, r, e in zip(
                    self.base.names, self.base.values, self.base.std, self.base.relative, self.base.expressions
                )
            ],
        }
        names = robot_names(self.prior)
        prior = standard_vector(self.prior)
        try:
            standard = self.standard()
        except ValueError:
            standard = None
        out["standard"] = [
            {"name": k, "prior": float(p), **({"value": float(v)} if standard is not None else {})}
            for k, p, v in zip(names, prior, standard if standard is not None else prior)
        ]
        out["standard_frames"] = "the regressor's link frames (modified DH / joint axis along z)"
        if self.consistent is not None:
            out["consistent"] = {
                "margins": [float(x) for x in self.consistent.margins],
                "moved": float(self.consistent.moved),
            }
        return out

    def write(
        self,
        out_dir: str | os.PathLike[str],
        validation: Validation | Data | None = None,
        *,
        figures: bool = True,
        urdf_source: str | os.PathLike[str] | None = None,
    ) -> list[Path]:
        """Write summary.txt, parameters.json, identified.urdf (a model read from a URDF: that file with
        the identified inertials, `urdf_source` its path or text where the robot's record does not
        reach it) and the figures (fit.png, validation.png, parameters.png; with matplotlib) into
        out_dir; returns the paths."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        if isinstance(validation, Data):
            validation = self.validate(validation)
        paths = [out / "summary.txt", out / "parameters.json"]
        notes = []
        if getattr(self.prior, "urdf", None) is not None:
            written, notes = self._write_urdf(out / "identified.urdf", urdf_source)
            paths += written
        paths[1].write_text(json.dumps(self.parameters(), indent=1) + "\n")
        text = self.summary(validation)
        if notes:
            text += "\n\nidentified.urdf:\n" + "\n".join(f"  {line}" for line in notes)
        paths[0].write_text(text + "\n")
        if figures:
            import importlib.util
            import sys

            if importlib.util.find_spec("matplotlib") is None:
                print("symdyn: no figures: they need matplotlib (pip install 'symdyn[plot]')", file=sys.stderr)
            else:
                paths += self.figures(out, validation)
        return paths

    def _write_urdf(self, path: Path, source=None) -> tuple[list, list]:
        """identified.urdf through the URDF writer (the original file's other elements kept), where
        this symdyn has one; its warnings (what URDF cannot say: rotor inertia, asymmetric Coulomb
        friction) come back as lines for the summary."""
        import warnings

        write = getattr(Robot, "to_urdf", None)
        if write is None:
            try:
                from importlib import import_module

                writer = import_module("symdyn.model.urdf.writer").to_urdf
            except (ImportError, AttributeError):
                return [], ["not written: this symdyn has no URDF writer"]
            write = writer
        try:
            robot = self.robot
        except ValueError as exc:
            return [], [f"not written: {exc}"]
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            write(robot, path, source=str(source) if source is not None else None)
        return [path], [str(w.message) for w in caught]

    def figures(self, out: Path, validation: Validation | None = None) -> list[Path]:
        from ..apps.studies._plot import pyplot, save

        plt = pyplot()
        paths = []
        d = self.data
        fit_view = Validation(
            source=d.source,
            t=d.t,
            measured=d.tau,
            predicted=self.predict(d.q, d.qd, d.qdd),
            rms=self.rms,
            relative=self.rms,
        )
        for name, v in (("fit", fit_view), ("validation", validation)):
            if v is None:
                continue
            rows = self.data.columns("tau")
            n = len(rows)
            fig, axes = plt.subplots(n, 1, figsize=(8, 1.6 * n + 0.6), sharex=True, squeeze=False)
            for j, ax in enumerate(axes[:, 0]):
                ax.plot(v.t, v.measured[:, j], lw=0.6, color="0.6", label="measured")
                ax.plot(v.t, v.predicted[:, j], lw=0.9, color="C0", label="predicted")
                ax.set_ylabel(rows[j])
                if name == "validation":
                    ax.set_title(f"{rows[j]}: rms error {v.rms[j]:.3g} ({100 * v.relative[j]:.1f} %)", fontsize=8)
            axes[0, 0].legend(fontsize=7, loc="upper right")
            axes[-1, 0].set_xlabel("t (s)")
            fig.suptitle(f"{self.prior.name}: {name} ({v.source})", fontsize=9)
            paths.append(save(fig, out, name))
        fig, ax = plt.subplots(figsize=(max(6, 0.12 * len(self.base)), 3))
        rel = np.where(np.isfinite(self.base.relative), self.base.relative, np.nan)
        ax.bar(range(len(self.base)), rel, color="C0")
        ax.set_yscale("log")
        ax.set_xticks(range(len(self.base)), self.base.names, rotation=90, fontsize=6)
        ax.set_ylabel("relative σ (%)")
        ax.set_title(
            f"{self.prior.name}: base parameters' relative standard deviation (condition {self.condition:.3g})",
            fontsize=9,
        )
        paths.append(save(fig, out, "parameters"))
        return paths
