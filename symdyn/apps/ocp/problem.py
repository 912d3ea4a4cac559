"""What an optimal-control problem says: boundary states, time, grid and transcription (`Problem`),
box `Limits`, the `Cost`; and what a solve returns (`Solution`)."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ...model import Robot

METHODS = ("multiple-shooting", "trapezoidal", "hermite-simpson")


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
            NaN one: `Limits`); cost weights that are not n entries; task_costs that are
            not a tuple of `FrameCost` terms, or a task or cost on another robot's frames; `unactuated`
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
    #: Task-space cost terms (`symdyn.apps.ocp_task.FrameCost`): a frame's distance from a target
    #: pose, position or path, along the motion or at its end, added to the cost.
    task_costs: tuple = ()
    #: Whether the end configuration is free: qf then only ends the starting guess, and the end is
    #: what the cost makes it (a `FrameCost` at the end: a soft task-space goal; a `task` frees it too).
    free_end: bool = False

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
        if not isinstance(self.task_costs, (tuple, list)) or not all(
            callable(getattr(c, "cost", None)) for c in self.task_costs
        ):
            raise ValueError(f"task_costs must be a tuple of FrameCost terms, got {self.task_costs!r}")
        object.__setattr__(self, "task_costs", tuple(self.task_costs))
        for term in (self.task, *self.task_costs):
            pose = getattr(term, "frame_pose", None)
            if pose is not None and pose.numel_in(0) != n:
                raise ValueError(
                    f"{type(term).__name__}'s frame_pose takes q of {pose.numel_in(0)}, the problem's q0 has {n}: "
                    "build it on the problem's robot"
                )
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
