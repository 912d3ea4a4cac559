"""Studies: forward-dynamics simulation of the Puma 560, with figures.

`collapse`: the arm released at qz with zero torque falls under gravity;
with viscous friction its energy drains away, without any friction it is
conserved.  `integrators`: fixed-step RK4 against scipy's adaptive solver,
and smoothed Coulomb friction.  Each writes `sim_*.png` and `summary.txt`;
`quick=True` simulates a short span (for tests).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.integrate import simpson

from ...model import arms
from ...numeric import reference
from .. import simulate as S
from ._plot import finish, pyplot, save


def collapse(out_dir: Path, quick: bool = False) -> str:
    """The Puma falling from qz under zero torque: joint angles, and energy with and without viscous friction."""
    puma = arms.load("puma560")
    T, T_free = (0.1, 0.1) if quick else (5.0, 2.0)
    viscous, free = puma.nofriction(), puma.nofriction(all=True)
    sample = 0.01 if quick else 0.005
    run = lambda robot, span, label: S.simulate(  # noqa: E731
        robot,
        span,
        robot.qz,
        integrator=S.Adaptive(rtol=1e-9, atol=1e-9, sample=sample),
        progress=S.StderrProgress(label),
    )
    start = time.perf_counter()
    fall = run(viscous, T, "collapse, viscous friction")
    drift = run(free, T_free, "collapse, no friction")
    seconds = time.perf_counter() - start
    E, E_free = S.total_energy(viscous, fall), S.total_energy(free, drift)
    kinetic = reference.energy(viscous, fall.q, fall.qd)[0]
    work = simpson(np.einsum("ni,ni->n", fall.qd, reference.friction(viscous, fall.qd)), x=fall.t)

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.8))
    for j in range(puma.n):
        ax.plot(fall.t, fall.q[:, j], label=f"q{j + 1}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("joint angle (rad)")
    ax.grid(True)
    ax.legend(ncol=3, fontsize=8)
    ax.set_title("Puma 560 released at qz, zero torque, viscous friction")
    save(fig, out_dir, "sim_collapse_joints")
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    axes[0].plot(fall.t, E, label="total, viscous friction")
    axes[0].plot(fall.t, kinetic, "--", label="kinetic, viscous friction")
    axes[0].plot(drift.t, E_free, label="total, no friction")
    axes[0].set_xlabel("t (s)")
    axes[0].set_ylabel("energy (J)")
    axes[0].grid(True)
    axes[0].legend(fontsize=8)
    axes[0].set_title("energy")
    axes[1].semilogy(drift.t[1:], np.abs(E_free[1:] - E_free[0]) + 1e-16)
    axes[1].set_xlabel("t (s)")
    axes[1].set_ylabel("|E(t) - E(0)| (J)")
    axes[1].grid(True)
    axes[1].set_title("no friction: energy error (integration tolerance 1e-9)")
    save(fig, out_dir, "sim_collapse_energy")

    scale = reference.energy(free, drift.q, drift.qd)[0].max()  # energy exchanged: the peak kinetic
    lines = [
        f"Puma 560 released at qz with zero torque, scipy DOP853 rtol = atol = 1e-9 ({seconds:.1f} s of computing):",
        f" viscous friction only, {T} s: q(T) = {np.array2string(fall.q[-1], precision=3)} rad",
        f"  energy {E[0]:.3f} J -> {E[-1]:.3f} J: lost {E[0] - E[-1]:.3f} J; friction work {work:.3f} J",
        f"  largest energy rise between samples {max(np.diff(E).max(), 0.0):.2e} J (monotone decay)",
        f" no friction, {T_free} s: energy {E_free[0]:.6f} J, max |E - E0| = {np.abs(E_free - E_free[0]).max():.2e} J "
        f"({np.abs(E_free - E_free[0]).max() / scale:.1e} of the peak kinetic energy, {scale:.2f} J)",
    ]
    return finish(out_dir, lines)


def integrators(out_dir: Path, quick: bool = False) -> str:
    """RK4 against adaptive on the falling Puma (convergence, cost), and smoothed Coulomb friction."""
    puma = arms.load("puma560")
    viscous = puma.nofriction()
    T = 0.1 if quick else 0.5
    steps = (0.05, 0.025) if quick else (0.05, 0.025, 0.0125, 0.00625)
    calls = _counting()
    start = time.perf_counter()
    tol = 1e-10 if quick else 1e-12
    best = S.simulate(viscous, T, viscous.qz, integrator=S.Adaptive(rtol=tol, atol=tol), progress=calls)
    cost = {f"adaptive {tol:g}": (time.perf_counter() - start, calls.evaluations)}
    errors = []
    for dt in steps:
        calls = _counting()
        start = time.perf_counter()
        traj = S.simulate(viscous, T, viscous.qz, integrator=S.RK4(dt), progress=calls)
        cost[f"RK4 dt = {dt:g}"] = (time.perf_counter() - start, calls.evaluations)
        errors.append(np.abs(traj.q[-1] - best.q[-1]).max())
    order = np.polyfit(np.log(steps), np.log(errors), 1)[0]

    width, dt = S.COULOMB_WIDTH, 0.002
    T_c = 0.02 if quick else 0.5
    fixed = S.simulate(puma, T_c, puma.qz, integrator=S.RK4(dt), progress=S.StderrProgress("Coulomb, RK4"))
    adaptive = S.simulate(
        puma,
        T_c,
        puma.qz,
        integrator=S.Adaptive(rtol=1e-8, atol=1e-8, sample=dt),
        progress=S.StderrProgress("Coulomb, adaptive"),
    )
    smooth_only = S.simulate(viscous, T_c, viscous.qz, integrator=S.RK4(dt))

    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    axes[0].loglog(steps, errors, "o-", label="RK4")
    axes[0].loglog(steps, errors[-1] * (np.array(steps) / steps[-1]) ** 4, "k--", label="slope 4")
    axes[0].set_xlabel("step dt (s)")
    axes[0].set_ylabel(f"max |q(T) - q_adaptive(T)| (rad), T = {T} s")
    axes[0].set_title("RK4 against adaptive (viscous friction)")
    axes[0].grid(True)
    axes[0].legend()
    for j, colour in zip(range(3), ("C0", "C1", "C2")):
        axes[1].plot(fixed.t, fixed.q[:, j], color=colour, label=f"q{j + 1}, Coulomb + viscous")
        axes[1].plot(smooth_only.t, smooth_only.q[:, j], "--", color=colour, label=f"q{j + 1}, viscous only")
    axes[1].set_xlabel("t (s)")
    axes[1].set_ylabel("joint angle (rad)")
    axes[1].grid(True)
    axes[1].set_title(f"Coulomb friction, tanh width {width} rad/s")
    axes[1].legend(fontsize=7, ncol=2)
    save(fig, out_dir, "sim_integrators")

    lines = [
        f"Puma 560 falling from qz, viscous friction, T = {T} s; reference: DOP853 at rtol = atol = {tol:g}",
        " RK4 error at T against dt: " + ", ".join(f"{dt:g} s: {e:.2e} rad" for dt, e in zip(steps, errors)),
        f"  observed order {order:.2f} (4 expected)",
        " cost (wall time, right-hand-side calls): "
        + "; ".join(f"{name}: {sec:.2f} s, {count}" for name, (sec, count) in cost.items()),
        f" with Coulomb friction (tanh width {width} rad/s), {T_c} s: RK4 dt = {dt} s vs adaptive 1e-8: "
        f"max |dq| = {np.abs(fixed.q - adaptive.q).max():.2e} rad",
        f"  q(T) with Coulomb {np.array2string(fixed.q[-1], precision=4)} rad",
        f"  q(T) viscous only {np.array2string(smooth_only.q[-1], precision=4)} rad",
    ]
    return finish(out_dir, lines)


class _counting:
    """A progress callback that only counts calls: one per right-hand side, plus one at the end."""

    def __init__(self):
        self.count = 0

    def __call__(self, fraction: float, t: float, T: float) -> None:
        self.count += 1

    @property
    def evaluations(self) -> int:
        return self.count - 1


STUDIES = {
    "collapse": ("the Puma falling from qz under zero torque: joint angles, energy with/without friction", collapse),
    "integrators": ("RK4 vs adaptive forward dynamics, convergence and cost; smoothed Coulomb friction", integrators),
}
