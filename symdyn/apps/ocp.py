"""Trajectory optimisation for any arm on CasADi dynamics functions (Opti + IPOPT).

The third use of symdyn: the emitted CasADi functions feed optimal control.
A `Problem` (boundary states, fixed or free final time, grid, transcription,
`Limits`, `Cost`) is posed with `casadi.Opti` as direct multiple shooting
(piecewise-constant torque, RK4 on fdyn(q, q̇, τ)) or direct collocation
(trapezoidal or Hermite–Simpson, q̈ a decision variable and τ = ID(q, q̇, q̈)
imposed: no mass-matrix inverse).  `solve` returns a `Solution`; `verify`
re-simulates its torque open-loop with the numeric reference and checks the
goal and the limits, so every optimum is checked against `symdyn.reference`.
"""

from __future__ import annotations

import functools
import math
import numbers
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from ..derivation.progress import reported
from ..model import Robot
from ..model.base_joint import coordinate_rates
from ..numeric import casadi_rnea, reference

__all__ = [
    "METHODS",
    "SOURCES",
    "OCPError",
    "ArmFunctions",
    "Limits",
    "Cost",
    "Problem",
    "Solution",
    "Check",
    "Tracker",
    "RTITracker",
    "dynamics",
    "planar_rates",
    "motor_torque_limits",
    "solve",
    "resimulate",
    "verify",
    "limit_violation",
]

METHODS = ("multiple-shooting", "trapezoidal", "hermite-simpson")
SOURCES = ("symdyn", "plain")


class OCPError(RuntimeError):
    """IPOPT found no solution; `status` is IPOPT's return status."""

    def __init__(self, message: str, status: str, iterations: int):
        super().__init__(message)
        self.status = status
        self.iterations = iterations


# --------------------------------------------------------------------------- dynamics sources


@dataclass(frozen=True)
class ArmFunctions:
    """CasADi dynamics of one arm: tau(q, qd, qdd) -> τ (needed by collocation) and
    fdyn(q, qd, tau) -> q̈ (needed by multiple shooting); either may be None.

    Raises:
        ValueError: neither tau nor fdyn, or one that is not a `casadi.Function` of
            3 inputs and 1 output.
    """

    tau: ca.Function | None
    fdyn: ca.Function | None
    source: str = "custom"
    compiled: bool = False
    fdyn_sx: ca.Function | None = None  # the SX fdyn compiled ones come from: the shooting step's
    #: (q, q̇, τ) → (q̈, ∂q̈/∂q, ∂q̈/∂q̇, M⁻¹) on SX when the source generates it (symdyn's
    #: `fdyn_derivatives`); else the shooting step takes CasADi's AD of fdyn_sx.
    fdyn_derivatives_sx: ca.Function | None = None
    name: str = ""  # the arm's, for progress lines
    #: (q, v) → q̇ of a planar base, whose velocities are in its own frame (`planar_rates`);
    #: None: q̇ = v.
    rates: ca.Function | None = None

    def shooting_step(self, substeps: int) -> ca.Function:
        """(q, q̇, τ, h) → (q⁺, q̇⁺), `substeps` RK4 steps: compiled with explicit Jacobian and
        Hessian (`ocp_step.rk4_step`, built once into the cache) when these dynamics are
        compiled from SX and q̇ = v, else CasADi's AD through the RK4 stages."""
        if self.compiled and self.fdyn_sx is not None and self.rates is None:
            return _compiled_step(self.fdyn_sx, self.n, substeps, self.fdyn_derivatives_sx, self.name)
        return _rk4_step(self.need("multiple-shooting"), self.n, substeps, self.rates)

    @property
    def label(self) -> str:
        """The source and how it is evaluated, e.g. "symdyn compiled", "plain SX"."""
        return f"{self.source} {'compiled' if self.compiled else 'SX'}"

    def __post_init__(self) -> None:
        if self.tau is None and self.fdyn is None:
            raise ValueError("ArmFunctions needs tau(q, qd, qdd), fdyn(q, qd, tau) or both")
        for name in ("tau", "fdyn"):
            f = getattr(self, name)
            if f is not None and (f.n_in() != 3 or f.n_out() != 1):
                raise ValueError(f"{name} must be a casadi.Function of 3 inputs and 1 output, got {f}")

    @property
    def n(self) -> int:
        return (self.tau or self.fdyn).size1_in(0)

    def need(self, method: str) -> ca.Function:
        """The function `method` transcribes: fdyn for multiple shooting, else tau."""
        name = "fdyn" if method == "multiple-shooting" else "tau"
        if getattr(self, name) is None:
            raise ValueError(f"{method} needs the {name} function, but this {self.source!r} dynamics has none")
        return getattr(self, name)


@functools.lru_cache(maxsize=16)
def dynamics(robot: Robot, source: str = "symdyn", *, compiled: bool = True) -> ArmFunctions:
    """The arm's inverse and forward dynamics as CasADi Functions, friction included
    (pass `robot.nofriction()` to drop the non-smooth Coulomb term).

    source="symdyn": symdyn's simplified generated functions
    (`symdyn.load(robot, target="casadi")`, derived and cached on first use for
    a robot that is not shipped); "plain": the unsimplified SX Newton–Euler of
    `symdyn.numeric.casadi_rnea`.  compiled=True (the default): each function is
    a `casadi.external` on compiled C, with its Jacobian and the Hessian of λᵀf
    compiled beside it (`symdyn.codegen.emit.casadi.compiled`, built once into
    the cache, ~15 s for the Puma's fdyn), and multiple shooting's whole interval
    is compiled with explicit derivatives (`ArmFunctions.shooting_step`);
    compiled=False: CasADi's SX virtual machine and its AD at every evaluation
    (no compiler needed).  A step that takes over `progress.REPORT_AFTER_S` (a
    first build; not a read from the cache) says what it builds on stderr, and
    how long it took (`symdyn.derivation.progress.reported`).

    A planar base (`Robot.base_joint`) adds its coordinates' rates (`planar_rates`): q and v
    both have nq = nv entries, v's base part in the base's own frame; whether the base is
    driven is the problem's (`Problem.unactuated`).

    Returns:
        An `ArmFunctions` (cached per robot, source and compiled).

    Raises:
        ValueError: an unknown source, or an arm whose code cannot be derived or
            generated (a symbolic robot); a free base (q has 7 base entries, v 6: not
            transcribed) or source="plain" on a floating base.
        RuntimeError: compiled=True without a C compiler, or a failed build.
    """
    from ..codegen.emit.casadi import compiled as compile_function

    if robot.base_joint == "free":
        raise ValueError(
            f"ocp.dynamics({robot.name!r}): a free base is not transcribed (its quaternion makes q 7 "
            "entries long and v 6); a planar base is, and any fixed base"
        )
    if robot.base_joint is not None and source == "plain":
        raise ValueError(f"ocp.dynamics({robot.name!r}): the plain source has no floating base: use source='symdyn'")
    rates = planar_rates(robot) if robot.base_joint == "planar" else None
    derivatives = None
    if source == "plain":
        tau, fdyn = casadi_rnea.rnea_function(robot), casadi_rnea.fdyn_function(robot)
    elif source == "symdyn":
        from ..codegen import entry as codegen

        with reported(f"ocp {robot.name}: symdyn's CasADi functions (derived and generated once, into the cache)"):
            f = codegen.load(robot, "casadi")
        tau, fdyn, derivatives = (f.functions[k] for k in ("tau", "fdyn", "fdyn_derivatives"))
    else:
        raise ValueError(f"unknown dynamics source {source!r}: expected one of {SOURCES}")
    if compiled:
        built = []
        for name, f in (("tau", tau), ("fdyn", fdyn)):
            with reported(
                f"ocp {robot.name}: compiling {name} ({source}) with its Jacobian and Hessian (once, into the cache)"
            ):
                built.append(compile_function(f))
        return ArmFunctions(*built, source, True, fdyn, derivatives, robot.name, rates)
    return ArmFunctions(tau, fdyn, source, False, name=robot.name, rates=rates)


def planar_rates(robot: Robot) -> ca.Function:
    """(q, v) → q̇ of a robot on a planar base: ẋ, ẏ = R(yaw)·(vx, vy), the yaw rate ω and the
    joints' q̇ = v (`symdyn.model.base_joint.coordinate_rates`, in CasADi).

    Raises:
        ValueError: a robot whose base is not planar.
    """
    if robot.base_joint != "planar":
        raise ValueError(f"planar_rates({robot.name!r}): its base is {robot.base_joint or 'fixed'}, not planar")
    q, v = ca.SX.sym("q", robot.nq), ca.SX.sym("v", robot.nv)
    c, s = ca.cos(q[2]), ca.sin(q[2])
    qd = ca.vertcat(c * v[0] - s * v[1], s * v[0] + c * v[1], v[2:])
    return ca.Function("rates", [q, v], [qd], ["q", "v"], ["qd"])


@functools.lru_cache(maxsize=16)
def _compiled_step(
    fdyn: ca.Function, n: int, substeps: int, derivatives: ca.Function | None, name: str = ""
) -> ca.Function:
    from .ocp_step import rk4_step

    with reported(
        f"ocp {name or f'{n}-joint arm'}: compiling the multiple-shooting interval "
        f"({substeps} RK4 step{'s' * (substeps != 1)}, explicit derivatives; once, into the cache)"
    ):
        return rk4_step(fdyn, n, substeps, derivatives)


# --------------------------------------------------------------------------- the problem


def motor_torque_limits(robot: Robot, motor_tau_max: ArrayLike) -> np.ndarray:
    """Joint torque limits (n,) N·m from motor torque limits: τ_max,joint = τ_max,motor·|G|.

    Raises:
        ValueError: motor_tau_max that is not n positive numbers (NaN named by its joint).
    """
    tm = np.asarray(motor_tau_max, dtype=float)
    if tm.shape != (robot.n,):
        raise ValueError(f"motor torque limits must be {robot.n} positive numbers, got {motor_tau_max!r}")
    bad = np.flatnonzero(~(tm > 0))  # NaN included
    if bad.size:
        j = int(bad[0])
        raise ValueError(
            f"motor torque limits must be {robot.n} positive numbers, got {motor_tau_max!r}: "
            f"joint {j + 1} has {float(tm[j])}"
        )
    return tm * np.abs([float(link.G) for link in robot.links])


@dataclass(frozen=True)
class Limits:
    """Box limits at every grid point: q (n, 2) [lower, upper] rad or m; |q̇| ≤ qd (n,);
    |τ| ≤ tau (n,) N·m (N for a prismatic joint).  None leaves a quantity unbounded;
    an infinite entry leaves that joint's quantity unbounded (no constraint is posed).

    Raises:
        ValueError: a limit that is not numbers, or a NaN entry (named by its joint).
    """

    q: np.ndarray | None = None
    qd: np.ndarray | None = None
    tau: np.ndarray | None = None

    def __post_init__(self) -> None:
        # NaN compares false with everything: a NaN limit would silently bound nothing
        for name in ("q", "qd", "tau"):
            v = getattr(self, name)
            if v is None:
                continue
            try:
                values = np.asarray(v, dtype=float)
            except (TypeError, ValueError):
                raise ValueError(f"Limits.{name} must be numbers, got {v!r}") from None
            nan = np.argwhere(np.isnan(values))
            if nan.size:
                joint = int(nan[0][0]) + 1 if values.ndim else 1
                raise ValueError(f"Limits.{name} of joint {joint} is NaN (inf leaves a joint unbounded), got {v!r}")

    @classmethod
    def for_robot(
        cls,
        robot: Robot,
        *,
        qd: ArrayLike | None = None,
        tau: ArrayLike | None = None,
        motor_tau: ArrayLike | None = None,
    ) -> "Limits":
        """The robot's limits: its joint limits (`robot.qlim`); speed limits qd (n,) as
        given, else the links' `velocity_limit`; torque limits tau (n,) as given, or from
        the motors (motor_tau·|G|), else the links' `effort_limit` — for a URDF arm the
        file's `<limit velocity=… effort=…>`.  Where only some links have a limit, the
        others get inf (that joint unbounded); where none has one (the DH models), None.

        Raises:
            ValueError: both tau and motor_tau, or motor_tau that is not n positive numbers.
        """
        if tau is not None and motor_tau is not None:
            raise ValueError("give torque limits either as tau (joint side) or motor_tau, not both")
        if motor_tau is not None:
            tau = motor_torque_limits(robot, motor_tau)
        qd = _link_limits(robot, "velocity_limit") if qd is None else np.asarray(qd, dtype=float)
        tau = _link_limits(robot, "effort_limit") if tau is None else np.asarray(tau, dtype=float)
        return cls(q=robot.qlim, qd=qd, tau=tau)

    def bounds_any(self) -> bool:
        """Whether a finite torque or speed limit bounds at least one joint (what keeps a
        minimum-time problem from collapsing to T → 0)."""
        return any(v is not None and bool(np.isfinite(v).any()) for v in (self.tau, self.qd))


def _link_limits(robot: Robot, name: str) -> np.ndarray | None:
    """The links' `name` limits (n,), inf where a link has none; None where no link has one."""
    values = [getattr(link, name) for link in robot.links]
    if all(v is None for v in values):
        return None
    return np.array([np.inf if v is None else float(v) for v in values])


def _finite_or_one(limit: np.ndarray | None, n: int) -> np.ndarray:
    """A scale per joint (n,): its limit where finite, else 1."""
    if limit is None:
        return np.ones(n)
    limit = np.asarray(limit, dtype=float)
    return np.where(np.isfinite(limit), limit, 1.0)


@dataclass(frozen=True)
class Cost:
    """Weights of the cost terms: time T, effort ∫τᵀWτ dt, smoothness ∫(dτ/dt)ᵀW(dτ/dt) dt;
    `weights` is the diagonal of W (n,), default ones.

    Raises:
        ValueError: a weight (time, effort, smoothness or an entry of `weights`) that
            is not a finite number ≥ 0.
    """

    time: float = 0.0
    effort: float = 0.0
    smoothness: float = 0.0
    weights: tuple | None = None

    def __post_init__(self) -> None:
        for name in ("time", "effort", "smoothness"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, numbers.Real) or not (math.isfinite(v) and v >= 0):
                raise ValueError(f"the cost weight {name} must be a finite number ≥ 0, got {v!r}")
        if self.weights is not None:
            if isinstance(self.weights, (str, bytes)) or np.ndim(self.weights) != 1:
                raise ValueError(
                    f"the cost weights must be a sequence of numbers (one per joint), got {self.weights!r}"
                )
            for j, w in enumerate(self.weights):
                if isinstance(w, bool) or not isinstance(w, numbers.Real) or not (math.isfinite(w) and w >= 0):
                    raise ValueError(
                        f"the cost weights must be finite numbers ≥ 0: joint {j + 1} has {w!r} in {self.weights!r}"
                    )


@dataclass(frozen=True)
class Problem:
    """Point to point from (q0, qd0) to (qf, qdf), at rest unless given.

    T: the fixed final time (s), or None for a free final time within
    T_bounds, starting from T_guess.  N intervals; method in METHODS;
    `substeps` RK4 steps per interval for multiple shooting.

    Raises:
        ValueError: an unknown method; N not an integer ≥ 2; T not positive;
            T_bounds not 0 < T_min < T_max; a free T without a positive time weight
            or without any finite torque or speed limit; q0, qf, qd0, qdf of
            different lengths or with a NaN or infinite entry; joint limits not
            (n, 2); speed or torque limits that are not n positive numbers (or a
            NaN one: `Limits`); cost weights that are not n entries; `unactuated`
            indices that are not distinct integers in 0 … n − 1, or all of them; a
            guess that is not (t, q, v) with t increasing from 0, q and v (len(t), n), finite.
    """

    q0: np.ndarray
    qf: np.ndarray
    T: float | None = None
    N: int = 40
    method: str = "hermite-simpson"
    limits: Limits = field(default_factory=Limits)
    cost: Cost = field(default_factory=lambda: Cost(effort=1.0))
    qd0: np.ndarray | None = None
    qdf: np.ndarray | None = None
    T_guess: float = 1.0
    T_bounds: tuple = (0.01, 20.0)
    substeps: int = 4
    #: (t, q, v) samples of a motion over [0, t[-1]] to start IPOPT from (a simulation, a plan),
    #: taken as a path in t/t[-1] and stretched to T; default the minimum-jerk path q0 → qf.
    guess: tuple | None = None
    #: Indices of v whose τ is held at zero: a free-floating base's velocities (no thruster, no
    #: wheel), or a passive joint.  Default none: every row is driven, a mobile base's too.
    unactuated: tuple = ()
    #: A task-space goal (`symdyn.apps.ocp_task.TaskGoal`): a frame's end pose instead of qf (which
    #: then only ends the starting guess) and obstacles that chosen frames clear at every node.
    task: object = None

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"unknown transcription {self.method!r}: expected one of {METHODS}")
        if not (isinstance(self.N, int) and self.N >= 2):
            raise ValueError(f"N must be an integer of at least 2 intervals, got {self.N!r}")
        if self.T is not None and not self.T > 0:
            raise ValueError(f"the final time T must be positive (or None for free), got {self.T!r}")
        lo, hi = self.T_bounds
        if not 0 < lo < hi:
            raise ValueError(f"T_bounds must be 0 < T_min < T_max, got {self.T_bounds!r}")
        if self.T is None and not self.cost.time > 0:
            raise ValueError("a free final time (T=None) needs a positive time weight in the cost; otherwise give T")
        n = np.size(self.q0)
        for name in ("q0", "qf", "qd0", "qdf"):
            v = getattr(self, name)
            if v is not None and np.shape(v) != (n,):
                raise ValueError(f"{name} must have shape ({n},) like q0, got {np.shape(v)}")
            if v is not None:
                values = np.asarray(v, dtype=float)
                bad = np.flatnonzero(~np.isfinite(values))
                if bad.size:
                    j = int(bad[0])
                    raise ValueError(f"{name} must be finite: joint {j + 1} has {float(values[j])}, got {v!r}")
        if self.guess is not None:
            _check_guess(self.guess, n)
        held = list(self.unactuated)
        if not all(isinstance(i, numbers.Integral) and 0 <= i < n for i in held) or len(set(held)) != len(held):
            raise ValueError(f"unactuated must be distinct joint indices in 0 … {n - 1}, got {self.unactuated!r}")
        if len(held) == n:
            raise ValueError(f"unactuated names every one of the {n} joints: nothing is left to drive the motion")
        if self.cost.weights is not None and len(self.cost.weights) != n:
            raise ValueError(f"the cost weights must be {n} numbers (one per joint), got {self.cost.weights!r}")
        lim = self.limits
        if lim.q is not None and np.shape(lim.q) != (n, 2):
            raise ValueError(f"joint limits must have shape ({n}, 2), got {np.shape(lim.q)}")
        for name in ("qd", "tau"):
            v = getattr(lim, name)
            if v is not None and (np.shape(v) != (n,) or not np.all(np.asarray(v) > 0)):
                raise ValueError(f"{name} limits must be {n} positive numbers, got {v!r}")
        if self.T is None and not lim.bounds_any():
            raise ValueError(
                "this minimum-time problem has no torque or speed limit on any joint (limits.tau and "
                "limits.qd are None or infinite), so nothing bounds how fast the arm moves and T would "
                f"collapse to T_bounds[0] = {lo:g} s; give limits: Limits(tau=..., qd=...), "
                "Limits.for_robot(robot, tau=..., qd=...) or motor_tau=..., or read a URDF whose joints "
                "have <limit effort=... velocity=...> (Robot.from_urdf; Limits.for_robot takes them)"
            )

    @property
    def n(self) -> int:
        return np.size(self.q0)

    def boundary(self) -> tuple[np.ndarray, ...]:
        """q0, qd0, qf, qdf as float arrays (velocities default to rest)."""
        z = np.zeros(self.n)
        return tuple(np.asarray(v if v is not None else z, dtype=float) for v in (self.q0, self.qd0, self.qf, self.qdf))


# --------------------------------------------------------------------------- the solution


@dataclass(frozen=True)
class Solution:
    """An optimal trajectory on its grid.

    t, q, qd: node times (N+1,) and states (N+1, n).  tau: (N, n) per interval
    (multiple shooting, held constant) or (N+1, n) at the nodes (collocation,
    interpolated linearly by trapezoidal, quadratically through tau_mid by
    Hermite–Simpson).  q_mid, qd_mid, tau_mid: interval midpoints (Hermite–
    Simpson) or None.  stats: IPOPT status, iterations and timings.
    """

    method: str
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    cost: float
    stats: dict
    qdd: np.ndarray | None = None
    q_mid: np.ndarray | None = None
    qd_mid: np.ndarray | None = None
    tau_mid: np.ndarray | None = None

    @property
    def T(self) -> float:
        return float(self.t[-1])

    @property
    def N(self) -> int:
        return len(self.t) - 1

    def interval_torque(self, k: int, s: float) -> np.ndarray:
        """τ (n,) at time s ∈ [0, h] into interval k, as the transcription assumes."""
        h = self.t[k + 1] - self.t[k]
        if self.method == "multiple-shooting":
            return self.tau[k]
        a, c = self.tau[k], self.tau[k + 1]
        if self.method == "trapezoidal":
            return a + (c - a) * (s / h)
        b, x = self.tau_mid[k], s / h
        return a * (2 * x - 1) * (x - 1) + 4 * b * x * (1 - x) + c * x * (2 * x - 1)

    def torque(self, t: ArrayLike) -> np.ndarray:
        """τ(t) (len(t), n) on [0, T], right-continuous at the nodes."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        k = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, self.N - 1)
        return np.array([self.interval_torque(ki, ti - self.t[ki]) for ki, ti in zip(k, t)])


# --------------------------------------------------------------------------- transcription


def _rk4_step(fdyn: ca.Function, n: int, substeps: int, rates: ca.Function | None = None) -> ca.Function:
    """(q, qd, tau, h) -> (q⁺, qd⁺): `substeps` RK4 steps of q̈ = fdyn(q, q̇, τ), τ held;
    q̇ = rates(q, v) where given (a planar base)."""
    q, qd, tau, h = ca.MX.sym("q", n), ca.MX.sym("qd", n), ca.MX.sym("tau", n), ca.MX.sym("h")
    qdot = (lambda x: x[n:]) if rates is None else (lambda x: rates(x[:n], x[n:]))  # noqa: E731
    x = rk4_steps(lambda x: ca.vertcat(qdot(x), fdyn(x[:n], x[n:], tau)), ca.vertcat(q, qd), h, substeps)
    return ca.Function("rk4", [q, qd, tau, h], [x[:n], x[n:]])


def rk4_steps(f, x, h, substeps: int):
    """x after `substeps` classical RK4 steps of ẋ = f(x) over the time h (NumPy or CasADi alike)."""
    dt = h / substeps
    for _ in range(substeps):
        k1 = f(x)
        k2 = f(x + dt / 2 * k1)
        k3 = f(x + dt / 2 * k2)
        k4 = f(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def _quadratic_smoothness(a, b, c, h):
    """∫₀ʰ (dτ/dt)² dt, per joint, of the quadratic through a, b, c at 0, h/2, h."""
    A = (-3 * a + 4 * b - c) / h
    B = (4 * a - 8 * b + 4 * c) / h**2
    return A**2 * h + A * B * h**2 + B**2 * h**3 / 3


def _check_guess(guess, n: int) -> None:
    """Raise ValueError unless guess is (t, q, v): t increasing from 0, q and v (len(t), n), all finite."""
    try:
        t, q, v = (np.asarray(x, dtype=float) for x in guess)
    except (TypeError, ValueError):
        raise ValueError(f"guess must be (t, q, v) arrays, got {type(guess).__name__}") from None
    if t.ndim != 1 or t.size < 2 or t[0] != 0 or not np.all(np.diff(t) > 0):
        raise ValueError(f"the guess's t must increase from 0 over at least 2 samples, got shape {t.shape}")
    for name, x in (("q", q), ("v", v)):
        if x.shape != (t.size, n):
            raise ValueError(f"the guess's {name} must have shape ({t.size}, {n}) like t and q0, got {x.shape}")
    if not all(np.isfinite(x).all() for x in (t, q, v)):
        raise ValueError("the guess must be finite: it has a NaN or infinite entry")


def _guess(problem: Problem, arm: ArmFunctions, T: float):
    """The starting path with its velocities, accelerations and ID torques at fractions s
    (N+1 nodes and N midpoints): `problem.guess` stretched to T, or a minimum-jerk path
    q0 → qf; the unactuated rows' torques zero."""
    q0, _, qf, _ = problem.boundary()
    s = np.linspace(0, 1, 2 * problem.N + 1)[:, None]
    if problem.guess is None:
        q = q0 + (qf - q0) * (10 * s**3 - 15 * s**4 + 6 * s**5)
        qd = (qf - q0) * (30 * s**2 - 60 * s**3 + 30 * s**4) / T
        qdd = (qf - q0) * (60 * s - 180 * s**2 + 120 * s**3) / T**2
    else:
        t, qg, vg = (np.asarray(x, dtype=float) for x in problem.guess)
        along = lambda x: np.stack([np.interp(s[:, 0], t / t[-1], c) for c in x.T], -1)  # noqa: E731
        q, qd = along(qg), along(vg) * t[-1] / T
        qdd = np.gradient(qd, s[:, 0] * T, axis=0)
    if arm.tau is None:
        return q, qd, qdd, np.zeros_like(q)
    tau = np.array(arm.tau.map(len(s))(q.T, qd.T, qdd.T)).T
    tau[:, list(problem.unactuated)] = 0.0
    if problem.limits.tau is not None:
        tau = np.clip(tau, -problem.limits.tau, problem.limits.tau)
    return q, qd, qdd, tau


def _bound(opti: ca.Opti, lo, X, hi) -> None:
    """lo ≤ X ≤ hi in every column of X (n, K), lo and hi (n,); a row with no finite
    bound gets no constraint (an infinite limit: that joint unbounded)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    rows = np.flatnonzero(np.isfinite(lo) | np.isfinite(hi))
    if rows.size == 0:
        return
    if rows.size < X.shape[0]:
        lo, hi, X = lo[rows], hi[rows], X[rows.tolist(), :]
    cols = X.shape[1]
    opti.subject_to(opti.bounded(np.repeat(lo[:, None], cols, 1), X, np.repeat(hi[:, None], cols, 1)))


def _bound_states(opti: ca.Opti, limits: Limits, Q, QD) -> None:
    if limits.q is not None:
        q = np.asarray(limits.q, dtype=float)
        _bound(opti, q[:, 0], Q, q[:, 1])
    if limits.qd is not None:
        _bound(opti, -limits.qd, QD, limits.qd)


def _bound_torque(opti: ca.Opti, problem: Problem, U) -> None:
    """The torque limits on U (n, K), and τ = 0 on the unactuated rows."""
    if problem.limits.tau is not None:
        _bound(opti, -problem.limits.tau, U, problem.limits.tau)
    if problem.unactuated:
        opti.subject_to(U[list(problem.unactuated), :] == 0)


def _pose(problem: Problem, arm: ArmFunctions, opti: ca.Opti):
    """Decision variables, constraints and cost of the transcription; returns the
    handles to read back and the cost expression."""
    n, N, lim = problem.n, problem.N, problem.limits
    q0, qd0, qf, qdf = problem.boundary()
    if problem.T is None:
        T = opti.variable()
        opti.subject_to(opti.bounded(problem.T_bounds[0], T, problem.T_bounds[1]))
        opti.set_initial(T, problem.T_guess)
        T0 = problem.T_guess
    else:
        T = T0 = problem.T
    guess = _guess(problem, arm, T0)
    Q, QD = opti.variable(n, N + 1), opti.variable(n, N + 1)
    opti.set_initial(Q, guess[0][::2].T)
    opti.set_initial(QD, guess[1][::2].T)
    opti.subject_to([Q[:, 0] == q0, QD[:, 0] == qd0, QD[:, N] == qdf])
    if problem.task is None:
        opti.subject_to(Q[:, N] == qf)
    else:  # the frame's end pose, and the obstacles cleared at every node
        problem.task.constrain(opti, Q)
    _bound_states(opti, lim, Q, QD)
    handles = {"Q": Q, "QD": QD, "T": T}
    pose = _multiple_shooting if problem.method == "multiple-shooting" else _collocation
    return handles, problem.cost.time * T + pose(problem, arm, opti, handles, T / N, guess)


def _weighted(problem: Problem):
    """X (n, K) -> (1, K): Σⱼ wⱼ·Xⱼₖ per column, w = cost.weights (default ones)."""
    w = problem.cost.weights
    W = ca.diag(ca.DM(np.ones(problem.n) if w is None else np.asarray(w, dtype=float)))
    return lambda X: ca.sum1(ca.mtimes(W, X))


def _multiple_shooting(problem: Problem, arm: ArmFunctions, opti: ca.Opti, handles: dict, h, guess):
    """Piecewise-constant τ per interval, RK4 on fdyn; returns the effort and smoothness cost."""
    n, N, cost = problem.n, problem.N, problem.cost
    Q, QD = handles["Q"], handles["QD"]
    U = handles["U"] = opti.variable(n, N)
    opti.set_initial(U, guess[3][1::2].T)
    _bound_torque(opti, problem, U)
    step = arm.shooting_step(problem.substeps).map(N)
    qn, qdn = step(Q[:, :N], QD[:, :N], U, h)
    opti.subject_to([Q[:, 1:] == qn, QD[:, 1:] == qdn])
    w = _weighted(problem)
    return cost.effort * h * ca.sum2(w(U**2)) + cost.smoothness * ca.sum2(w(ca.diff(U, 1, 1) ** 2)) / h


def _collocation(problem: Problem, arm: ArmFunctions, opti: ca.Opti, handles: dict, h, guess):
    """Trapezoidal or Hermite–Simpson (separated form) collocation with q̈ as decision
    variable and τ = ID(q, q̇, q̈) imposed at every collocation point (scaled by the
    torque limits); returns the effort and smoothness cost."""
    n, N, lim, cost = problem.n, problem.N, problem.limits, problem.cost
    gq, gqd, gqdd, gtau = guess
    Q, QD = handles["Q"], handles["QD"]
    QDD, U = opti.variable(n, N + 1), opti.variable(n, N + 1)
    opti.set_initial(QDD, gqdd[::2].T)
    opti.set_initial(U, gtau[::2].T)
    _bound_torque(opti, problem, U)
    ID = arm.need(problem.method)
    scale = ca.DM(_finite_or_one(lim.tau, n))
    opti.subject_to((ID.map(N + 1)(Q, QD, QDD) - U) / ca.repmat(scale, 1, N + 1) == 0)
    a, b = slice(0, N), slice(1, N + 1)
    handles.update(QDD=QDD, U=U)
    w = _weighted(problem)
    rate = (lambda Q, V: V) if arm.rates is None else (lambda Q, V: arm.rates.map(Q.shape[1])(Q, V))  # noqa: E731
    QDOT = rate(Q, QD)  # q̇ at the nodes: v, or a planar base's rates
    if problem.method == "trapezoidal":
        opti.subject_to(Q[:, b] - Q[:, a] == h / 2 * (QDOT[:, a] + QDOT[:, b]))
        opti.subject_to(QD[:, b] - QD[:, a] == h / 2 * (QDD[:, a] + QDD[:, b]))
        return (
            cost.effort * h / 2 * ca.sum2(w(U[:, a] ** 2) + w(U[:, b] ** 2))
            + cost.smoothness * ca.sum2(w(ca.diff(U, 1, 1) ** 2)) / h
        )
    Qm, QDm, QDDm, Um = (opti.variable(n, N) for _ in range(4))
    for X, g in ((Qm, gq), (QDm, gqd), (QDDm, gqdd), (Um, gtau)):
        opti.set_initial(X, g[1::2].T)
    _bound_states(opti, lim, Qm, QDm)
    _bound_torque(opti, problem, Um)
    opti.subject_to(Qm == (Q[:, a] + Q[:, b]) / 2 + h / 8 * (QDOT[:, a] - QDOT[:, b]))
    opti.subject_to(QDm == (QD[:, a] + QD[:, b]) / 2 + h / 8 * (QDD[:, a] - QDD[:, b]))
    opti.subject_to(Q[:, b] - Q[:, a] == h / 6 * (QDOT[:, a] + 4 * rate(Qm, QDm) + QDOT[:, b]))
    opti.subject_to(QD[:, b] - QD[:, a] == h / 6 * (QDD[:, a] + 4 * QDDm + QDD[:, b]))
    opti.subject_to((ID.map(N)(Qm, QDm, QDDm) - Um) / ca.repmat(scale, 1, N) == 0)
    handles.update(Qm=Qm, QDm=QDm, QDDm=QDDm, Um=Um)
    return cost.effort * h / 6 * ca.sum2(w(U[:, a] ** 2) + 4 * w(Um**2) + w(U[:, b] ** 2)) + cost.smoothness * ca.sum2(
        w(_quadratic_smoothness(U[:, a], Um, U[:, b], h))
    )


def _hint(problem: Problem, arm: ArmFunctions) -> str:
    """Where the torque limits are below the torque that holds the arm at the end points."""
    lim = problem.limits.tau
    if lim is None or arm.tau is None:
        return ""
    q0, _, qf, _ = problem.boundary()
    z = np.zeros(problem.n)
    notes = []
    for name, q in (("q0", q0), ("qf", qf)):
        g = np.array(arm.tau(q, z, z)).ravel()
        over = np.flatnonzero(np.abs(g) > lim)
        notes += [
            f"joint {j + 1} needs {abs(g[j]):.3g} N·m to hold the arm at {name} "
            f"but its torque limit is {lim[j]:.3g} N·m"
            for j in over
        ]
    return ("; hint: " + "; ".join(notes)) if notes else ""


def solve(
    problem: Problem,
    arm: ArmFunctions,
    *,
    verbose: bool = False,
    max_iter: int = 3000,
    expand: bool = False,
    simple_bounds: bool = True,
) -> Solution:
    """Pose `problem` on the CasADi dynamics `arm` and solve it with IPOPT.

    expand=True expands the whole NLP into SX: faster iterations, much longer
    set-up.  simple_bounds=True (the default) hands the limits on decision variables
    to IPOPT as variable bounds (nlpsol's `detect_simple_bounds`) instead of general
    inequality rows with slacks: a KKT system about half the size, ~1.3× faster
    collocation iterations on compiled dynamics (docs/studies_ocp.md).  Raises
    OCPError (with IPOPT's return status) when no solution is found.

    Returns:
        The `Solution`: grid, states, torques, cost and IPOPT's stats.

    Raises:
        ValueError: dynamics for another number of joints than the problem's, or
            without the function the method needs (fdyn for multiple shooting,
            tau for collocation).
        OCPError: IPOPT finds no solution (CasADi's failure, translated; its
            `status` and `iterations`, and a hint where a torque limit cannot hold
            the arm at an end point).
        RuntimeError: building the compiled multiple-shooting interval fails.
    """
    if arm.n != problem.n:
        raise ValueError(f"the dynamics are for {arm.n} joints but the problem has {problem.n}")
    opti = ca.Opti()
    handles, J = _pose(problem, arm, opti)
    opti.minimize(J)
    opti.solver(
        "ipopt",
        {"print_time": verbose, "record_time": True, "expand": expand, "detect_simple_bounds": simple_bounds},
        {"print_level": 5 if verbose else 0, "sb": "yes", "max_iter": max_iter},
    )
    start, cpu = time.perf_counter(), time.process_time()
    try:
        sol = opti.solve()
    except RuntimeError:
        st = opti.stats()
        status, iters = st.get("return_status", "unknown"), st.get("iter_count", 0)
        raise OCPError(
            f"IPOPT found no {problem.method} solution: return status {status} after "
            f"{iters} iterations{_hint(problem, arm)}",
            status,
            iters,
        ) from None
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    st = sol.stats()
    iters = int(st["iter_count"])
    evals = sum(v for k, v in st.items() if k.startswith("t_wall_nlp_"))
    stats = {
        "status": st["return_status"],
        "success": bool(st["success"]),
        "iterations": iters,
        "solve_wall": wall,
        "solve_cpu": cpu,
        "ipopt_wall": float(st["t_wall_total"]),
        "eval_wall": float(evals),
        "setup_wall": wall - float(st["t_wall_total"]),
        "per_iteration": float(st["t_wall_total"]) / max(iters, 1),
        "source": arm.source,
        "compiled": arm.compiled,
    }
    v = lambda x: np.atleast_2d(np.array(sol.value(x), dtype=float))  # noqa: E731
    T = float(sol.value(handles["T"]))
    out = dict(
        method=problem.method,
        t=np.linspace(0, T, problem.N + 1),
        q=v(handles["Q"]).T,
        qd=v(handles["QD"]).T,
        tau=v(handles["U"]).T,
        cost=float(sol.value(opti.f)),
        stats=stats,
    )
    if problem.method != "multiple-shooting":
        out["qdd"] = v(handles["QDD"]).T
    if problem.method == "hermite-simpson":
        out.update(q_mid=v(handles["Qm"]).T, qd_mid=v(handles["QDm"]).T, tau_mid=v(handles["Um"]).T)
    return Solution(**out)


# --------------------------------------------------------------------------- verification


def resimulate(
    robot: Robot, solution: Solution, *, substeps: int = 10, restart: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Open-loop simulation of the solution's torque with the reference forward dynamics
    (`reference.accel`): fixed-step RK4, `substeps` steps per interval, τ interpolated as
    the transcription assumes.  restart=True starts each interval from the solution's own
    node (the transcription's local error, free of the growth an unstable open loop adds).
    Returns (t, q, qd), states at the nodes (at node k+1: the end of interval k).

    Raises:
        ValueError: a symbolic robot, or one whose joint count is not the solution's;
            a state that turns NaN or infinite (the reference's input check).
        SingularInertia: M(q) is singular along the motion (a `ValueError`).
    """
    n = robot.nv  # a planar base's q and v are both nq = nv long
    x = np.concatenate([solution.q[0], solution.qd[0]])
    qs, qds = [x[:n]], [x[n:]]
    for k in range(solution.N):
        if restart:
            x = np.concatenate([solution.q[k], solution.qd[k]])
        h = (solution.t[k + 1] - solution.t[k]) / substeps

        def f(x, s, k=k):
            tau = solution.interval_torque(k, s)
            return np.concatenate([coordinate_rates(robot, x[:n], x[n:]), reference.accel(robot, x[:n], x[n:], tau)])

        for j in range(substeps):
            s = j * h
            k1 = f(x, s)
            k2 = f(x + h / 2 * k1, s + h / 2)
            k3 = f(x + h / 2 * k2, s + h / 2)
            k4 = f(x + h * k3, s + h)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        qs.append(x[:n])
        qds.append(x[n:])
    return solution.t, np.array(qs), np.array(qds)


@dataclass(frozen=True)
class Check:
    """The verification of one solution: IPOPT success, the re-simulation's errors (rad or m,
    and per s) and the worst limit violation on the grid.  replay "open-loop": one simulation
    from the start, judged by its goal errors; "intervals": each interval re-simulated from the
    solution's node, judged by the worst gap at the next node (path_q/qd_error).
    q, qd: the re-simulated states at the nodes (N+1, n)."""

    success: bool
    status: str
    goal_q_error: float
    goal_qd_error: float
    path_q_error: float
    path_qd_error: float
    limit_violation: float
    tol_q: float
    tol_qd: float
    tol_limits: float
    replay: str = "open-loop"
    q: np.ndarray = field(repr=False, default=None)
    qd: np.ndarray = field(repr=False, default=None)

    @property
    def ok(self) -> bool:
        errors = (
            (self.goal_q_error, self.goal_qd_error)
            if self.replay == "open-loop"
            else (self.path_q_error, self.path_qd_error)
        )
        return (
            self.success
            and errors[0] <= self.tol_q
            and errors[1] <= self.tol_qd
            and self.limit_violation <= self.tol_limits
        )

    def describe(self) -> str:
        if self.replay == "open-loop":
            replay = (
                f"open-loop re-simulation reaches the goal within {self.goal_q_error:.2e} rad "
                f"(tol {self.tol_q:g}) and {self.goal_qd_error:.2e} rad/s (tol {self.tol_qd:g}), "
                f"max deviation from the optimised path {self.path_q_error:.2e} rad"
            )
        else:
            replay = (
                f"re-simulated interval by interval from each node: worst gap at the next node "
                f"{self.path_q_error:.2e} rad (tol {self.tol_q:g}) and {self.path_qd_error:.2e} rad/s "
                f"(tol {self.tol_qd:g})"
            )
        return (
            f"IPOPT {self.status}; {replay}; worst limit violation {self.limit_violation:.1e} "
            f"(tol {self.tol_limits:g}): {'PASS' if self.ok else 'FAIL'}"
        )


def _violation(x: np.ndarray | None, lo, hi) -> float:
    if x is None:
        return 0.0
    return float(max(0.0, np.max(lo - x), np.max(x - hi)))


def limit_violation(problem: Problem, solution: Solution) -> float:
    """Worst excess over any limit at the grid points (nodes, and midpoints for
    Hermite–Simpson), in the quantity's units.

    Raises:
        ValueError: a solution whose joint count differs from the problem's.
    """
    for name in ("q", "qd", "tau", "q_mid", "qd_mid", "tau_mid"):
        v = getattr(solution, name)
        if v is not None and (np.ndim(v) != 2 or np.shape(v)[1] != problem.n):
            raise ValueError(
                f"the solution's {name} has shape {np.shape(v)}, not (·, {problem.n}): "
                f"its joint count differs from the problem's ({problem.n} joints)"
            )
    lim, worst = problem.limits, 0.0
    for q, qd in ((solution.q, solution.qd), (solution.q_mid, solution.qd_mid)):
        if q is None:
            continue
        if lim.q is not None:
            worst = max(worst, _violation(q, lim.q[:, 0], lim.q[:, 1]))
        if lim.qd is not None:
            worst = max(worst, _violation(qd, -lim.qd, lim.qd))
    if lim.tau is not None:
        for tau in (solution.tau, solution.tau_mid):
            worst = max(worst, _violation(tau, -lim.tau, lim.tau))
    return worst


def verify(
    robot: Robot,
    problem: Problem,
    solution: Solution,
    *,
    tol_q: float = 1e-2,
    tol_qd: float = 5e-2,
    tol_limits: float = 1e-6,
    substeps: int = 10,
    replay: str = "open-loop",
) -> Check:
    """Re-simulate with the reference dynamics and check the result and the limits: open loop
    from the start (the goal reached), or replay="intervals", each interval from the solution's
    node (every node reached: the check for arms whose open loop is unstable over the motion,
    where a tiny transcription error grows into a miss however right the trajectory).

    Returns:
        A `Check`; `check.ok` is the verdict, `check.describe()` says it in words.

    Raises:
        ValueError: an unknown replay, and those of `resimulate`.
        SingularInertia: M(q) is singular along the re-simulation (a `ValueError`).
    """
    if replay not in ("open-loop", "intervals"):
        raise ValueError(f"unknown replay {replay!r}: expected 'open-loop' or 'intervals'")
    _, q, qd = resimulate(robot, solution, substeps=substeps, restart=replay == "intervals")
    _, _, qf, qdf = problem.boundary()
    if problem.task is not None:  # the goal is a pose: the optimised end reaches it
        qf = solution.q[-1]
    return Check(
        success=solution.stats["success"],
        status=solution.stats["status"],
        goal_q_error=float(np.abs(q[-1] - qf).max()),
        goal_qd_error=float(np.abs(qd[-1] - qdf).max()),
        path_q_error=float(np.abs(q - solution.q).max()),
        path_qd_error=float(np.abs(qd - solution.qd).max()),
        limit_violation=limit_violation(problem, solution),
        tol_q=tol_q,
        tol_qd=tol_qd,
        tol_limits=tol_limits,
        replay=replay,
        q=q,
        qd=qd,
    )


# --------------------------------------------------------------------------- receding horizon


class Tracker:
    """Nonlinear MPC for trajectory tracking: one IPOPT problem built once, solved
    each sample period from the measured state, warm-started from the previous
    solution shifted by one interval (primal and dual).

    Direct multiple shooting over `horizon` intervals of the sample period `dt`
    (s), τ held over each interval, one semi-implicit Euler step of fdyn per interval
    (integrator="euler", the default: one fdyn evaluation) or one RK4 step ("rk4"); cost
    Σₖ (q−q_ref)ᵀW_q(q−q_ref) + (q̇−q̇_ref)ᵀW_qd(q̇−q̇_ref) + r‖τ/τ_max‖² over the
    horizon (τ_max = 1 N·m for a joint whose limit is inf);
    |τ| ≤ limits.tau and |q̇| ≤ limits.qd (and the joint limits) as bounds
    on the decision variables, the first state fixed to the measurement by its bounds.

    Raises:
        ValueError: limits without torque or speed limits (`Limits.tau`, `Limits.qd`),
            an unknown integrator, or dynamics without fdyn.
        RuntimeError: integrator "rk4" on compiled dynamics, and building the
            compiled interval fails (no C compiler, a failed build).  An IPOPT
            failure at a step does not raise: `control`'s stats say it.
    """

    def __init__(
        self,
        arm: ArmFunctions,
        limits: Limits,
        dt: float,
        horizon: int,
        *,
        w_q: float = 1e4,
        w_qd: float = 10.0,
        r: float = 1e-2,
        max_iter: int = 100,
        integrator: str = "euler",
        tol: float = 1e-4,
    ):
        n = arm.n
        if limits.tau is None or limits.qd is None:
            raise ValueError("the tracker needs torque and speed limits (Limits.tau and Limits.qd)")
        self.n, self.N, self.dt, self.limits = n, horizon, dt, limits
        N = horizon
        X, U, R = ca.MX.sym("X", 2 * n, N + 1), ca.MX.sym("U", n, N), ca.MX.sym("R", 2 * n, N + 1)
        fdyn = arm.need("multiple-shooting")
        if integrator == "rk4":  # the compiled interval when the dynamics are compiled
            qn, qdn = arm.shooting_step(1).map(N)(X[:n, :N], X[n:, :N], U, dt)
        elif integrator == "euler":  # semi-implicit: q̇⁺ = q̇ + h q̈, q⁺ = q + h q̇⁺ (one fdyn per interval)
            qdn = X[n:, :N] + dt * fdyn.map(N)(X[:n, :N], X[n:, :N], U)
            qn = X[:n, :N] + dt * qdn
        else:
            raise ValueError(f"unknown integrator {integrator!r}: expected 'euler' or 'rk4'")
        e = X - R
        W = ca.DM(np.r_[np.full(n, w_q), np.full(n, w_qd)])
        scale = ca.repmat(ca.DM(_finite_or_one(limits.tau, n)), 1, N)  # an unbounded joint: plain τ
        J = ca.sum2(ca.sum1(W * e[:, 1:] ** 2)) + r * ca.sumsqr(U / scale)
        g = ca.vertcat(ca.vec(X[:n, 1:] - qn), ca.vec(X[n:, 1:] - qdn))
        self._solver = ca.nlpsol(
            "mpc",
            "ipopt",
            {"x": ca.vertcat(ca.vec(X), ca.vec(U)), "p": ca.vec(R), "f": J, "g": g},
            {
                "print_time": False,
                "ipopt": {
                    "print_level": 0,
                    "sb": "yes",
                    "max_iter": max_iter,
                    "tol": tol,
                    "warm_start_init_point": "yes",
                    "mu_init": 1e-3,
                    "warm_start_bound_push": 1e-6,
                    "warm_start_mult_bound_push": 1e-6,
                },
            },
        )
        qlo, qhi = (np.full(n, -np.inf), np.full(n, np.inf)) if limits.q is None else limits.q.T
        xlo = np.tile(np.r_[qlo, -limits.qd], N + 1)
        self._lbx = np.r_[xlo, np.tile(-limits.tau, N)]
        self._ubx = np.r_[np.tile(np.r_[qhi, limits.qd], N + 1), np.tile(limits.tau, N)]
        self._nx = 2 * n * (N + 1)
        self._warm = None

    def control(self, x: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, dict]:
        """τ (n,) to apply now, from the measured state x = (q, q̇) (2n,) and the reference
        states over the horizon (N+1, 2n); and the solve's stats (wall and CPU time, s,
        IPOPT iterations, status, success)."""
        n, N = self.n, self.N
        lbx, ubx = self._lbx.copy(), self._ubx.copy()
        lbx[: 2 * n] = ubx[: 2 * n] = x
        args = dict(lbx=lbx, ubx=ubx, lbg=0, ubg=0, p=np.asarray(reference).T.ravel(order="F"))
        if self._warm is None:
            args["x0"] = np.r_[np.tile(x, N + 1), np.zeros(n * N)]
        else:
            args.update(self._warm)
        wall, cpu = time.perf_counter(), time.process_time()
        sol = self._solver(**args)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        st = self._solver.stats()
        w, lam_x, lam_g = (np.array(sol[k]).ravel() for k in ("x", "lam_x", "lam_g"))
        self._warm = dict(x0=self._shift(w), lam_x0=self._shift(lam_x), lam_g0=_shift_block(lam_g, n, N))
        tau = w[self._nx : self._nx + n]
        return tau, {
            "wall": wall,
            "cpu": cpu,
            "iterations": int(st["iter_count"]),
            "status": st["return_status"],
            "success": bool(st["success"]),
        }

    def _shift(self, w: np.ndarray) -> np.ndarray:
        """The decision vector one interval later: states and torques moved one column
        left, the last one repeated."""
        n, N = self.n, self.N
        X = w[: self._nx].reshape(N + 1, 2 * n)
        U = w[self._nx :].reshape(N, n)
        return np.r_[np.vstack([X[1:], X[-1:]]).ravel(), np.vstack([U[1:], U[-1:]]).ravel()]


def _shift_block(lam_g: np.ndarray, n: int, N: int) -> np.ndarray:
    """Constraint multipliers (q rows then q̇ rows, N columns each) shifted one interval."""
    q, qd = lam_g[: n * N].reshape(N, n), lam_g[n * N :].reshape(N, n)
    return np.r_[np.vstack([q[1:], q[-1:]]).ravel(), np.vstack([qd[1:], qd[-1:]]).ravel()]


def _tracking_step(arm: ArmFunctions, dt: float, integrator: str) -> ca.Function:
    """x⁺ = F(x, τ) (2n,) of the tracker's prediction: one semi-implicit Euler step of fdyn
    (q̇⁺ = q̇ + dt·q̈, q⁺ = q + dt·q̇⁺; one fdyn evaluation) or one RK4 step ("rk4", the
    compiled interval of `ArmFunctions.shooting_step` when the dynamics are compiled)."""
    n = arm.n
    fdyn = arm.need("multiple-shooting")
    x, u = ca.MX.sym("x", 2 * n), ca.MX.sym("tau", n)
    if integrator == "euler":
        qd = x[n:] + dt * fdyn(x[:n], x[n:], u)
        xn = ca.vertcat(x[:n] + dt * qd, qd)
    elif integrator == "rk4":
        xn = ca.vertcat(*arm.shooting_step(1)(x[:n], x[n:], u, dt))
    else:
        raise ValueError(f"unknown integrator {integrator!r}: expected 'euler' or 'rk4'")
    return ca.Function("step", [x, u], [xn], ["x", "tau"], ["x_next"])


class RTITracker:
    """Nonlinear MPC by the real-time iteration (Diehl, Bock & Schlöder 2005): one
    Gauss–Newton SQP step — one QP — per sample period instead of a converged NLP.

    The same problem as `Tracker` (multiple shooting over `horizon` intervals of `dt`,
    semi-implicit Euler on fdyn, cost Σₖ₌₁ᴺ eₖᵀW eₖ + r‖τ/τ_max‖², e = x − x_ref, |τ|, |q̇|
    and joint limits), split into the two phases of the scheme:

    - `prepare(reference)`, before the state is measured: linearise the prediction
      x⁺ = F(x, τ) around the shifted guess (x̄, ū) — one call of a compiled-fdyn
      Function that returns F, Aₖ = ∂F/∂x and Bₖ = ∂F/∂τ at all N intervals — and
      condense: with δx₀ the deviation of the measurement from x̄₀, the predicted
      deviations are δX = Φ δx₀ + Γ δU + c (Γ block lower triangular, Γₖⱼ = Aₖ⋯Aⱼ₊₁Bⱼ,
      c the propagated defects F(x̄ₖ, ūₖ) − x̄ₖ₊₁).  The Gauss–Newton Hessian of the cost,
      H = 2(ΓᵀWΓ + R), is exact for this least-squares cost up to the dynamics' curvature.
    - `feedback(x)`, when the state arrives: the QP in δU (n·N unknowns) — gradient
      and state-bound rows affine in δx₀ — solved by CasADi's `qpsol` (qpOASES by
      default, dense active set), then x̄, ū updated by the full step.

    `control(x, reference)` runs both and shifts the guess by one interval (the
    warm start of the next step).  The torque bounds are bounds of the QP's
    unknowns and hold exactly; the state bounds hold on the linearised prediction.
    Iterating `prepare`/`feedback` at a fixed x and reference is the Gauss–Newton SQP
    and converges to the NLP's solution (the one `Tracker` finds with IPOPT).

    Raises:
        ValueError: limits without torque or speed limits (`Limits.tau`, `Limits.qd`),
            an unknown integrator, or dynamics without fdyn.
        RuntimeError: a `qp` that is not one of CasADi's QP solver plugins
            (CasADi's error); integrator "rk4" on compiled dynamics, and building
            the compiled interval fails; later, `feedback` before `prepare`.
    """

    def __init__(
        self,
        arm: ArmFunctions,
        limits: Limits,
        dt: float,
        horizon: int,
        *,
        w_q: float = 1e4,
        w_qd: float = 10.0,
        r: float = 1e-2,
        integrator: str = "euler",
        qp: str = "qpoases",
    ):
        n = arm.n
        if limits.tau is None or limits.qd is None:
            raise ValueError("the tracker needs torque and speed limits (Limits.tau and Limits.qd)")
        self.n, self.N, self.dt, self.limits = n, horizon, dt, limits
        N, nx = horizon, 2 * n
        step = _tracking_step(arm, dt, integrator)
        x, u = ca.MX.sym("x", nx), ca.MX.sym("tau", n)
        xn = step(x, u)
        lin = ca.Function("lin", [x, u], [xn, ca.jacobian(xn, x), ca.jacobian(xn, u)])
        self._lin = lin.map(N)  # (nx, N), (nx, N) → F, [A₀ … ], [B₀ … ]
        self._W = np.tile(np.r_[np.full(n, w_q), np.full(n, w_qd)], N)  # (N·nx,)
        self._R = np.tile(r / _finite_or_one(limits.tau, n) ** 2, N)  # (N·n,)
        qlo, qhi = (np.full(n, -np.inf), np.full(n, np.inf)) if limits.q is None else np.asarray(limits.q, float).T
        xlo, xhi = np.tile(np.r_[qlo, -limits.qd], N), np.tile(np.r_[qhi, limits.qd], N)
        self._rows = np.flatnonzero(np.isfinite(xlo) | np.isfinite(xhi))  # bounded state rows
        self._xlo, self._xhi = xlo[self._rows], xhi[self._rows]
        self._ulo, self._uhi = np.tile(-limits.tau, N), np.tile(limits.tau, N)
        nu = n * N
        pattern = np.tril(np.kron(np.tril(np.ones((N, N))), np.ones((nx, n))))[self._rows]
        a_sp = ca.DM(pattern).sparsity()
        opts = {"print_problem": False, "print_time": False, "error_on_fail": False}
        if qp == "qpoases":
            opts.update(printLevel="none", sparse=False)
        elif qp == "osqp":
            opts.update(
                warm_start_primal=True,
                osqp={"verbose": False, "eps_abs": 1e-7, "eps_rel": 1e-7, "polish": True, "max_iter": 10000},
            )
        self.qp_solver = qp
        self._qp = ca.conic("rti_qp", qp, {"h": ca.Sparsity.dense(nu, nu), "a": a_sp}, opts)
        self._X = self._U = None
        self._prep = None

    @property
    def prediction(self) -> tuple[np.ndarray, np.ndarray]:
        """The current guess: states (N+1, 2n) and torques (N, n) over the horizon
        (after `feedback`, the QP's solution; after `control`, shifted one interval)."""
        return self._X.copy(), self._U.copy()

    # ---------------------------------------------------------------- the two phases

    def prepare(self, reference: np.ndarray) -> float:
        """Linearise around the current guess and condense the QP, given the reference
        states over the horizon (N+1, 2n); returns the wall time (s).  Call before the
        measurement (the guess is the previous solution shifted, or at rest at the
        reference's first state on the first call)."""
        start = time.perf_counter()
        n, N, nx = self.n, self.N, 2 * self.n
        ref = np.asarray(reference, float)
        if self._X is None:
            self._X = np.tile(ref[0], (N + 1, 1))
            self._U = np.zeros((N, n))
        F, A, B = (np.array(v) for v in self._lin(self._X[:-1].T, self._U.T))
        A = A.reshape(nx, N, nx).transpose(1, 0, 2)  # (N, nx, nx)
        B = B.reshape(nx, N, n).transpose(1, 0, 2)  # (N, nx, n)
        d = F.T - self._X[1:]  # defects (N, nx)
        G = np.zeros((N * nx, N * n))
        Phi = np.zeros((N * nx, nx))
        c = np.zeros(N * nx)
        prev = slice(0, 0)
        for k in range(N):
            rows = slice(k * nx, (k + 1) * nx)
            if k == 0:
                Phi[rows], c[rows] = A[0], d[0]
            else:
                G[rows, : k * n] = A[k] @ G[prev, : k * n]
                Phi[rows], c[rows] = A[k] @ Phi[prev], A[k] @ c[prev] + d[k]
            G[rows, k * n : (k + 1) * n] = B[k]
            prev = rows
        e = (self._X[1:] - ref[1:]).ravel() + c  # deviation from the reference at δx₀ = 0, δU = 0
        WG = self._W[:, None] * G
        u = self._U.ravel()
        self._prep = dict(
            H=2 * (G.T @ WG + np.diag(self._R)),
            g0=2 * (WG.T @ e + self._R * u),
            g1=2 * WG.T @ Phi,
            A=G[self._rows],
            a0=self._X[1:].ravel()[self._rows] + c[self._rows],
            a1=Phi[self._rows],
            lbx=self._ulo - u,
            ubx=self._uhi - u,
            G=G,
            Phi=Phi,
            c=c,
        )
        return time.perf_counter() - start

    def feedback(self, x: np.ndarray) -> tuple[np.ndarray, dict]:
        """Solve the prepared QP for the measured state x = (q, q̇) (2n,) and take the full
        step; τ (n,) to apply now, and stats (feedback wall and CPU time, s; QP status)."""
        if self._prep is None:
            raise RuntimeError("feedback() needs prepare(reference) first")
        wall, cpu = time.perf_counter(), time.process_time()
        p, n = self._prep, self.n
        dx0 = np.asarray(x, float) - self._X[0]
        xs = p["a0"] + p["a1"] @ dx0  # bounded states at δU = 0
        sol = self._qp(
            h=p["H"],
            g=p["g0"] + p["g1"] @ dx0,
            a=p["A"],
            lba=self._xlo - xs,
            uba=self._xhi - xs,
            lbx=p["lbx"],
            ubx=p["ubx"],
        )
        du = np.array(sol["x"]).ravel()
        st = self._qp.stats()
        U = self._U + du.reshape(self.N, n)
        self._U = np.clip(U, -self.limits.tau, self.limits.tau)  # the QP's bounds, exactly
        self._X = self._rollout(np.asarray(x, float), dx0, du)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        return self._U[0].copy(), {
            "feedback": wall,
            "feedback_cpu": cpu,
            "success": bool(st["success"]),
            "status": str(st.get("return_status", "")),
        }

    def _rollout(self, x: np.ndarray, dx0: np.ndarray, du: np.ndarray) -> np.ndarray:
        """The new state guess (N+1, 2n): the measurement, then x̄ + δX of the linearised
        prediction δX = Φ δx₀ + Γ δU + c (no further fdyn call)."""
        p = self._prep
        dX = p["G"] @ du + p["Phi"] @ dx0 + p["c"]
        return np.vstack([x, self._X[1:] + dX.reshape(self.N, 2 * self.n)])

    def control(self, x: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, dict]:
        """One real-time iteration: prepare (linearise, condense), feedback (one QP) from
        the measured state x (2n,) and the reference states (N+1, 2n), then shift the
        guess one interval.  Stats: preparation and feedback wall time (s), their sum
        `wall`, CPU time, QP success."""
        cpu = time.process_time()
        prep = self.prepare(reference)
        tau, st = self.feedback(x)
        self.shift()
        st.update(prepare=prep, wall=prep + st["feedback"], cpu=time.process_time() - cpu, iterations=1)
        return tau, st

    def shift(self) -> None:
        """Move the guess one interval later: states and torques one step left, the last
        state and torque repeated."""
        self._X = np.vstack([self._X[1:], self._X[-1:]])
        self._U = np.vstack([self._U[1:], self._U[-1:]])
