"""A `Problem` posed with `casadi.Opti` — direct multiple shooting (RK4 on fdyn) or collocation
(trapezoidal, Hermite–Simpson: τ = ID(q, q̇, q̈) imposed) — and solved by IPOPT (`solve`)."""

from __future__ import annotations

import time

import casadi as ca
import numpy as np
from .functions import ArmFunctions
from .problem import Limits, Problem, Solution, _finite_or_one


class OCPError(RuntimeError):
    """IPOPT found no solution; `status` is IPOPT's return status."""

    def __init__(self, message: str, status: str, iterations: int):
        super().__init__(message)
        self.status = status
        self.iterations = iterations


def _quadratic_smoothness(a, b, c, h):
    """∫₀ʰ (dτ/dt)² dt, per joint, of the quadratic through a, b, c at 0, h/2, h."""
    A = (-3 * a + 4 * b - c) / h
    B = (4 * a - 8 * b + 4 * c) / h**2
    return A**2 * h + A * B * h**2 + B**2 * h**3 / 3


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
    if problem.task is not None:  # the frame's end pose, and the obstacles cleared at every node
        problem.task.constrain(opti, Q)
    elif not problem.free_end:
        opti.subject_to(Q[:, N] == qf)
    _bound_states(opti, lim, Q, QD)
    handles = {"Q": Q, "QD": QD, "T": T}
    pose = _multiple_shooting if problem.method == "multiple-shooting" else _collocation
    task = sum((c.cost(Q, T / N) for c in problem.task_costs), 0)  # on the nodes' frame poses
    return handles, problem.cost.time * T + pose(problem, arm, opti, handles, T / N, guess) + task


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
