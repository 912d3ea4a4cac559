"""Study: the Puma on an air puck (the chapter's exercise 9) — moving the arm
translates and spins the free base; a planned arm motion moves the base to a
chosen pose and stops it; the effort-optimal motion between the same states, on a
true planar base, does it with less effort.  Model, controller and planner:
`symdyn.apps.air_puck`, run through the 9-joint model's generated C code; the
optimal control `symdyn.apps.ocp`; this module plots and reports.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from ...model.base_joint import base_pose
from ...numeric import backend
from ...numeric import reference as ref
from .. import air_puck as P
from .. import control as C
from .. import ocp
from ._plot import finish, pyplot, save

START = np.array([0.0, np.pi / 4, np.pi, 0.0, np.pi / 4, 0.0])  # the arm at qn
GOAL = np.array([0.02, 0.0, np.radians(10.0)])  # base x, y (m), yaw (rad)


def run(model: backend.Model, trajectory, T: float, dt: float = 2e-3) -> C.Trace:
    """The puck robot from rest with the base at the origin and the arm at START, the arm
    under `PassiveBase` computed torque along `trajectory`, zero base torque, RK4 at dt."""
    ctrl = P.PassiveBase(model, trajectory)
    return C.simulate(
        lambda t, q, qd, tau: model.fdyn(q, qd, tau), ctrl, T, np.concatenate([np.zeros(3), START]), dt=dt
    )


def waist_swing(T: float = 2.0):
    """The arm's trajectory for part A: the waist turns +90° in T s (quintic), the rest held."""
    return functools.partial(C.quintic, START, START + np.array([np.pi / 2, 0, 0, 0, 0, 0]), T)


def optimal(trace: C.Trace, arm_end, T: float):
    """Part C: the effort-optimal motion (Hermite–Simpson, 40 intervals, CasADi SX) of the Puma on a
    true planar base from rest at START to the base at GOAL, the arm at `arm_end`, at rest in T s,
    the base unactuated, started from `trace` (the planned loop) with its velocities turned into
    the base's frame (its first T s).  Returns (robot, problem, solution, check)."""
    robot = P.puck_robot(planar=True)
    k = trace.t <= T + 1e-9
    t, q, qd = trace.t[k], trace.q[k], trace.qd[k]
    R = base_pose("planar", q)[0][:, :2, :2]  # the disc's turn: v = Rᵀ·(ẋ, ẏ), the yaw rate as it is
    v = np.concatenate([np.einsum("kji,kj->ki", R, qd[:, :2]), qd[:, 2:]], -1)
    problem = ocp.Problem(
        np.r_[np.zeros(3), START],
        np.r_[GOAL, arm_end],
        T=T,
        N=40,
        unactuated=(0, 1, 2),
        guess=(t, q, v),
    )
    solution = ocp.solve(problem, ocp.dynamics(robot, compiled=False))
    return robot, problem, solution, ocp.verify(robot, problem, solution)


def air_puck(out_dir: Path, quick: bool = False) -> str:
    """Puma on an air puck: arm motion moves the unactuated base; a planned motion reaches a base pose and stops."""
    robot = P.puck_robot()
    model = backend.model(robot, "c")
    swing = run(model, waist_swing(), 2.5)
    path, params, planned = P.plan(model, START, GOAL, steps=60)
    moved = run(model, P.timed(path, params, 4.0), 4.5)
    planar, problem, best, check = optimal(moved, path(params, 1.0)[0], 4.0)
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    lines = [
        f"Puma 560 (Coulomb friction removed) on a {robot.links[2].m} kg disc of radius 0.25 m, free in x, y, yaw: "
        f"9 joints (2 prismatic + 1 revolute base, unactuated), {model.source}; arm at qn, base at the origin, at rest;",
        "  arm under computed torque with the base passive (Kp = 100, Kv = 20), zero base torque, RK4 2 ms.",
    ]
    for k, (name, tr) in enumerate((("A: waist +90 deg in 2 s", swing), ("B: planned loop", moved))):
        M = ref.inertia(robot, tr.q)
        mom = P.momentum(M, tr.q, tr.qd)
        com = P.centre_of_mass(robot, tr.q)
        ax = axes[0, k]
        ax.plot(tr.t, tr.q[:, 0] * 1e3, label="base x (mm)")
        ax.plot(tr.t, tr.q[:, 1] * 1e3, label="base y (mm)")
        ax.plot(tr.t, np.degrees(tr.q[:, 2]) * 10, label="base yaw (0.1 deg)")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("base pose (mm, 0.1 deg)")
        axes[1, 0].plot(tr.q[:, 0] * 1e3, tr.q[:, 1] * 1e3, label=f"{name[:2]} base path")
        axes[1, 1].semilogy(tr.t, np.maximum(np.abs(mom).max(-1), 1e-16), label=f"{name[:2]} max |p_x, p_y, L_z|")
        lines.append(
            f"  {name}: base ends at x {tr.q[-1, 0] * 1e3:+.3f} mm, y {tr.q[-1, 1] * 1e3:+.3f} mm, yaw "
            f"{np.degrees(tr.q[-1, 2]):+.4f} deg; final base speed {np.abs(tr.qd[-1, :3]).max():.1e}; "
            f"momentum drift |p| {np.abs(mom[:, :2]).max():.1e} kg·m/s, |L_z| {np.abs(mom[:, 2]).max():.1e} "
            f"kg·m²/s; centre of mass moved {np.ptp(com[:, :2], axis=0).max() * 1e3:.1e} mm in x-y"
        )
    for k, goal in enumerate(GOAL):
        axes[0, 1].axhline(goal * (1e3 if k < 2 else np.degrees(1) * 10), color=f"C{k}", ls=":", lw=1)
    lines.append(
        f"  B: goal x {GOAL[0] * 1e3:.1f} mm, y {GOAL[1] * 1e3:.1f} mm, yaw {np.degrees(GOAL[2]):.1f} deg; plan "
        f"(zero-momentum kinematics, 60 RK4 steps) waist swing +-1 rad with elbow bend {params[0]:+.3f} rad, "
        f"end offsets waist {params[1]:+.3f}, shoulder {params[2]:+.3f} rad, 4 s; planned base "
        f"{np.round(planned * [1e3, 1e3, np.degrees(1)], 4).tolist()} (mm, mm, deg)"
    )
    k = moved.t < 4.0 - 1e-9  # B's 4 s of motion, τ held over each step
    plan_effort = float(np.sum(moved.tau[k] ** 2) * (moved.t[1] - moved.t[0]))
    momentum = ref.momentum(planar, check.q, check.qd)[:, [0, 1, 5]]
    lines.append(
        f"  C: effort-optimal (Hermite-Simpson, 40 intervals, IPOPT {best.stats['iterations']} iterations "
        f"from B as the guess) on a true planar base (velocities in the disc's frame), base unactuated: "
        f"integral of tau^T tau {best.cost:.1f} N^2 m^2 s against B's {plan_effort:.1f}; re-simulated open loop "
        f"with the reference, the base ends at x {check.q[-1, 0] * 1e3:+.3f} mm, y {check.q[-1, 1] * 1e3:+.3f} mm, "
        f"yaw {np.degrees(check.q[-1, 2]):+.4f} deg ({check.describe().split('; ')[1]}); momentum "
        f"{np.abs(momentum).max():.1e}"
    )
    axes[1, 0].plot(check.q[:, 0] * 1e3, check.q[:, 1] * 1e3, label="C base path (optimal, replayed)")
    axes[1, 0].plot(GOAL[0] * 1e3, GOAL[1] * 1e3, "k*", ms=10, label="goal B")
    axes[1, 0].set_xlabel("base x (mm)")
    axes[1, 0].set_ylabel("base y (mm)")
    axes[1, 0].set_title("base path, top view")
    axes[1, 1].set_xlabel("time (s)")
    axes[1, 1].set_ylabel("momentum (kg·m/s, kg·m²/s)")
    axes[1, 1].set_title("momentum of the whole system (from rest: 0)")
    for ax in axes.ravel():
        ax.grid(True, which="both")
        ax.legend(fontsize=7)
    save(fig, out_dir, "ex_air_puck")
    return finish(out_dir, lines)


STUDIES = {
    "ex-air-puck": ("ex. 9: Puma on an air puck, 9 joints, base moved by the arm, momentum conserved", air_puck),
}
