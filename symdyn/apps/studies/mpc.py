"""Study: nonlinear MPC of the Puma 560 tracking a fast trajectory on compiled code.

`ocp.RTITracker` (the real-time iteration: one Gauss–Newton QP per step on the
linearised multiple-shooting problem, semi-implicit Euler on symdyn's compiled fdyn;
`ocp.Tracker`, a full warm-started IPOPT solve per step, as the comparison)
closes the loop every sample period on a plant simulated with the
numeric reference (`symdyn.numeric.reference`, RK4 substeps, torque held): once
with the model the controller uses, once with every link's mass and inertia
perturbed by ±10 %.  It reports the per-step solve time against the sample
period, the tracking error and the constraint satisfaction, and plots them.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ...model import Robot
from ...numeric import reference as ref
from .. import ocp
from ..ocp.functions import rk4_steps
from ._plot import finish, pyplot, save
from .ocp import puma, puma_limits

DT = 0.02  # s, sample period
HORIZON = 10  # intervals: a 0.2 s look-ahead
DURATION = 3.0  # s of tracking
PLANT_SUBSTEPS = 10  # RK4 steps of the plant per sample period
# The reference: q_ref(t) = q_c + A·sin(2πft), fast enough that joints 2 and 3
# run into their speed limits (|q̇_ref| up to 1.1× the limit) and the shoulder's
# torque limit is approached.
CENTRE = (0.0, 0.6, -1.6, 0.0, 0.0, 0.0)
AMPLITUDE = (0.8, 0.6, 0.7, 1.0, 0.8, 1.0)  # rad
FREQUENCY = (0.7, 1.0, 1.0, 0.6, 0.8, 0.6)  # Hz
PERTURBATION = 0.10  # ±10 % on every link's mass and inertia (signs alternate by link)


def reference(t) -> tuple[np.ndarray, np.ndarray]:
    """q_ref(t), q̇_ref(t) (len(t), 6) of the multi-sine reference."""
    t = np.atleast_1d(np.asarray(t, float))[:, None]
    w = 2 * np.pi * np.asarray(FREQUENCY)
    A = np.asarray(AMPLITUDE)
    return np.asarray(CENTRE) + A * np.sin(w * t), A * w * np.cos(w * t)


def perturbed(robot: Robot, scale: float = PERTURBATION) -> Robot:
    """The robot with link i's mass and inertia tensor scaled by 1 + scale·(−1)ⁱ."""
    links = [
        dataclasses.replace(
            link, m=link.m * (1 + scale * (-1) ** i), I=np.asarray(link.I, float) * (1 + scale * (-1) ** i)
        )
        for i, link in enumerate(robot.links)
    ]
    return dataclasses.replace(robot, links=links)


def _plant_step(robot: Robot, x: np.ndarray, tau: np.ndarray, dt: float, substeps: int) -> np.ndarray:
    """The state after dt under constant τ: RK4 on the reference forward dynamics."""
    n = robot.n
    return rk4_steps(lambda x: np.concatenate([x[n:], ref.accel(robot, x[:n], x[n:], tau)]), x, dt, substeps)


SCHEMES = ("rti", "ipopt")


def run(plant: Robot, model: Robot, duration: float = DURATION, *, compiled: bool = True, scheme: str = "rti") -> dict:
    """Closed loop: the tracker (semi-implicit Euler prediction) on `model`'s compiled symdyn
    dynamics — scheme "rti" (`ocp.RTITracker`, one QP per step) or "ipopt" (`ocp.Tracker`,
    a converged NLP per step) — the plant `plant` simulated with the reference; starts at
    rest at q_ref(0).  Arrays over the steps: t, q, qd, tau, q_ref, qd_ref, and per-step
    solve wall/CPU time (s; for RTI also its preparation and feedback phases), iterations."""
    limits = puma_limits(model)
    arm = ocp.dynamics(model, "symdyn", compiled=compiled)
    if scheme == "rti":
        tracker = ocp.RTITracker(arm, limits, DT, HORIZON)
    elif scheme == "ipopt":
        tracker = ocp.Tracker(arm, limits, DT, HORIZON)
    else:
        raise ValueError(f"unknown MPC scheme {scheme!r}: expected one of {SCHEMES}")
    steps = int(round(duration / DT))
    x = np.r_[reference(0.0)[0][0], np.zeros(model.n)]
    rows = {k: [] for k in ("t", "x", "tau", "wall", "cpu", "iterations", "success", "prepare", "feedback")}
    for k in range(steps):
        t = k * DT
        rq, rqd = reference(t + DT * np.arange(HORIZON + 1))
        tau, st = tracker.control(x, np.hstack([rq, rqd]))
        for key, v in (
            ("t", t),
            ("x", x),
            ("tau", tau),
            ("wall", st["wall"]),
            ("cpu", st["cpu"]),
            ("iterations", st["iterations"]),
            ("success", st["success"]),
            ("prepare", st.get("prepare", np.nan)),
            ("feedback", st.get("feedback", st["wall"])),
        ):
            rows[key].append(v)
        x = _plant_step(plant, x, tau, DT, PLANT_SUBSTEPS)
    out = {k: np.array(v) for k, v in rows.items()}
    n = model.n
    out["q"], out["qd"] = out["x"][:, :n], out["x"][:, n:]
    out["q_ref"], out["qd_ref"] = reference(out["t"])
    out["limits"] = limits
    out["scheme"] = scheme
    return out


def metrics(r: dict, settle: float = 0.2) -> dict:
    """Solve-time statistics (ms), tracking error (rad, after `settle` s) and limit use."""
    lim = r["limits"]
    after = r["t"] >= settle
    err = np.abs(r["q"] - r["q_ref"])[after]
    return dict(
        median=1e3 * np.median(r["wall"]),
        p95=1e3 * np.percentile(r["wall"], 95),
        max=1e3 * r["wall"].max(),
        cpu_median=1e3 * np.median(r["cpu"]),
        prepare=1e3 * np.median(r["prepare"]),
        feedback=1e3 * np.median(r["feedback"]),
        feedback_p95=1e3 * np.percentile(r["feedback"], 95),
        iterations=float(np.median(r["iterations"])),
        failures=int((~r["success"]).sum()),
        rms=float(np.sqrt((err**2).mean())),
        worst=float(err.max()),
        tau_use=float((np.abs(r["tau"]) / lim.tau).max()),
        qd_use=float((np.abs(r["qd"]) / lim.qd).max()),
        ref_qd_use=float((np.abs(r["qd_ref"]) / lim.qd).max()),
    )


def _plot(out_dir: Path, runs: dict) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(4, 1, figsize=(10, 10), sharex=True)
    for (label, r), ls in zip(runs.items(), ("-", "--", ":")):
        lim = r["limits"]
        t = r["t"]
        if r["scheme"] == "rti":
            axes[0].plot(t, 1e3 * r["wall"], ls=ls, label=f"{label}: preparation + feedback")
            axes[0].plot(t, 1e3 * r["feedback"], ls=ls, lw=0.8, label=f"{label}: feedback (QP)")
        else:
            axes[0].plot(t, 1e3 * r["wall"], ls=ls, label=f"{label}: IPOPT solve")
        for j in (1, 2):
            axes[1].plot(t, r["q"][:, j] - r["q_ref"][:, j], f"C{j}", ls=ls, label=f"q{j + 1} error, {label}")
            axes[2].plot(t, r["qd"][:, j] / lim.qd[j], f"C{j}", ls=ls, label=f"q̇{j + 1}/limit, {label}")
            axes[3].step(t, r["tau"][:, j] / lim.tau[j], f"C{j}", ls=ls, where="post", label=f"τ{j + 1}/limit, {label}")
    axes[0].axhline(1e3 * DT, color="k", ls=":", label="sample period")
    axes[0].axhline(1e3 * DT / 5, color="k", ls="--", lw=1, label="sample period / 5")
    axes[0].set_ylabel("ms")
    axes[0].set_yscale("log")
    axes[1].set_ylabel("q − q_ref (rad)")
    for ax in axes[2:]:
        for s in (1, -1):
            ax.axhline(s, color="k", ls="--", lw=1)
    axes[2].set_ylabel("q̇ / q̇_max")
    axes[3].set_ylabel("τ / τ_max")
    axes[3].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(True)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[0].set_title(
        f"Puma 560 NMPC (real-time iteration), sample period {1e3 * DT:.0f} ms, horizon {HORIZON} (joints 2, 3)"
    )
    save(fig, out_dir, "mpc_puma")


def mpc_puma(out_dir: Path, quick: bool = False) -> str:
    """NMPC tracking of a fast Puma trajectory under torque and speed limits by the
    real-time iteration: plant = the reference, then a ±10 % perturbed reference; and
    the full-IPOPT tracker on the nominal plant as the comparison."""
    model = puma()
    duration = 0.6 if quick else DURATION
    runs = {
        "RTI, nominal plant": run(model, model, duration),
        f"RTI, ±{100 * PERTURBATION:.0f} % plant": run(perturbed(model), model, duration),
        "IPOPT, nominal plant": run(model, model, duration, scheme="ipopt"),
    }
    lim = puma_limits(model)
    lines = [
        f"Puma 560 NMPC tracking (Coulomb friction off, viscous on): sample period {1e3 * DT:.0f} ms, "
        f"horizon {HORIZON} intervals ({HORIZON * DT:.2f} s), multiple shooting with one semi-implicit "
        f"Euler step per interval on symdyn's compiled fdyn; {duration} s",
        "  RTI: one Gauss–Newton QP per step (condensed to the n·N = 60 torques, qpOASES), "
        "linearised around the shifted previous solution; IPOPT: the same NLP solved to tol 1e-4 "
        "each step, exact Hessian, warm-started",
        f"  reference q_c + A sin(2πft): A = {list(AMPLITUDE)} rad, f = {list(FREQUENCY)} Hz; "
        f"limits |τ| ≤ {np.round(lim.tau, 1).tolist()} N·m, |q̇| ≤ {lim.qd.tolist()} rad/s",
        "  plant: symdyn.numeric.reference, RK4 × "
        f"{PLANT_SUBSTEPS} per period; second run: link masses and inertias × (1 ± {PERTURBATION:g})",
    ]
    for label, r in runs.items():
        m = metrics(r)
        ok = m["median"] * 5 <= 1e3 * DT
        phases = (
            f"; preparation median {m['prepare']:.2f} ms, feedback (QP) median {m['feedback']:.2f} ms, "
            f"95th percentile {m['feedback_p95']:.2f} ms"
            if r["scheme"] == "rti"
            else f"; median {m['iterations']:.0f} IPOPT iterations"
        )
        lines += [
            f"{label}: solve time per step median {m['median']:.2f} ms, 95th percentile {m['p95']:.2f} ms, "
            f"max {m['max']:.2f} ms (wall; CPU median {m['cpu_median']:.2f} ms) against the "
            f"{1e3 * DT:.0f} ms period: median ≤ period/5 {'yes' if ok else 'NO'}{phases}; "
            f"{m['failures']} unsuccessful solves",
            f"  tracking error after 0.2 s: RMS {m['rms']:.4f} rad, worst {m['worst']:.4f} rad; "
            f"peak |τ|/τ_max {m['tau_use']:.3f}, peak |q̇|/q̇_max {m['qd_use']:.3f} "
            f"(the reference asks for {m['ref_qd_use']:.2f}): torque limits "
            f"{'held' if m['tau_use'] <= 1 + 1e-6 else 'VIOLATED'} (they bound the decision "
            f"variables); the plant's speed exceeds its limit by at most "
            f"{100 * max(0.0, m['qd_use'] - 1):.1f} % (the prediction is a model, the plant is not)",
        ]
    _plot(out_dir, runs)
    return finish(out_dir, lines)


STUDIES = {
    "mpc-puma": ("Puma 560 NMPC tracking a fast trajectory under torque and speed limits, on compiled code", mpc_puma),
}
