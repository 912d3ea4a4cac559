"""The Monte-Carlo sweep: the chapter's computed-torque controller under many parameter draws.

Where it sits: a sweep task (`symdyn.sweep.engine`) around the computed-torque
part of the control study (`symdyn.apps.studies.control.torque_control`,
Eq. 9.13): the Puma (Coulomb friction off, as there) follows the quintic
qz → qr in T, computed torque Kp = ωn², Kv = 2ωn with ωn = 10 rad/s sampled at
1 kHz, the plant the arm's generated code integrated by RK4 at 1 kHz.  As in
the study, the plant is the nominal arm and the controller's model is wrong:
draw k scales each link's mass, centre-of-mass coordinates, inertia tensor
and viscous friction by its own factor in [1 − x, 1 + x] (uniform; draw 0 is
nominal, so it reproduces the study's "computed torque, model exact" row).

The controller's wrong model costs nothing to build: the dynamics are linear
in the standard inertial parameters π (`symdyn.derivation.regressor`), so
τ_model = τ_nominal + Y(q, q̇, q̈)·(π_draw − π_nominal), Y the generated
regressor; for the nominal draw the correction is exactly zero.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np

from ..apps import control as C
from ..codegen import entry as codegen
from ..derivation.cache import build_lock, cache_dir
from ..derivation.regressor import parameter_values
from ..model import Robot, arms
from ..numeric import backend
from .engine import Sweep
from .table import decode_json

ARMS = ("puma560", "twolink")
WN = 10.0  # rad/s, the study's computed-torque bandwidth: Kp = WN², Kv = 2·WN
PERIOD = 1e-3  # s, control period and RK4 step, as in the study
SETTLE = 0.5  # s simulated after the trajectory ends, as in the study
KINDS = ("m", "r", "I", "B")  # what a draw scales: mass, COM coordinates, inertia tensor, viscous friction


@functools.lru_cache(maxsize=4)
def scene(arm: str):
    """(robot, plant model, regressor Y, nominal π, start, goal) of an arm, loaded once per process
    (the processes of one host take turns, so the checked-in C is compiled once): the Puma of the
    control study (`puma_scene`: nofriction, generated code) or the two-link arm."""
    if arm not in ARMS:
        raise ValueError(f"unknown arm {arm!r} for the Monte-Carlo study: expected one of {', '.join(ARMS)}")
    robot = arms.load(arm).nofriction()
    with build_lock(cache_dir() / f"sweep-generated-{arm}"):  # a host's workers compile the code once
        plant = backend.model(robot)
        Y = codegen.load(arm, "c").Y  # kinematics only: the same for every parameter draw
    pi = np.array([float(v) for v in parameter_values(robot)])
    goal = robot.qr if arm == "puma560" else robot.qn
    return robot, plant, Y, pi, np.asarray(robot.qz, float), np.asarray(goal, float)


def perturbed(robot: Robot, draw: dict) -> Robot:
    """`robot` with link j's mass × m[j], COM coordinates × r[j] (3 factors), inertia tensor
    × I[j] and viscous friction × B[j]."""
    links = []
    for j, link in enumerate(robot.links):
        links.append(
            dataclasses.replace(
                link,
                m=float(link.m) * draw["m"][j],
                r=tuple(float(x) * f for x, f in zip(link.r, draw["r"][j])),
                I=tuple(tuple(float(x) * draw["I"][j] for x in row) for row in link.I),
                B=float(link.B) * draw["B"][j],
            )
        )
    return dataclasses.replace(robot, links=tuple(links), name=f"{robot.name} (draw)")


def draw(n_links: int, spread: float, rng: np.random.Generator | None) -> dict:
    """Factors for each kind (KINDS): all 1 when rng is None (the nominal draw), else uniform in
    [1 − spread, 1 + spread], rounded to 6 digits."""

    def factors(shape):
        if rng is None:
            return np.ones(shape).tolist()
        return np.round(rng.uniform(1 - spread, 1 + spread, shape), 6).tolist()

    return {"m": factors(n_links), "r": factors((n_links, 3)), "I": factors(n_links), "B": factors(n_links)}


def inputs(n: int, *, seed: int = 0, arm: str = "puma560", spread: float = 0.1, T: float = 2.0) -> list[dict]:
    """n draws: draw 0 nominal, draw k ≥ 1 from the generator seeded by (seed, k)."""
    if not (isinstance(n, int) and n >= 1):
        raise ValueError(f"--n must be a positive number of draws, got {n!r}")
    if not 0 <= spread < 1:
        raise ValueError(f"spread must be a fraction in [0, 1), got {spread!r}")
    if not T > 0 or abs(round(T / PERIOD) * PERIOD - T) > 1e-9:
        raise ValueError(f"T must be a positive whole number of control periods ({PERIOD} s), got {T!r}")
    if arm not in ARMS:
        raise ValueError(f"unknown arm {arm!r} for the Monte-Carlo study: expected one of {', '.join(ARMS)}")
    n_links = arms.load(arm).n
    return [
        {
            "index": k,
            "arm": arm,
            "seed": seed,
            "spread": spread,
            "T": T,
            "draw": draw(n_links, spread, None if k == 0 else np.random.default_rng([seed, k])),
        }
        for k in range(n)
    ]


def controller_model(arm: str, draw_: dict) -> backend.Model:
    """The controller's model of one draw: the plant's generated τ plus Y·Δπ (exactly the
    plant's τ for the nominal draw)."""
    robot, plant, Y, pi, _, _ = scene(arm)
    dpi = np.array([float(v) for v in parameter_values(perturbed(robot, draw_))]) - pi

    def tau(q, qd, qdd):
        return plant.tau(q, qd, qdd) + Y(q, qd, qdd) @ dpi

    return dataclasses.replace(plant, tau=tau, source=f"{plant.source} + Y·Δπ")


def tracking(item: dict) -> dict:
    """One draw: the closed loop simulated, the tracking error q* − q over the run (rad)."""
    robot, plant, _, _, start, goal = scene(item["arm"])
    T = float(item["T"])
    traj = functools.partial(C.quintic, start, goal, T)
    ct = C.ComputedTorque(controller_model(item["arm"], item["draw"]), traj, WN**2, 2 * WN)
    tr = C.simulate(lambda t, q, qd, tau: plant.fdyn(q, qd, tau), ct, T + SETTLE, start, dt=PERIOD, period=PERIOD)
    err = traj(tr.t)[0] - tr.q
    per_joint = np.abs(err).max(0)
    return {
        "max_error": float(per_joint.max()),
        "joint_max_error": per_joint,
        "rms_error": float(np.sqrt(np.mean(err**2))),
        "final_error": float(np.abs(err[-1]).max()),
    }


INPUT_COLUMNS = ("index", "arm", "seed", "spread", "T", "draw")
RESULT_COLUMNS = ("max_error", "joint_max_error", "rms_error", "final_error")


def report(rows: list[dict], out_dir: Path, worst: int = 5) -> list[str]:
    """Summary lines (distribution, the nominal draw in the study's format, the worst draws with
    their factors) and the histogram `montecarlo_error.png`."""
    done = sorted((r for r in rows if not r["error"]), key=lambda r: float(r["max_error"]))
    lines = [f"Monte-Carlo computed torque: {len(rows)} draws, {len(done)} simulated, {len(rows) - len(done)} errors"]
    if not done:
        return lines
    first = done[0]
    e = np.array([float(r["max_error"]) for r in done]) * 1e3
    q = np.percentile(e, [50, 90, 99])
    lines += [
        f"  {first['arm']}, quintic in T = {float(first['T']):g} s (+{SETTLE} s), computed torque Kp = "
        f"{WN**2:g} /s², Kv = {2 * WN:g} /s at 1 kHz; controller model: masses, COMs, inertias, "
        f"viscous friction x U[1 ± {float(first['spread']):g}] per link, plant nominal",
        f"  max |q* - q| over the run (mrad): median {q[0]:.3f}, 90 % {q[1]:.3f}, 99 % {q[2]:.3f}, max {e.max():.3f}",
    ]
    nominal = [r for r in done if r["index"] == "0"]
    for r in nominal:
        per_joint = " ".join(f"{x:7.3f}" for x in np.array(decode_json(r["joint_max_error"])) * 1e3)
        lines.append(
            f"  nominal draw (the study's 'computed torque, model exact'): [{per_joint}]  "
            f"max {float(r['max_error']) * 1e3:7.3f}"
        )
    lines.append(f"  the {min(worst, len(done))} worst draws (factors per link):")
    for r in done[::-1][:worst]:
        d = decode_json(r["draw"])
        lines.append(
            f"    draw {r['index']}: max error {float(r['max_error']) * 1e3:.3f} mrad; "
            + "; ".join(f"{k} {np.round(d[k], 3).tolist()}" for k in KINDS)
        )
    _figure(e, out_dir, first)
    lines.append(f"  figure: {Path(out_dir) / 'montecarlo_error.png'}")
    return lines


def _figure(e: np.ndarray, out_dir: Path, first: dict) -> None:
    from ..apps.studies._plot import pyplot, save

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.hist(e, bins=max(5, min(50, len(e) // 5)))
    ax.set_xlabel("max tracking error over the run (mrad)")
    ax.set_ylabel("draws")
    ax.set_title(
        f"{first['arm']}: computed torque under ±{100 * float(first['spread']):g} % parameter draws", fontsize=10
    )
    ax.grid(True)
    save(fig, out_dir, "montecarlo_error")


SWEEP = Sweep(
    name="monte-carlo",
    summary="the chapter's computed-torque controller under random parameter errors (±x %)",
    task=tracking,
    inputs=inputs,
    input_columns=INPUT_COLUMNS,
    result_columns=RESULT_COLUMNS,
    report=report,
    options={
        "arm": ("puma560", f"the arm: {', '.join(ARMS)}"),
        "spread": (0.1, "relative spread x of each factor, uniform in [1 - x, 1 + x]"),
        "T": (2.0, "duration of the quintic qz -> qr (s)"),
        "seed": (0, "seed of the draws"),
    },
)
