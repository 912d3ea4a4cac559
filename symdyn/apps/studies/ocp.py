"""Studies: optimal control on the arm's CasADi dynamics (`symdyn.ocp`), with figures.

Minimum-time Puma 560 motions under torque and velocity limits, minimum-effort
Puma motions with and without a payload, the two-link arm's swing-up, and the
solver comparison of symdyn's simplified functions against a plain CasADi
Newton–Euler.  Each study writes `ocp_*.png` and `summary.txt` and returns the
summary; `quick=True` uses coarse grids (tests).  Every optimum is re-simulated
open-loop with `symdyn.reference` (`ocp.verify`) and the check is reported.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from ...model import IDENTITY, Robot
from ...model import arms as shipped  # "arm" in this module is a source of dynamics functions
from ...numeric import reference as ref
from .. import ocp
from ._plot import finish, pyplot, save
from .analyses import PUMA_PAYLOAD

# Illustrative limits (the consensus parameters give none): motor torque limits,
# N·m at the motor, times |G| at the joint = (75, 129, 64, 19, 18, 19) N·m; joint
# speed limits, rad/s.  The shoulder limit is 3.5× its gravity load at qz.
PUMA_MOTOR_TAU = (1.2, 1.2, 1.2, 0.25, 0.25, 0.25)
PUMA_QD_MAX = (4.0, 4.0, 4.0, 6.0, 6.0, 6.0)
PUMA_EFFORT_T = 1.0  # s, fixed time of the minimum-effort motion (≈ 1.8× the minimum time)
# Minimum time: a tiny torque-rate penalty (weight per (N·m/s)²·s) stops chattering
# on arcs where a torque is not at a limit; it changes T by < 0.1 %.
MIN_TIME_SMOOTHING = 1e-8
# The two-link arm: the shoulder cannot hold the arm out horizontally (that takes
# 19.62 N·m), so it has to swing up.
TWOLINK_TAU = (15.0, 4.0)
TWOLINK_QD_MAX = (5.0, 5.0)
TWOLINK_T = 2.0
TWOLINK_HANG = (-np.pi / 2, 0.0)  # gravity acts along −y of frame {0}: q1 = −π/2 points down
TWOLINK_UP = (np.pi / 2, 0.0)
TWOLINK_SMOOTHING = 1e-3
ACTIVE = 0.995  # a limit is "active" where |x| ≥ 0.995 of it
SOURCE = "symdyn"  # the studies run on symdyn's generated functions, compiled


def puma() -> Robot:
    """The Puma 560 without Coulomb friction (viscous kept): the OCP needs smooth dynamics."""
    return shipped.load("puma560").nofriction()


def puma_limits(robot: Robot) -> ocp.Limits:
    return ocp.Limits.for_robot(robot, qd=PUMA_QD_MAX, motor_tau=PUMA_MOTOR_TAU)


def min_time_problem(robot: Robot, q0, qf, *, N: int = 40, method: str = "hermite-simpson") -> ocp.Problem:
    """Minimum time between two poses at rest, under joint, speed and motor torque limits."""
    return ocp.Problem(
        np.asarray(q0, float),
        np.asarray(qf, float),
        T=None,
        N=N,
        method=method,
        limits=puma_limits(robot),
        T_guess=1.0,
        cost=ocp.Cost(time=1.0, smoothness=MIN_TIME_SMOOTHING),
    )


def min_effort_problem(robot: Robot, *, N: int = 40, method: str = "hermite-simpson") -> ocp.Problem:
    """Minimum effort ∫Σ(τⱼ/τmax,ⱼ)² dt from qz to qr in PUMA_EFFORT_T, under the same limits.

    Normalised by the torque limits so that each motor's effort counts alike: with
    plain ∫τᵀτ a wrist N·m is ~50× cheaper than a shoulder N·m of the same motor
    share, and the optimum swings the payload on joint 5 (1.15 rad, at its limit)."""
    limits = puma_limits(robot)
    return ocp.Problem(
        robot.qz,
        robot.qr,
        T=PUMA_EFFORT_T,
        N=N,
        method=method,
        limits=limits,
        cost=ocp.Cost(effort=1.0, weights=tuple(limits.tau**-2.0)),
    )


def swing_up_problem(robot: Robot | None = None, *, N: int = 50, method: str = "multiple-shooting") -> ocp.Problem:
    """The two-link arm (`robot`, the shipped one by default) from hanging to upright in
    TWOLINK_T, minimum effort, torque and speed limited, within its joint limits (multiple
    shooting: its piecewise-constant torque re-simulates faithfully on this fast,
    unstable motion)."""
    robot = shipped.load("twolink") if robot is None else robot
    return ocp.Problem(
        np.array(TWOLINK_HANG),
        np.array(TWOLINK_UP),
        T=TWOLINK_T,
        N=N,
        method=method,
        limits=ocp.Limits.for_robot(robot, tau=TWOLINK_TAU, qd=TWOLINK_QD_MAX),
        cost=ocp.Cost(effort=1.0, smoothness=TWOLINK_SMOOTHING),
    )


def solve_checked(robot: Robot, problem: ocp.Problem, src: str = "symdyn", compiled: bool = True):
    """Solve on `src` dynamics (compiled code unless compiled=False) and verify against the
    reference: (solution, check)."""
    sol = ocp.solve(problem, ocp.dynamics(robot, src, compiled=compiled))
    return sol, ocp.verify(robot, problem, sol)


def _active(x: np.ndarray, limit) -> np.ndarray:
    """Fraction of grid points (n,) where |x| is at its limit."""
    return (np.abs(x) >= ACTIVE * np.asarray(limit)).mean(0)


def _dense(sol: ocp.Solution, per: int = 20):
    t = np.linspace(0, sol.T, sol.N * per + 1)
    return t, sol.torque(t)


# --------------------------------------------------------------------------- minimum time


def _plot_min_time(out_dir: Path, name: str, title: str, robot, problem, sol, resim_q):
    plt = pyplot()
    lim = problem.limits
    fig, axes = plt.subplots(3, 1, figsize=(10.5, 8), sharex=True)
    td, taud = _dense(sol)
    for j in range(robot.n):
        c = f"C{j}"
        at_tau, at_qd = _active(sol.tau, lim.tau)[j], _active(sol.qd, lim.qd)[j]
        axes[0].plot(sol.t, sol.q[:, j], c, label=f"q{j + 1}")
        axes[0].plot(sol.t, resim_q[:, j], c, ls=":", lw=2)
        axes[1].plot(
            sol.t, sol.qd[:, j] / lim.qd[j], c, marker=".", ms=3, label=f"joint {j + 1}: at limit {100 * at_qd:.0f} %"
        )
        axes[2].plot(
            td,
            taud[:, j] / lim.tau[j],
            c,
            label=f"joint {j + 1} (±{lim.tau[j]:.0f} N·m): at limit {100 * at_tau:.0f} %",
        )
    for ax in axes[1:]:
        for s in (1, -1):
            ax.axhline(s, color="k", ls="--", lw=1)
        ax.set_ylim(-1.15, 1.15)
    axes[0].set_ylabel("q (rad); dotted: re-simulated")
    axes[1].set_ylabel("qd / qd_max")
    axes[2].set_ylabel("τ / τmax")
    axes[2].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(True)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[0].set_title(title)
    save(fig, out_dir, name)


def min_time(out_dir: Path, quick: bool = False) -> str:
    """Minimum-time Puma 560 motions qz → qr and qr → qs (bang-bang-like torques)."""
    robot = puma()
    lim = puma_limits(robot)
    src = SOURCE
    N = 12 if quick else 40
    lines = [
        f"Minimum-time Puma 560 motions (Hermite–Simpson collocation, N = {N}, dynamics: {src}, compiled; "
        f"Coulomb friction off, viscous on)",
        f"  torque limits (motor {PUMA_MOTOR_TAU} N·m × |G|): {np.round(lim.tau, 1).tolist()} N·m",
        f"  speed limits: {list(PUMA_QD_MAX)} rad/s; joint limits of the model; "
        f"smoothing {MIN_TIME_SMOOTHING:g}·∫|dτ/dt|²",
    ]
    for a, b in (("qz", "qr"), ("qr", "qs")):
        problem = min_time_problem(robot, getattr(robot, a), getattr(robot, b), N=N)
        sol, check = solve_checked(robot, problem, src)
        _plot_min_time(
            out_dir,
            f"ocp_mintime_{a}_{b}",
            f"Puma 560 minimum time {a} → {b}: T = {sol.T:.3f} s",
            robot,
            problem,
            sol,
            check.q,
        )
        at_tau, at_qd = _active(sol.tau, lim.tau), _active(sol.qd, lim.qd)
        lines += [
            f"{a} → {b}: T = {sol.T:.4f} s, {sol.stats['iterations']} IPOPT iterations, "
            f"{sol.stats['solve_wall']:.1f} s",
            "  torque at its limit (share of grid points): "
            + ", ".join(f"j{j + 1} {100 * x:.0f} %" for j, x in enumerate(at_tau) if x > 0),
            "  speed at its limit: "
            + (", ".join(f"j{j + 1} {100 * x:.0f} %" for j, x in enumerate(at_qd) if x > 0) or "none"),
            f"  check: {check.describe()}",
        ]
    return finish(out_dir, lines)


# --------------------------------------------------------------------------- minimum effort


def _effort(robot: Robot, t: np.ndarray, q, qd, qdd, weights) -> float:
    """∫τᵀWτ dt by the trapezoidal rule of the reference inverse dynamics on a path."""
    tau = ref.rne(robot, q, qd, qdd)
    return float(np.trapezoid((np.asarray(weights) * tau**2).sum(1), t))


def _min_jerk_effort(robot: Robot, problem: ocp.Problem, samples: int = 401) -> float:
    """Effort of the quintic (minimum-jerk) path between the same poses in the same time."""
    q0, _, qf, _ = problem.boundary()
    T = problem.T
    s = np.linspace(0, 1, samples)[:, None]
    q = q0 + (qf - q0) * (10 * s**3 - 15 * s**4 + 6 * s**5)
    qd = (qf - q0) * (30 * s**2 - 60 * s**3 + 30 * s**4) / T
    qdd = (qf - q0) * (60 * s - 180 * s**2 + 120 * s**3) / T**2
    return _effort(robot, s[:, 0] * T, q, qd, qdd, problem.cost.weights)


def min_effort(out_dir: Path, quick: bool = False) -> str:
    """Minimum-effort Puma 560 qz → qr in 1 s, with and without the book's 2.5 kg payload."""
    base = puma()
    src = SOURCE
    N = 12 if quick else 40
    m, p = PUMA_PAYLOAD
    arms = {"no payload": base, f"{m} kg payload": base.payload(m, p)}
    lines = [
        f"Minimum-effort Puma 560 qz → qr in {PUMA_EFFORT_T} s (min ∫Σ(τj/τmax,j)² dt; "
        f"Hermite–Simpson, N = {N}, dynamics: {src}, compiled; same limits as ocp-mintime)",
        f"  payload as the book's payload({m}, {list(p)}): link 6's mass becomes {m} kg at {list(p)} m "
        f"in frame {{6}} (its own 0.09 kg is replaced)",
    ]
    sols = {}
    for label, robot in arms.items():
        problem = min_effort_problem(robot, N=N)
        sol, check = solve_checked(robot, problem, src)
        sols[label] = sol
        jerk = _min_jerk_effort(robot, problem)
        peak = np.abs(sol.tau).max(0)
        moved = np.abs(sol.q - sol.q[0]).max(0)
        lines += [
            f"{label}: effort {sol.cost:.4f} s (the minimum-jerk path takes {jerk:.4f} s, "
            f"{jerk / sol.cost:.2f}×); peak |τ| = {np.round(peak, 1).tolist()} N·m; "
            f"largest excursion of joints 1, 4, 5, 6: {moved[[0, 3, 4, 5]].max():.3f} rad; "
            f"{sol.stats['iterations']} iterations",
            f"  check: {check.describe()}",
        ]
    a, b = sols.values()
    lines.append(f"payload raises the minimum effort by {100 * (b.cost / a.cost - 1):.1f} %")
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for (label, sol), ls in zip(sols.items(), ("-", "--")):
        td, taud = _dense(sol)
        for j in (1, 2):
            axes[0].plot(sol.t, sol.q[:, j], f"C{j}", ls=ls, label=f"q{j + 1}, {label}")
            axes[1].plot(td, taud[:, j], f"C{j}", ls=ls, label=f"τ{j + 1}, {label}")
    axes[0].set_ylabel("q (rad)")
    axes[1].set_ylabel("τ (N·m)")
    axes[1].set_xlabel("time (s)")
    axes[0].set_title(f"Puma 560 minimum effort qz → qr in {PUMA_EFFORT_T} s (joints 2 and 3)")
    for ax in axes:
        ax.grid(True)
        ax.legend(fontsize=8)
    save(fig, out_dir, "ocp_effort")
    return finish(out_dir, lines)


# --------------------------------------------------------------------------- swing-up


def _upper_arm(robot: Robot) -> Robot:
    return dataclasses.replace(robot, links=robot.links[:1], tool=IDENTITY, poses={})


def hanging_check(robot: Robot) -> tuple[np.ndarray, bool]:
    """Gravity load at TWOLINK_HANG (zero at an equilibrium) and whether its potential
    energy is below that of every nearby pose (a stable, hanging equilibrium)."""
    q = np.array(TWOLINK_HANG)
    rng = np.random.default_rng(0)
    near = q + rng.uniform(-0.1, 0.1, (50, 2))
    _, pot = ref.energy(robot, np.vstack([q, near]), np.zeros((51, 2)))
    return ref.gravload(robot, q), bool(np.all(pot[1:] > pot[0]))


def swing_up(out_dir: Path, quick: bool = False) -> str:
    """Two-link arm swing-up from hanging to upright, torque limited, minimum effort."""
    robot = shipped.load("twolink")
    src = SOURCE
    N = 30 if quick else 60
    G_hang, stable = hanging_check(robot)
    problem = swing_up_problem(robot, N=N)
    sol, check = solve_checked(robot, problem, src)
    rq = check.q
    lines = [
        f"Two-link arm swing-up, q = {[round(x, 4) for x in TWOLINK_HANG]} → "
        f"{[round(x, 4) for x in TWOLINK_UP]} in {TWOLINK_T} s (multiple shooting, N = {N}, RK4 × "
        f"{problem.substeps} per interval, dynamics: {src}, compiled)",
        f"  hanging check: G(q_hang) = {np.round(G_hang, 12).tolist()} N·m, potential energy is a "
        f"local minimum there: {stable}",
        f"  limits |τ| ≤ {list(TWOLINK_TAU)} N·m (holding the arm horizontal takes 19.62 N·m at the "
        f"shoulder), |q̇| ≤ {list(TWOLINK_QD_MAX)} rad/s; cost ∫τᵀτ dt + {TWOLINK_SMOOTHING:g}·∫|dτ/dt|²",
        f"effort {sol.cost:.2f}, {sol.stats['iterations']} iterations, {sol.stats['solve_wall']:.1f} s; "
        f"torque at its limit: "
        + ", ".join(f"j{j + 1} {100 * x:.0f} %" for j, x in enumerate(_active(sol.tau, TWOLINK_TAU))),
        f"  check: {check.describe()}",
    ]
    plt = pyplot()
    fig = plt.figure(figsize=(10, 5))
    ax = fig.add_subplot(1, 2, 1)
    elbow = ref.fkine(_upper_arm(robot), sol.q[:, :1])[:, :3, 3]
    tip = ref.fkine(robot, sol.q)[:, :3, 3]
    for k in range(0, sol.N + 1, max(1, sol.N // 20)):
        shade = str(0.8 - 0.8 * k / sol.N)
        ax.plot([0, elbow[k, 0], tip[k, 0]], [0, elbow[k, 2], tip[k, 2]], color=shade, marker="o", ms=3)
    ax.plot(tip[:, 0], tip[:, 2], "C3", lw=1, label="tip")
    ax.set_aspect("equal")
    ax.grid(True)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m), up")
    ax.set_title("stroboscope, light → dark in time")
    ax.legend(fontsize=8)
    a1 = fig.add_subplot(2, 2, 2)
    a2 = fig.add_subplot(2, 2, 4, sharex=a1)
    for j in range(2):
        a1.plot(sol.t, sol.q[:, j], f"C{j}", label=f"q{j + 1}")
        a1.plot(sol.t, rq[:, j], f"C{j}", ls=":", lw=2)
        a2.step(sol.t[:-1], sol.tau[:, j], f"C{j}", where="post", label=f"τ{j + 1}")
        for s in (1, -1):
            a2.axhline(s * TWOLINK_TAU[j], color=f"C{j}", ls="--", lw=1)
    a1.set_ylabel("q (rad); dotted: re-simulated")
    a1.legend(fontsize=8)
    a1.grid(True)
    a2.set_ylabel("τ (N·m), limits dashed")
    a2.set_xlabel("time (s)")
    a2.legend(fontsize=8)
    a2.grid(True)
    save(fig, out_dir, "ocp_swingup")
    return finish(out_dir, lines)


# --------------------------------------------------------------------------- comparison


def comparison_cases(quick: bool = False) -> list[tuple[str, Robot, ocp.Problem]]:
    """The problems solved by `compare`: (label, robot, problem)."""
    robot = puma()
    n_hs, n_ms = (8, 6) if quick else (40, 20)
    return [
        (
            f"Puma min-time qz→qr, Hermite–Simpson N={n_hs} (τ = ID(q, q̇, q̈))",
            robot,
            min_time_problem(robot, robot.qz, robot.qr, N=n_hs),
        ),
        (
            f"Puma min-time qz→qr, multiple shooting N={n_ms} (RK4 on fdyn)",
            robot,
            min_time_problem(robot, robot.qz, robot.qr, N=n_ms, method="multiple-shooting"),
        ),
    ]


#: The variants `compare` measures by default: (source, compiled); the first is the
#: reference of the ratios.
VARIANTS = (("symdyn", True), ("symdyn", False), ("plain", True), ("plain", False))


def _instructions(robot: Robot, src: str) -> tuple[int, int]:
    """Instructions of the source's SX tau and fdyn (what compiled code is generated from)."""
    arm = ocp.dynamics(robot, src, compiled=False)
    return arm.tau.n_instructions(), arm.fdyn.n_instructions()


def compare(variants=VARIANTS, cases=None, *, quick: bool = False, repeats: int = 1) -> list[dict]:
    """Solve each case with each variant's dynamics — (source, compiled): symdyn's or the
    plain Newton–Euler, on compiled code or CasADi's SX virtual machine — in one run;
    rows of sizes and timings (the fastest of `repeats` solves by wall time; CPU time of
    the process beside it, the fairer measure on a shared machine).  The repeats go round
    the variants in turn, so a slow spell of a shared machine falls on all of them alike.

    Before timing, the variants' τ must agree at random states (else a ValueError)
    and the optima must agree (same cost to 1e-6), so the ratios compare like with like.
    Building a compiled variant the first time compiles it into the cache (the Puma's
    fdyn ~15 s, its multiple-shooting interval ~15 s more); `build` is the time to get
    the functions in this run.
    """
    cases = comparison_cases(quick) if cases is None else cases
    warm = ocp.Problem(np.zeros(2), np.full(2, 0.1), T=1.0, N=4)
    ocp.solve(warm, ocp.dynamics(shipped.load("twolink"), "plain", compiled=False))  # load IPOPT first
    rows = []
    for label, robot, problem in cases:
        arms, builds = [], []
        for src, comp in variants:
            start = time.perf_counter()
            arms.append(ocp.dynamics.__wrapped__(robot, src, compiled=comp))  # fresh: no shared caches
            if problem.method == "multiple-shooting":
                arms[-1].shooting_step(problem.substeps)  # a compiled interval is built (or read) here
            builds.append(time.perf_counter() - start)
        _agree(robot, arms)
        runs = [[] for _ in arms]
        for _ in range(repeats):
            for arm, done in zip(arms, runs):
                done.append(ocp.solve(problem, arm))
        costs = []
        for arm, build, done in zip(arms, builds, runs):
            sol = min(done, key=lambda s: s.stats["solve_wall"])
            costs.append(sol.cost)
            st = sol.stats
            tau_i, fdyn_i = _instructions(robot, arm.source)
            rows.append(
                dict(
                    case=label,
                    source=arm.label,
                    build=build,
                    tau_instructions=tau_i,
                    fdyn_instructions=fdyn_i,
                    iterations=st["iterations"],
                    setup=st["setup_wall"],
                    ipopt=st["ipopt_wall"],
                    per_iteration=st["per_iteration"],
                    total=st["solve_wall"],
                    cpu=st["solve_cpu"],
                    cost=sol.cost,
                    T=sol.T,
                    eval_per_iteration=st["eval_wall"] / max(st["iterations"], 1),
                    outside_per_iteration=(st["ipopt_wall"] - st["eval_wall"]) / max(st["iterations"], 1),
                    free_evaluations=st["solve_wall"] - st["eval_wall"],
                )
            )
        if max(costs) - min(costs) > 1e-6 * max(1.0, abs(max(costs))):
            raise RuntimeError(f"{label}: the variants reach different optima {costs}; no fair comparison")
    return rows


def _agree(robot: Robot, arms: list, count: int = 20) -> None:
    rng = np.random.default_rng(0)
    lo, hi = robot.qlim.T
    q = rng.uniform(lo, hi, (count, robot.n))
    qd, qdd = rng.uniform(-2, 2, (2, count, robot.n))
    taus = [np.array(a.tau.map(count)(q.T, qd.T, qdd.T)) for a in arms]
    for a, t in zip(arms[1:], taus[1:]):
        if np.abs(t - taus[0]).max() > 1e-9 * max(1.0, np.abs(taus[0]).max()):
            raise ValueError(f"dynamics {arms[0].label!r} and {a.label!r} disagree on τ")


COLUMNS = (
    ("tau_instructions", "τ instructions (SX)", "{:d}"),
    ("fdyn_instructions", "fdyn instructions (SX)", "{:d}"),
    ("build", "load/build functions (s)", "{:.2f}"),
    ("iterations", "IPOPT iterations", "{:d}"),
    ("setup", "NLP set-up (s)", "{:.2f}"),
    ("per_iteration", "time per iteration (ms)", "{:.1f}"),
    ("eval_per_iteration", "of which function evaluations (ms)", "{:.1f}"),
    ("outside_per_iteration", "of which the solver itself (ms)", "{:.1f}"),
    ("total", "total solve, wall (s)", "{:.2f}"),
    ("cpu", "total solve, CPU (s)", "{:.2f}"),
)


def format_table(rows: list[dict]) -> str:
    """A Markdown table per case: one column per variant, and the ratio of each other
    variant to the first (e.g. "symdyn SX / symdyn compiled" > 1: compiled is faster)."""
    out = []
    for case in dict.fromkeys(r["case"] for r in rows):
        sub = [r for r in rows if r["case"] == case]
        srcs = [r["source"] for r in sub]
        out += [
            f"**{case}**",
            "",
            f"| | {' | '.join(srcs)} | {' | '.join(f'{s} / {srcs[0]}' for s in srcs[1:])} |",
            "|---|" + "---:|" * (2 * len(srcs) - 1),
        ]
        for key, name, fmt in COLUMNS:
            vals = [r[key] * (1e3 if key.endswith("per_iteration") else 1) for r in sub]
            ratios = [f"{v / vals[0]:.2f}" if vals[0] else "–" for v in vals[1:]]
            out.append(f"| {name} | {' | '.join(fmt.format(v) for v in vals)} | {' | '.join(ratios)} |")
        out += ["", _bound(sub), ""]
    return "\n".join(out)


def _bound(sub: list[dict]) -> str:
    """What no faster evaluation can beat: the first variant's solve with its function
    evaluations taken out (set-up and the solver's own work stay), and the largest
    ratios over the other variants that this leaves."""
    free = sub[0]["free_evaluations"]
    ratios = ", ".join(f"{r['total'] / free:.2f}× over {r['source']}" for r in sub[1:])
    return (
        f"Bound: with free function evaluations, {sub[0]['source']} would still take {free:.2f} s "
        f"(set-up and the solver's own work), at most {ratios}."
    )


def comparison(out_dir: Path, quick: bool = False) -> str:
    """symdyn's CasADi functions against the plain SX Newton–Euler on the same OCPs."""
    rows = compare(VARIANTS, quick=quick)
    lines = [
        "Optimal-control solver comparison: symdyn's and a plain Newton–Euler's functions, each on "
        "compiled code (CasADi's code generation, -O1) and on CasADi's SX virtual machine "
        "(IPOPT, exact Hessian; one run, same machine)",
        "",
        format_table(rows),
    ]
    return finish(out_dir, lines)


STUDIES = {
    "ocp-mintime": ("Puma 560 minimum-time qz→qr and qr→qs under torque and speed limits", min_time),
    "ocp-effort": ("Puma 560 minimum-effort qz→qr in 1 s, with and without a 2.5 kg payload", min_effort),
    "ocp-swingup": ("two-link arm swing-up from hanging to upright, torque limited, minimum effort", swing_up),
    "ocp-compare": ("OCP solve time: symdyn's functions vs a plain Newton–Euler, compiled and on SX", comparison),
}
