"""The trajectory-library sweep: minimum-time motions between many start and goal poses.

Where it sits: a sweep task (`symdyn.sweep.engine`) around the minimum-time
study of the chapter (`symdyn.apps.studies.ocp`: the same problem, limits and
solver — Hermite–Simpson collocation on symdyn's compiled CasADi dynamics,
IPOPT).  A task is one motion: the arm's name and two poses in; the minimum
time, IPOPT's status and iterations, the re-simulation check against the
numeric reference (`REPLAY`: goal or every node reached, limits held) and the
trajectory (q, q̇, τ at the nodes) out.  Poses are random within the joint limits (shrunk by
`MARGIN`) where the torque limits can hold the arm still (gravity below
`HOLD` of each limit), deterministic in (seed, index).
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from ..apps import ocp
from ..apps.studies import ocp as study
from ..derivation.cache import build_lock, cache_dir
from ..model import arms
from ..numeric import reference as ref
from .engine import Sweep
from .table import decode_json

ARMS = ("puma560", "panda", "twolink")
MARGIN = 0.1  # poses keep 10 % of each joint range clear of its limits
HOLD = 0.8  # … and need at most 80 % of each torque limit to hold still
POSE_DIGITS = 4  # poses rounded to 0.1 mrad: short, exact inputs
#: Collocation intervals per motion unless --N says otherwise: the Panda's light wrist under its
#: 12 N·m limits accelerates fast enough that 40 intervals leave a re-simulated interval up to
#: 0.06 rad/s off its next node (60: 0.03, 80: 0.017 on the same motions).
DEFAULT_N = {"puma560": 40, "panda": 60, "twolink": 40}
#: How each arm's motions are re-simulated with the reference (`ocp.verify`).  The Panda's open
#: loop is unstable over its 1-2 s motions: its per-interval errors of ~1e-3 rad grow into misses of
#: 6-20 rad however right the trajectory, so each interval is re-simulated from its own node.
REPLAY = {"puma560": "open-loop", "panda": "intervals", "twolink": "open-loop"}


@functools.lru_cache(maxsize=4)
def scene(arm: str):
    """(robot, limits) of an arm of the library: the Puma of the minimum-time study
    (Coulomb friction off) and its limits, or the two-link arm with the swing-up's."""
    if arm == "puma560":
        robot = study.puma()
        return robot, study.puma_limits(robot)
    if arm == "twolink":
        robot = arms.load("twolink").nofriction()
        return robot, ocp.Limits.for_robot(robot, tau=study.TWOLINK_TAU, qd=study.TWOLINK_QD_MAX)
    if arm == "panda":  # its URDF's joint, speed and effort limits
        robot = arms.load("panda")
        return robot, ocp.Limits.for_robot(robot)
    raise ValueError(f"unknown arm {arm!r} for the trajectory library: expected one of {', '.join(ARMS)}")


def problem(arm: str, start, goal, N: int) -> ocp.Problem:
    """The minimum-time problem between two poses at rest (the study's, for the Puma)."""
    robot, limits = scene(arm)
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    for name, q in (("start", start), ("goal", goal)):
        if q.shape != (robot.n,) or not np.all(np.isfinite(q)):
            raise ValueError(f"{name} pose must be {robot.n} finite joint angles for {arm}, got {q.tolist()}")
        if limits.q is not None and (np.any(q < limits.q[:, 0]) or np.any(q > limits.q[:, 1])):
            j = int(np.flatnonzero((q < limits.q[:, 0]) | (q > limits.q[:, 1]))[0])
            raise ValueError(
                f"{name} pose {q.tolist()} of {arm}: joint {j + 1} at {q[j]:.4f} rad is outside "
                f"its limits [{limits.q[j, 0]:.4f}, {limits.q[j, 1]:.4f}]"
            )
    if arm == "puma560":
        return study.min_time_problem(robot, start, goal, N=N)
    return ocp.Problem(
        start,
        goal,
        T=None,
        N=N,
        method="hermite-simpson",
        limits=limits,
        T_guess=1.0,
        cost=ocp.Cost(time=1.0, smoothness=study.MIN_TIME_SMOOTHING),
    )


@functools.lru_cache(maxsize=4)
def dynamics(arm: str) -> ocp.ArmFunctions:
    """The arm's compiled CasADi functions, from this host's cache (derived, generated and compiled
    there on a first run).  Once per process; the worker processes of one host take turns (a lock),
    so the first builds and the others read its result instead of generating the same code at once."""
    robot, _ = scene(arm)
    with build_lock(cache_dir() / f"sweep-ocp-{arm}"):
        return ocp.dynamics(robot, study.SOURCE, compiled=True)


def _ranges(arm: str) -> np.ndarray:
    robot, limits = scene(arm)
    q = limits.q if limits.q is not None else np.tile([-math.pi, math.pi], (robot.n, 1))
    q = np.where(np.isfinite(q), q, np.sign(q) * math.pi)
    span = q[:, 1] - q[:, 0]
    return np.stack([q[:, 0] + MARGIN * span, q[:, 1] - MARGIN * span], axis=1)


def random_pose(arm: str, rng: np.random.Generator) -> list[float]:
    """A pose within the shrunk joint limits that the torque limits can hold still."""
    robot, limits = scene(arm)
    box = _ranges(arm)
    for _ in range(10_000):
        q = np.round(rng.uniform(box[:, 0], box[:, 1]), POSE_DIGITS)
        if limits.tau is None or np.all(np.abs(ref.gravload(robot, q)) <= HOLD * limits.tau):
            return q.tolist()
    raise RuntimeError(f"found no pose of {arm} that its torque limits can hold in 10000 draws")


def inputs(n: int, *, seed: int = 0, arm: str = "puma560", N: int | None = None, verify: bool = True) -> list[dict]:
    """n motions: index k's start and goal drawn from the generator seeded by (seed, k), so a
    larger n extends a library rather than reshuffling it; N intervals (default: the arm's
    `DEFAULT_N`)."""
    if not (isinstance(n, int) and n >= 1):
        raise ValueError(f"--n must be a positive number of motions, got {n!r}")
    scene(arm)
    N = DEFAULT_N[arm] if N is None else N
    if not (isinstance(N, int) and N >= 2):
        raise ValueError(f"N must be an integer of at least 2 intervals, got {N!r}")
    out = []
    for k in range(n):
        rng = np.random.default_rng([seed, k])
        out.append(
            {
                "index": k,
                "arm": arm,
                "seed": seed,
                "N": N,
                "verify": bool(verify),
                "start": random_pose(arm, rng),
                "goal": random_pose(arm, rng),
            }
        )
    return out


def motion(item: dict) -> dict:
    """One minimum-time motion: the task of the library (runs on a worker).

    The worker loads the arm by name and its compiled CasADi functions from its
    own cache (`dynamics`, built there on a first run: nothing travels but the
    input); both stay in the worker for its later tasks."""
    robot, _ = scene(item["arm"])
    prob = problem(item["arm"], item["start"], item["goal"], int(item["N"]))
    try:
        sol = ocp.solve(prob, dynamics(item["arm"]))
    except ocp.OCPError as exc:  # no minimum: a result of the library, not an error of the task
        return {"status": exc.status, "iterations": exc.iterations}
    row = {
        "T": sol.T,
        "status": sol.stats["status"],
        "iterations": sol.stats["iterations"],
        "limit_violation": ocp.limit_violation(prob, sol),
        "q": sol.q,
        "qd": sol.qd,
        "tau": sol.tau,
    }
    if item.get("verify", True):
        check = ocp.verify(robot, prob, sol, replay=REPLAY[item["arm"]])
        row.update(
            check=check.ok,
            goal_error=check.goal_q_error,
            path_q_error=check.path_q_error,
            path_qd_error=check.path_qd_error,
        )
    return row


INPUT_COLUMNS = ("index", "arm", "seed", "N", "verify", "start", "goal")
RESULT_COLUMNS = (
    "T",
    "status",
    "iterations",
    "check",
    "goal_error",
    "path_q_error",
    "path_qd_error",
    "limit_violation",
    "q",
    "qd",
    "tau",
)


def report(rows: list[dict], out_dir: Path) -> list[str]:
    """Summary lines and the figure `library_min_time.png`: the minimum time over the goal
    space and against the speed-limit bound max_j |Δq_j| / q̇max_j."""
    done = [r for r in rows if not r["error"]]
    solved = [r for r in done if r["T"]]
    lines = [
        f"trajectory library: {len(rows)} motions, {len(solved)} solved, "
        f"{len(done) - len(solved)} without a minimum (IPOPT status), {len(rows) - len(done)} errors"
    ]
    statuses: dict[str, int] = {}
    for r in done:
        statuses[r["status"]] = statuses.get(r["status"], 0) + 1
    lines.append("  IPOPT status: " + ", ".join(f"{k} {v}" for k, v in sorted(statuses.items())))
    if not solved:
        return lines
    T = np.array([float(r["T"]) for r in solved])
    it = np.array([int(r["iterations"]) for r in solved])
    checked = [r for r in solved if r["check"]]
    passed = [r for r in checked if r["check"] == "1"]
    replay = REPLAY.get(solved[0]["arm"], "open-loop")
    lines += [
        f"  minimum time: min {T.min():.3f} s, median {np.median(T):.3f} s, max {T.max():.3f} s; "
        f"IPOPT iterations median {np.median(it):.0f}, max {it.max()}",
        _replayed(replay, checked, passed) if checked else "  not re-simulated (--no-verify)",
        f"  worst limit violation on the grid: {max(float(r['limit_violation']) for r in solved):.1e}",
    ]
    for r in [r for r in checked if r["check"] != "1"][:10]:
        lines.append(
            f"    FAIL task {r['task_id']}: goal error {float(r['goal_error']):.2e} rad, worst node gap "
            f"{float(r['path_q_error']):.2e} rad, {float(r['path_qd_error']):.2e} rad/s, "
            f"limit violation {float(r['limit_violation']):.1e}"
        )
    _figure(solved, out_dir)
    lines.append(f"  figure: {Path(out_dir) / 'library_min_time.png'}")
    return lines


def _replayed(replay: str, checked: list[dict], passed: list[dict]) -> str:
    worst = lambda key: max(float(r[key]) for r in checked)  # noqa: E731
    if replay == "open-loop":
        return (
            f"  re-simulated open loop with the reference: {len(passed)} of {len(checked)} reach the goal "
            f"within the tolerance with every limit held; worst goal error {worst('goal_error'):.2e} rad"
        )
    return (
        f"  re-simulated with the reference interval by interval from each node: {len(passed)} of "
        f"{len(checked)} reach every next node within the tolerance with every limit held; worst gap "
        f"{worst('path_q_error'):.2e} rad, {worst('path_qd_error'):.2e} rad/s (not open loop from the start: "
        f"unstable on this arm)"
    )


def _figure(solved: list[dict], out_dir: Path) -> None:
    from ..apps.studies._plot import pyplot, save

    arm = solved[0]["arm"]
    _, limits = scene(arm)
    start = np.array([decode_json(r["start"]) for r in solved])
    goal = np.array([decode_json(r["goal"]) for r in solved])
    T = np.array([float(r["T"]) for r in solved])
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    j, k = (1, 2) if goal.shape[1] > 2 else (0, 1)
    sc = a1.scatter(goal[:, j], goal[:, k], c=T, cmap="viridis", s=18)
    fig.colorbar(sc, ax=a1, label="minimum time (s)")
    a1.set_xlabel(f"goal q{j + 1} (rad)")
    a1.set_ylabel(f"goal q{k + 1} (rad)")
    a1.set_title(f"{arm}: minimum time over the goal space", fontsize=10)
    bound = (np.abs(goal - start) / (limits.qd if limits.qd is not None else 1.0)).max(1)
    a2.scatter(bound, T, s=12)
    top = max(bound.max(), T.max()) * 1.05
    a2.plot([0, top], [0, top], "k--", lw=1, label="T = max_j |Δq_j| / q̇max_j (speed bound)")
    a2.set_xlabel("speed-limit bound (s)")
    a2.set_ylabel("minimum time (s)")
    a2.legend(fontsize=8)
    for ax in (a1, a2):
        ax.grid(True)
    save(fig, out_dir, "library_min_time")


SWEEP = Sweep(
    name="trajectory-library",
    summary="minimum-time motions between random start/goal poses under torque and speed limits",
    task=motion,
    inputs=inputs,
    input_columns=INPUT_COLUMNS,
    result_columns=RESULT_COLUMNS,
    report=report,
    options={
        "arm": ("puma560", f"the arm: {', '.join(ARMS)}"),
        "N": (None, "collocation intervals per motion (default: puma560 and twolink 40, panda 60)"),
        "seed": (0, "seed of the random poses"),
        "verify": (True, "re-simulate each motion with the reference (--no-verify: faster)"),
    },
)
