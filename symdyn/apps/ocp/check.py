"""Every optimum checked against the numeric reference: its torques re-simulated open loop
(`resimulate`), the goal and the limits measured (`verify`, `Check`, `limit_violation`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...model import Robot
from ...model.base_joint import coordinate_rates
from ...numeric import reference
from .problem import Problem, Solution


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
    if problem.task is not None or problem.free_end:  # the goal is a pose, or the cost's: the optimised end
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
