"""Excitation design: a periodic joint trajectory that makes the base parameters well determined.

The identification pipeline's first step.  Each joint follows a finite
Fourier series (Swevers, Ganseman, Tükel, De Schutter & Van Brussel, IEEE
T-RA 1997), with ω = 2π/T and harmonics l = 1 … L:

    q_i(t)  = q0_i + Σ_l  a_il/(ωl)·sin(ωlt) − b_il/(ωl)·cos(ωlt)
    q̇_i(t)  =        Σ_l  a_il·cos(ωlt) + b_il·sin(ωlt)
    q̈_i(t)  =        Σ_l  ωl·(−a_il·sin(ωlt) + b_il·cos(ωlt))

periodic by construction, at rest at t = 0 and t = T (Σ_l a_il = 0 and
Σ_l l·b_il = 0: q̇ = q̈ = 0 there).  The coefficients are optimised with
CasADi (IPOPT) on the generated base regressor — the model's CasADi `Y`
restricted to the base columns of `base_parameters` — stacked over a grid
of the period: the criterion is log cond(W) ("cond", the default) or
−log det(WᵀW) ("logdet", D-optimal), spectral functions whose gradient
comes from the eigenvectors of the small Gram matrix WᵀW (∂λ/∂W = 2 W v vᵀ),
pulled back through W(x) by one reverse-mode sweep of CasADi; IPOPT runs
with a limited-memory Hessian and stops once the criterion stagnates (the
condition number is not smooth where its extreme singular values cross).
"cond" is the default: it is what the fit reports and what the issue asks,
and it reaches a 2–4× lower condition number than the D-optimal design
(which is 4–8× faster and gives the larger determinant).  Constraints: joint positions, speeds and accelerations on a
grid dense enough that the sinusoids cannot overshoot the 1 % margin
between grid points; torques (the model's CasADi τ) on the design grid with
a margin, checked afterwards on a fine grid and tightened if needed.
"""

from __future__ import annotations

import json
import math
import numbers
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..model import Robot

if TYPE_CHECKING:
    from ..codegen.entry import GeneratedModel

__all__ = ["excitation", "Excitation", "ExcitationLimits", "CRITERIA", "configure_parser", "run_cli"]

CRITERIA = ("cond", "logdet")
#: Defaults where the model has no limit: speed rad/s (m/s), acceleration rad/s² (m/s²).
DEFAULT_QD = (2.0, 0.5)
DEFAULT_QDD = (10.0, 2.0)
#: Limits are posed this much inside the model's (position: of the range, each side).
MARGIN = 0.01
PRINT = 0


@dataclass(frozen=True)
class ExcitationLimits:
    """Per joint: q (n, 2) lower/upper, qd (n,), qdd (n,), tau (n,) (inf: unbounded)."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray

    @classmethod
    def for_robot(cls, robot: Robot, *, q=None, qd=None, qdd=None, tau=None) -> "ExcitationLimits":
        """The model's limits (`symdyn.apps.ocp.Limits.for_robot`: its qlim, URDF velocity and
        effort) where present, else DEFAULT_QD and DEFAULT_QDD for speed and acceleration and
        no torque limit; any of them given overrides."""
        from ..apps.ocp import Limits

        model = Limits.for_robot(robot)
        revolute = np.array([link.is_revolute for link in robot.links])

        def pick(given, have, default):
            if given is not None:
                return np.broadcast_to(np.asarray(given, dtype=float), (robot.n,)).copy()
            out = np.where(revolute, default[0], default[1]) if have is None else np.asarray(have, float).copy()
            if have is not None:
                out[~np.isfinite(out)] = np.where(revolute, default[0], default[1])[~np.isfinite(out)]
            return out

        qlim = np.asarray(q if q is not None else model.q, dtype=float).reshape(robot.n, 2)
        return cls(
            q=qlim,
            qd=pick(qd, model.qd, DEFAULT_QD),
            qdd=pick(qdd, None, DEFAULT_QDD),
            tau=(
                np.broadcast_to(np.asarray(tau, float), (robot.n,)).copy()
                if tau is not None
                else np.full(robot.n, np.inf)
                if model.tau is None
                else np.asarray(model.tau, float)
            ),
        )

    def as_dict(self) -> dict:
        return {k: np.asarray(getattr(self, k)).tolist() for k in ("q", "qd", "qdd", "tau")}


def _basis(t: np.ndarray, period: float, harmonics: int):
    """(Bq, Bqd, Bqdd), each (len(t), 2L): the rows that map [a_1…a_L, b_1…b_L] of a joint
    to its q − q0, q̇, q̈ at times t."""
    w = 2 * math.pi / period
    l = np.arange(1, harmonics + 1)
    s, c = np.sin(w * np.outer(t, l)), np.cos(w * np.outer(t, l))
    Bq = np.hstack([s / (w * l), -c / (w * l)])
    Bqd = np.hstack([c, s])
    Bqdd = np.hstack([-s * w * l, c * w * l])
    return Bq, Bqd, Bqdd


@dataclass(frozen=True)
class Excitation:
    """An optimised excitation trajectory (module docstring).

    a, b: (n, L) Fourier coefficients (rad/s or m/s); q0: (n,) offsets; condition:
    the condition number of the stacked base regressor on the design grid (`samples`
    points of one period); logdet: log det(WᵀW) there; random_condition,
    random_logdet: the same for the random start of the same family (its
    coefficients `start`); limits: those that were posed.
    """

    robot: str
    period: float
    harmonics: int
    a: np.ndarray
    b: np.ndarray
    q0: np.ndarray
    criterion: str
    condition: float
    logdet: float
    random_condition: float
    random_logdet: float
    samples: int
    limits: ExcitationLimits
    start: tuple
    seconds: float
    iterations: int
    status: str
    base_names: tuple = field(default=())
    peak_torque: np.ndarray | None = None

    @property
    def n(self) -> int:
        return len(self.q0)

    def sample(self, rate: float, periods: int = 1):
        """(t, q, qd, qdd) at `rate` Hz over `periods` periods, both ends included:
        t (N,), q, qd, qdd (N, n)."""
        if not rate > 0:
            raise ValueError(f"the sample rate must be positive, got {rate}")
        count = int(round(self.period * periods * rate))
        t = np.linspace(0.0, self.period * periods, count + 1)
        return (t, *self.at(t))

    def at(self, t):
        """q, qd, qdd (len(t), n) at times t (s)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        Bq, Bqd, Bqdd = _basis(t, self.period, self.harmonics)
        ab = np.hstack([self.a, self.b]).T  # (2L, n)
        return self.q0 + Bq @ ab, Bqd @ ab, Bqdd @ ab

    def to_dict(self) -> dict:
        return {
            "robot": self.robot,
            "period": self.period,
            "harmonics": self.harmonics,
            "criterion": self.criterion,
            "a": self.a.tolist(),
            "b": self.b.tolist(),
            "q0": self.q0.tolist(),
            "condition": self.condition,
            "logdet": self.logdet,
            "random_condition": self.random_condition,
            "random_logdet": self.random_logdet,
            "design_samples": self.samples,
            "limits": self.limits.as_dict(),
            "seconds": self.seconds,
            "iterations": self.iterations,
            "status": self.status,
            "base_parameters": list(self.base_names),
            "peak_torque": None if self.peak_torque is None else self.peak_torque.tolist(),
        }

    def write(self, out_dir, rate: float = 100.0) -> list[Path]:
        """excitation.csv (t, q1…qn, qd1…qdn, qdd1…qddn at `rate` Hz, one period),
        excitation.json (coefficients, condition numbers, limits) and, with matplotlib,
        excitation.png.  Returns the paths written."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        t, q, qd, qdd = self.sample(rate)
        n = self.n
        header = (
            ["t"]
            + [f"q{i + 1}" for i in range(n)]
            + [f"qd{i + 1}" for i in range(n)]
            + [f"qdd{i + 1}" for i in range(n)]
        )
        paths = [out / "excitation.csv", out / "excitation.json"]
        _atomic(
            paths[0],
            ",".join(header)
            + "\n"
            + "\n".join(",".join(f"{x:.17g}" for x in row) for row in np.column_stack([t, q, qd, qdd]))
            + "\n",
        )
        _atomic(paths[1], json.dumps(self.to_dict(), indent=1) + "\n")
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            return paths
        fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
        for ax, y, label in zip(axes, (q, qd, qdd), ("q (rad, m)", "q̇ (/s)", "q̈ (/s²)")):
            for i in range(n):
                ax.plot(t, y[:, i], label=f"joint {i + 1}")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        axes[0].legend(fontsize=7, ncol=min(n, 4))
        axes[-1].set_xlabel("t (s)")
        fig.suptitle(
            f"{self.robot}: excitation, {self.harmonics} harmonics, T = {self.period:g} s\n"
            f"cond {self.condition:.4g} (random start of the family {self.random_condition:.4g}), "
            f"criterion {self.criterion}",
            fontsize=10,
        )
        fig.tight_layout()
        paths.append(out / "excitation.png")
        fig.savefig(paths[-1], dpi=120)
        plt.close(fig)
        return paths


def _atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)


# --------------------------------------------------------------------------- the optimisation


def _spectral(W: np.ndarray, criterion: str):
    """The criterion and its gradient with respect to W, from the eigenvalues λ = σ² of the
    small Gram matrix WᵀW (a tall SVD costs ten times more where BLAS threads compete for cores)."""
    lam, V = np.linalg.eigh(W.T @ W)
    if lam[0] <= 0:
        return np.inf, np.zeros_like(W)
    if criterion == "cond":  # log σ_max − log σ_min; ∂λ/∂W = 2 W v vᵀ
        f = 0.5 * (math.log(lam[-1]) - math.log(lam[0]))
        G = W @ (np.outer(V[:, -1], V[:, -1]) / lam[-1] - np.outer(V[:, 0], V[:, 0]) / lam[0])
    else:  # −log det(WᵀW) per parameter
        p = len(lam)
        f = -float(np.sum(np.log(lam))) / p
        G = -2 * W @ ((V / lam) @ V.T) / p
    return f, G


def _criterion_callbacks(Wf, Wrev, nx: int, criterion: str):
    """A CasADi Callback for the criterion with its gradient (a second Callback)."""
    import casadi as ca

    cache: dict = {}

    def value_and_gradient(x: np.ndarray):
        key = x.tobytes()
        if key not in cache:
            W = np.asarray(Wf(x))
            f, G = _spectral(W, criterion)
            grad = np.asarray(Wrev(x, W, G)).ravel() if np.isfinite(f) else np.zeros(nx)
            cache.clear()
            cache[key] = (f, grad)
        return cache[key]

    class Gradient(ca.Callback):
        def __init__(self, name, opts):
            ca.Callback.__init__(self)
            self.construct(name, opts)

        def get_n_in(self):
            return 2

        def get_n_out(self):
            return 1

        def get_sparsity_in(self, i):
            return ca.Sparsity.dense(nx, 1) if i == 0 else ca.Sparsity.dense(1, 1)

        def get_sparsity_out(self, i):
            return ca.Sparsity.dense(1, nx)

        def eval(self, arg):
            return [ca.DM(value_and_gradient(np.asarray(arg[0], dtype=float).ravel())[1]).T]

    class Criterion(ca.Callback):
        def __init__(self, name):
            ca.Callback.__init__(self)
            self.construct(name, {})

        def get_n_in(self):
            return 1

        def get_n_out(self):
            return 1

        def get_sparsity_in(self, i):
            return ca.Sparsity.dense(nx, 1)

        def get_sparsity_out(self, i):
            return ca.Sparsity.dense(1, 1)

        def eval(self, arg):
            return [value_and_gradient(np.asarray(arg[0], dtype=float).ravel())[0]]

        def has_jacobian(self):
            return True

        def get_jacobian(self, name, inames, onames, opts):
            self.gradient = Gradient(name, opts)  # kept alive with its owner
            return self.gradient

    return Criterion("excitation_criterion")


def _lift(B: np.ndarray, n: int, L: int, offset: bool):
    """The sparse (n·K × nx) matrix taking x = [a_1 b_1 (joint 1), …, a_n b_n, q0] to the K×n
    values B·[a_i; b_i] (+ q0_i where `offset`), time-major: row k·n + i."""
    import casadi as ca

    K = B.shape[0]
    rows, cols, vals = [], [], []
    for k in range(K):
        for i in range(n):
            rows += [k * n + i] * (2 * L)
            cols += list(range(i * 2 * L, (i + 1) * 2 * L))
            vals += list(B[k])
            if offset:
                rows.append(k * n + i)
                cols.append(2 * L * n + i)
                vals.append(1.0)
    return ca.DM.triplet(rows, cols, ca.DM(vals), K * n, 2 * L * n + n)


def _rest_projection(n: int, L: int) -> np.ndarray:
    """A (2L × 2L) projector onto the coefficients of one joint that start and end at rest."""
    C = np.zeros((2, 2 * L))
    C[0, :L] = 1.0  # Σ a_l = 0: q̇(0) = 0
    C[1, L:] = np.arange(1, L + 1)  # Σ l b_l = 0: q̈(0) = 0
    return np.eye(2 * L) - np.linalg.pinv(C) @ C


def excitation(
    robot: Robot,
    period: float = 10.0,
    harmonics: int = 5,
    *,
    criterion: str = "cond",
    rate: float | None = None,
    seed: int = 0,
    limits: ExcitationLimits | None = None,
    max_iter: int = 200,
    model: GeneratedModel | None = None,
) -> Excitation:
    """An optimised periodic excitation of `robot` (module docstring).

    period: T (s); harmonics: L; criterion: "cond" (log condition number of the stacked
    base regressor, the default) or "logdet" (D-optimal); rate: the design grid in Hz, on
    which the criterion and the torque limits are evaluated (default: max(10L, 3⌈p/n⌉)
    samples of one period, p base parameters, n joints); seed: the random start; limits: an
    `ExcitationLimits` (default `ExcitationLimits.for_robot(robot)`); max_iter: IPOPT's
    iteration limit; model: the CasADi
    model (`symdyn.load(robot, "casadi")`) when at hand.

    Returns:
        The `Excitation`: its Fourier coefficients, offsets and design record
        (`sample`, `at`, `write`).

    Raises:
        ValueError: an unknown criterion; a period that is not positive; harmonics
            not an integer ≥ 2; a rate that is not a positive finite number (or gives
            no sample in a period); a symbolic robot; torque limits that even a small
            motion about the middle of the joint ranges exceeds.
        RuntimeError: the optimised excitation's torques exceed the limits between
            design samples even with a 30 % margin (raise `rate`).
    """
    import casadi as ca

    from ..codegen.entry import load
    from .consistent import _base

    if criterion not in CRITERIA:
        raise ValueError(f"unknown criterion {criterion!r}: expected one of {CRITERIA}")
    if not period > 0:
        raise ValueError(f"the period must be positive, got {period}")
    if not (isinstance(harmonics, (int, np.integer)) and harmonics >= 2):
        raise ValueError(f"harmonics must be an integer ≥ 2 (rest at both ends takes two), got {harmonics!r}")
    if rate is not None:  # None: the default grid; 0 is no rate, not the default
        if isinstance(rate, bool) or not isinstance(rate, numbers.Real) or not (math.isfinite(rate) and rate > 0):
            raise ValueError(
                f"rate must be a positive, finite sample rate in Hz (or None for the default), got {rate!r}"
            )
        if round(period * rate) < 1:
            raise ValueError(f"rate={rate!r} Hz gives no design sample in a period of {period} s")
    robot.require_numeric("excitation design")
    robot.require_fixed_base("excitation design")
    start_time = time.perf_counter()
    n, L = robot.n, int(harmonics)
    limits = limits or ExcitationLimits.for_robot(robot)
    base = _base(robot)
    cols = list(base.independent)
    p = len(cols)
    model = model or load(robot, "casadi")
    Yfun, taufun = model.functions["Y"], model.functions["tau"]

    # default: 10 samples per period of the highest harmonic, ≥ 3 rows per base parameter (the
    # Panda's condition number on this grid, 34.2, is 33.9 on a 100 Hz grid; 100 samples cost twice)
    K = int(round(period * rate)) if rate is not None else max(10 * L, 3 * -(-p // n))
    t = np.arange(K) * period / K
    Bq, Bqd, Bqdd = _basis(t, period, L)
    Kd = 40 * L  # dense grid of the linear limits: a harmonic overshoots its samples by < 0.4 %
    td = np.arange(Kd) * period / Kd
    Dq, Dqd, Dqdd = _basis(td, period, L)

    # x = [coefficients of joint 1 (a_1…a_L, b_1…b_L), …, joint n, q0 (n)]
    nx = 2 * L * n + n
    x = ca.MX.sym("x", nx)
    # every linear map of x as one sparse constant matrix (rows time-major: k·n + i), so that the
    # constraint Jacobian is a constant IPOPT gets at the cost of a copy, not of an AD sweep
    Aq, Aqd, Aqdd = (_lift(B, n, L, q0) for B, q0 in ((Bq, True), (Bqd, False), (Bqdd, False)))
    Q, QD, QDD = (ca.reshape(ca.mtimes(A, x), n, K) for A in (Aq, Aqd, Aqdd))
    Yall = Yfun.map(K)(Q, QD, QDD)  # n × (14n·K)
    per = Yfun.size2_out(0)
    W = ca.vertcat(*(Yall[:, [k * per + c for c in cols]] for k in range(K)))
    Wf = ca.Function("W", [x], [W])
    Wrev = Wf.reverse(1)
    tau = taufun.map(K)(Q, QD, QDD)  # n × K

    crit = _criterion_callbacks(Wf, Wrev, nx, criterion)

    # linear limits on the dense grid, rest at both ends; torques on the design grid
    lo, hi = limits.q[:, 0], limits.q[:, 1]
    span = hi - lo
    qlo, qhi = lo + MARGIN * span, hi - MARGIN * span
    rest = np.zeros((2 * n, nx))
    for i in range(n):
        rest[i, i * 2 * L : i * 2 * L + L] = 1.0  # Σ a_l = 0
        rest[n + i, i * 2 * L + L : (i + 1) * 2 * L] = np.arange(1, L + 1)  # Σ l b_l = 0
    linear = [_lift(D, n, L, q0) for D, q0 in ((Dq, True), (Dqd, False), (Dqdd, False))] + [ca.DM(rest)]
    g_parts = [ca.mtimes(ca.vertcat(*linear), x)]
    lbg = [
        np.concatenate(
            [
                np.tile(qlo, Kd),
                np.tile(-limits.qd * (1 - MARGIN), Kd),
                np.tile(-limits.qdd * (1 - MARGIN), Kd),
                np.zeros(2 * n),
            ]
        )
    ]
    ubg = [
        np.concatenate(
            [
                np.tile(qhi, Kd),
                np.tile(limits.qd * (1 - MARGIN), Kd),
                np.tile(limits.qdd * (1 - MARGIN), Kd),
                np.zeros(2 * n),
            ]
        )
    ]
    bounded = np.isfinite(limits.tau)
    tauf = ca.Function("tau", [x], [tau])

    # the random start of the family: rest-projected, scaled inside every limit
    rng = np.random.default_rng(seed)
    proj = _rest_projection(n, L)
    coef = np.column_stack(
        [proj @ (rng.standard_normal(2 * L) / np.r_[np.arange(1, L + 1), np.arange(1, L + 1)]) for _ in range(n)]
    )  # (2L, n)
    mid = np.clip((qlo + qhi) / 2, qlo, qhi)
    dq, dqd, dqdd = Dq @ coef, Dqd @ coef, Dqdd @ coef
    room = np.minimum(qhi - mid, mid - qlo)
    scale = 0.8 * min(
        np.min(room / np.maximum(np.abs(dq).max(0), 1e-12)),
        np.min(limits.qd / np.maximum(np.abs(dqd).max(0), 1e-12)),
        np.min(limits.qdd / np.maximum(np.abs(dqdd).max(0), 1e-12)),
    )

    def pack(c, qm):
        return np.r_[c.ravel("F"), qm]

    x_start = pack(scale * coef, mid)
    for _ in range(30):  # torques inside their limits (gravity alone may need a smaller motion)
        peak = np.abs(np.asarray(tauf(x_start))).max(1)
        if np.all(peak <= 0.9 * limits.tau):
            break
        x_start = pack(0.7 * x_start[: 2 * L * n].reshape(2 * L, n, order="F"), mid)
    else:
        raise ValueError(
            f"{robot.name}: even a small motion about the middle of the joint ranges needs more than "
            f"90 % of the torque limits {limits.tau.tolist()}: give larger limits"
        )

    def measure(xv):
        W = np.asarray(Wf(xv))
        lam = np.linalg.eigvalsh(W.T @ W)
        return (
            float(np.sqrt(lam[-1] / lam[0])) if lam[0] > 0 else np.inf,
            float(np.sum(np.log(np.maximum(lam, 1e-300)))),
        )

    random_condition, random_logdet = measure(x_start)

    fine = np.linspace(0, period, 20 * K + 1)  # the torque check after the solve
    Fq, Fqd, Fqdd = _basis(fine, period, L)
    tau_fine = taufun.map(len(fine))

    def peak_torque(xv):
        c = xv[: 2 * L * n].reshape(2 * L, n, order="F")
        return np.abs(np.asarray(tau_fine((Fq @ c + xv[2 * L * n :]).T, (Fqd @ c).T, (Fqdd @ c).T))).max(1)

    # "cond" from the D-optimal design instead of the random start was measured: no faster
    # (Panda 216 against 200 iterations, Puma 91 against 31), so one stage
    stages = (criterion,)
    crits = {criterion: crit}
    tighten, xv, iterations, statuses = 0.95, x_start, 0, []
    for _ in range(4):
        g = ca.vertcat(*g_parts, *([ca.vec(tau[np.nonzero(bounded)[0].tolist(), :])] if bounded.any() else []))
        lb, ub = list(lbg), list(ubg)
        if bounded.any():
            lim = np.tile(tighten * limits.tau[bounded], K)
            lb.append(-lim)
            ub.append(lim)
        xv, iterations, statuses = x_start, 0, []
        for stage in stages:
            solver = ca.nlpsol(
                "excitation",
                "ipopt",
                {"x": x, "f": crits[stage](x), "g": g},
                {
                    "ipopt.print_level": PRINT,
                    "print_time": False,
                    "ipopt.sb": "yes",
                    "ipopt.hessian_approximation": "limited-memory",
                    "ipopt.max_iter": max_iter,
                    "ipopt.tol": 1e-6,
                    "show_eval_warnings": False,
                    # the condition number is not smooth (its extreme σ trade places): stop
                    # once it stagnates rather than let the line search crawl
                    "ipopt.acceptable_tol": 1e20,
                    "ipopt.acceptable_constr_viol_tol": 1e-9,
                    "ipopt.acceptable_obj_change_tol": 1e-3,
                    "ipopt.acceptable_iter": 8,
                },
            )
            sol = solver(x0=xv, lbg=np.concatenate(lb), ubg=np.concatenate(ub))
            stats = solver.stats()
            iterations += int(stats.get("iter_count", 0))
            statuses.append(f"{stage}: {stats.get('return_status', '')}")
            xv = np.asarray(sol["x"], dtype=float).ravel()
        peak = peak_torque(xv)
        if np.all(peak[bounded] <= limits.tau[bounded]):
            break
        tighten *= 0.9
    else:
        raise RuntimeError(
            f"{robot.name}: the excitation's torques exceed the limits between design samples "
            "even with a 30 % margin: raise rate="
        )
    if not _feasible(xv, limits, period, L, n):
        xv = x_start  # IPOPT gave up outside the limits: the random start is the best feasible point known
    condition, logdet = measure(xv)
    if condition > random_condition:
        xv, (condition, logdet) = x_start, (random_condition, random_logdet)
    coef = xv[: 2 * L * n].reshape(2 * L, n, order="F")
    return Excitation(
        robot=robot.name,
        period=float(period),
        harmonics=L,
        a=coef[:L].T.copy(),
        b=coef[L:].T.copy(),
        q0=xv[2 * L * n :].copy(),
        criterion=criterion,
        condition=condition,
        logdet=logdet,
        random_condition=random_condition,
        random_logdet=random_logdet,
        samples=K,
        limits=limits,
        start=(
            x_start[: 2 * L * n].reshape(2 * L, n, order="F")[:L].T.copy(),
            x_start[: 2 * L * n].reshape(2 * L, n, order="F")[L:].T.copy(),
            x_start[2 * L * n :].copy(),
        ),
        seconds=time.perf_counter() - start_time,
        iterations=iterations,
        status="; ".join(statuses),
        base_names=tuple(str(base.params[c]) for c in cols),
        peak_torque=peak_torque(xv),
    )


def _feasible(xv, limits: ExcitationLimits, period: float, L: int, n: int) -> bool:
    """Whether the position, speed and acceleration limits hold on a fine grid."""
    t = np.linspace(0, period, 200 * L + 1)
    Bq, Bqd, Bqdd = _basis(t, period, L)
    c = xv[: 2 * L * n].reshape(2 * L, n, order="F")
    q, qd, qdd = Bq @ c + xv[2 * L * n :], Bqd @ c, Bqdd @ c
    return bool(
        np.all(q >= limits.q[:, 0])
        and np.all(q <= limits.q[:, 1])
        and np.all(np.abs(qd) <= limits.qd)
        and np.all(np.abs(qdd) <= limits.qdd)
    )


# --------------------------------------------------------------------------- command line


def configure_parser(p) -> None:
    """`symdyn identify excite MODEL --period 10 --harmonics 5 --out DIR`."""
    from ..model.command_line import add_arguments

    add_arguments(p)
    p.add_argument("--period", type=float, default=10.0, help="the trajectory's period T in s (default 10)")
    p.add_argument("--harmonics", type=int, default=5, help="Fourier harmonics per joint (default 5)")
    p.add_argument(
        "--criterion",
        choices=CRITERIA,
        default="cond",
        help="cond: the base regressor's condition number (default); logdet: D-optimal",
    )
    p.add_argument("--rate", type=float, default=100.0, help="the CSV's sample rate in Hz (default 100)")
    p.add_argument(
        "--design-rate",
        type=float,
        default=None,
        help="the optimisation grid in Hz (default: enough for the harmonics and the parameters)",
    )
    p.add_argument("--seed", type=int, default=0, help="the random start (default 0)")
    p.add_argument("--max-iter", type=int, default=200, help="IPOPT's iteration limit (default 200)")
    p.add_argument("--out", required=True, help="folder for excitation.csv, excitation.json, excitation.png")


def run_cli(args) -> int:
    """Design the excitation the parsed `args` ask for, write it, print a summary."""
    from ..model.command_line import from_args

    robot = from_args(args)
    exc = excitation(
        robot,
        period=args.period,
        harmonics=args.harmonics,
        criterion=args.criterion,
        rate=args.design_rate,
        seed=args.seed,
        max_iter=args.max_iter,
    )
    paths = exc.write(args.out, rate=args.rate)
    print(
        f"{robot.name}: {exc.harmonics} harmonics, period {exc.period:g} s, criterion {exc.criterion}: "
        f"condition number {exc.condition:.4g} (random start of the same family {exc.random_condition:.4g}), "
        f"{exc.iterations} iterations, {exc.seconds:.1f} s ({exc.status})"
    )
    for path in paths:
        print(f"wrote {path}")
    return 0
