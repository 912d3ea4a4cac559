"""Receding horizon: a trajectory tracked by re-solving a short problem at each step (`Tracker`)
or by one SQP step with a warm start (`RTITracker`, real-time iteration)."""

from __future__ import annotations

import time

import casadi as ca
import numpy as np
from .functions import ArmFunctions
from .problem import Limits, _finite_or_one


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
