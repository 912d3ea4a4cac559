"""Hermite–Simpson on a structure-exploiting solver: fatrop against IPOPT + MUMPS (issue 13).

Run: .venv/bin/python scripts/ocp_fatrop.py [--N 40] [--source symdyn] [--sx]

The Puma's minimum-time problem of `scripts/ocp_compare.py` (Hermite–Simpson,
τ = ID(q, q̇, q̈)) in fatrop's stage-wise layout — state (q, q̇, q̈, τ, T), control
(q̈ and τ at the midpoint, q̈ and τ at the next node), the next q and q̇ explicit by
the Hermite–Simpson formulas, so the discretisation and its optimum are those of
`ocp.solve` — solved by fatrop (in the CasADi wheel); beside it `ocp.solve` with
IPOPT.  Prints iterations, the time per iteration and how much of it is function
evaluations, to show whether the sparse linear algebra, not the dynamics, bounds
the solve.
"""

import argparse
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from symdyn.apps import ocp  # noqa: E402
from symdyn.apps.ocp import transcription  # noqa: E402
from symdyn.apps.studies import ocp as studies  # noqa: E402


def stagewise(problem: ocp.Problem, arm: ocp.ArmFunctions) -> tuple[ca.Opti, ca.MX]:
    """The Hermite–Simpson problem as an Opti in fatrop's layout: per stage the
    gap-closing constraint first, then the stage's own constraints; returns the Opti
    and the final time."""
    n, N, lim = problem.n, problem.N, problem.limits
    q0, qd0, qf, qdf = problem.boundary()
    qlo, qhi = np.asarray(lim.q, float).T
    guess = transcription._guess(problem, arm, problem.T_guess)
    opti = ca.Opti()
    X, U = [], []
    for k in range(N + 1):  # declared in stage order: x0, u0, x1, u1, …, xN
        X.append(opti.variable(4 * n + 1))
        U += [opti.variable(4 * n)] if k < N else []
    J = 0
    for k in range(N + 1):
        q, qd, qdd, tau, T = X[k][:n], X[k][n : 2 * n], X[k][2 * n : 3 * n], X[k][3 * n : 4 * n], X[k][4 * n]
        opti.set_initial(X[k], np.concatenate([g[2 * k] for g in guess[:4]] + [[problem.T_guess]]))
        points = [(q, qd, qdd, tau)]
        if k < N:
            qddm, taum, qddn, taun = (U[k][i * n : (i + 1) * n] for i in range(4))
            opti.set_initial(
                U[k], np.r_[guess[2][2 * k + 1], guess[3][2 * k + 1], guess[2][2 * k + 2], guess[3][2 * k + 2]]
            )
            h = T / N
            qdn = qd + h / 6 * (qdd + 4 * qddm + qddn)
            qdm = (qd + qdn) / 2 + h / 8 * (qdd - qddn)
            qn = q + h / 6 * (qd + 4 * qdm + qdn)
            qm = (q + qn) / 2 + h / 8 * (qd - qdn)
            opti.subject_to(X[k + 1] == ca.vertcat(qn, qdn, qddn, taun, T))  # gap-closing first
            points.append((qm, qdm, qddm, taum))
            J += problem.cost.smoothness * ca.sum1(transcription._quadratic_smoothness(tau, taum, taun, h))
        if k == 0:
            opti.subject_to([q == q0, qd == qd0])
            opti.subject_to(opti.bounded(problem.T_bounds[0], T, problem.T_bounds[1]))
        if k == N:
            opti.subject_to([q == qf, qd == qdf])
        for a, b, c, t in points:
            opti.subject_to((arm.tau(a, b, c) - t) / lim.tau == 0)
            opti.subject_to(opti.bounded(qlo, a, qhi))
            opti.subject_to(opti.bounded(-lim.qd, b, lim.qd))
            opti.subject_to(opti.bounded(-lim.tau, t, lim.tau))
    opti.minimize(J + X[N][4 * n])
    return opti, X[0][4 * n]


def fatrop(problem: ocp.Problem, arm: ocp.ArmFunctions) -> dict:
    opti, T = stagewise(problem, arm)
    opti.solver(
        "fatrop",
        {"structure_detection": "auto", "record_time": True, "print_time": False},
        {"print_level": 0, "tol": 1e-8},
    )
    start = time.perf_counter()
    sol = opti.solve()
    wall = time.perf_counter() - start
    st = sol.stats()
    evals = sum(v for k, v in st.items() if k.startswith("t_wall_nlp_"))
    return dict(
        solver="fatrop (stage-wise)",
        iterations=int(st["iter_count"]),
        wall=wall,
        solver_wall=float(st["t_wall_total"]),
        evals=evals,
        T=float(sol.value(T)),
        cost=float(sol.value(opti.f)),
    )


def ipopt(problem: ocp.Problem, arm: ocp.ArmFunctions) -> dict:
    sol = ocp.solve(problem, arm)
    st = sol.stats
    return dict(
        solver="IPOPT + MUMPS (ocp.solve)",
        iterations=st["iterations"],
        wall=st["solve_wall"],
        solver_wall=st["ipopt_wall"],
        evals=st["eval_wall"],
        T=sol.T,
        cost=sol.cost,
    )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--N", type=int, default=40, help="intervals (default 40)")
    p.add_argument("--source", choices=ocp.SOURCES, default="symdyn")
    p.add_argument("--sx", action="store_true", help="CasADi's SX virtual machine instead of compiled code")
    p.add_argument("--repeats", type=int, default=3, help="solves per solver; the fastest is kept")
    args = p.parse_args(argv)
    robot = studies.puma()
    problem = studies.min_time_problem(robot, robot.qz, robot.qr, N=args.N)
    arm = ocp.dynamics(robot, args.source, compiled=not args.sx)
    print(f"Puma min-time qz→qr, Hermite–Simpson N={args.N}, {arm.label}, fastest of {args.repeats}\n")
    print(
        "| solver | iterations | solve with set-up, wall (s) | per iteration (ms) | of which function "
        "evaluations (ms) | of which the solver itself (ms) | T (s) | cost |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for run in (ipopt, fatrop):
        r = min((run(problem, arm) for _ in range(args.repeats)), key=lambda r: r["wall"])
        it = max(r["iterations"], 1)
        print(
            f"| {r['solver']} | {r['iterations']} | {r['wall']:.3f} | {1e3 * r['solver_wall'] / it:.1f} "
            f"| {1e3 * r['evals'] / it:.1f} | {1e3 * (r['solver_wall'] - r['evals']) / it:.1f} | {r['T']:.6f} "
            f"| {r['cost']:.9f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
