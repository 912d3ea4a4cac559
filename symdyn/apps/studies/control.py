"""Studies: the controllers of chapter 9, simulated, plotted and summarised.

Independent joint control of the Puma shoulder (velocity loop, windup,
link inertia, position loop), torque feedforward against computed torque
on the whole Puma, operational-space force control, and a series-elastic
actuator.  Each study writes `control_*.png` and `summary.txt` into its
folder and returns the summary; `quick=True` shortens the runs (tests).
The controllers and the simulator are `symdyn.apps.control`, the arm's dynamics
`symdyn.numeric.backend`; this module only sets the scenes, plots and reports.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Callable

import numpy as np

from ...model import arms
from ...numeric import backend
from ...numeric import reference as ref
from .. import control as C
from ._plot import finish, pyplot, save

PERIOD = 1e-3  # joint controllers: 1 kHz, one sample of computation delay
LOAD = 20.0  # N·m, gravity load on the shoulder, link side
# trapezoidal speed demand at the motor: 0 → 50 rad/s in 0.2 s, held 1 s (long
# enough to reach steady state), back to 0 in 0.2 s (the book's ramps, longer hold)
SPEED = ((0.0, 0.1, 0.3, 1.3, 1.5, 2.0), (0.0, 0.0, 50.0, 50.0, 0.0, 0.0))
# a demand steeper than the drive can follow: 0 → 100 rad/s in 20 ms
STEEP = ((0.0, 0.05, 0.07, 0.6), (0.0, 0.0, 100.0, 100.0))


def speed_demand(profile) -> Callable:
    """Piecewise-linear demand ω*(t) through (times, values)."""
    return functools.partial(np.interp, xp=profile[0], fp=profile[1])


def run_velocity_loop(
    drive: C.JointDrive, demand, T: float, *, Kv: float, Ki: float = 0.0, antiwindup: bool = False, tau_ff: float = 0.0
) -> C.Trace:
    """The velocity loop of Fig. 9.9 at 1 kHz with a one-sample delay; plant RK4 at 1 kHz."""
    loop = C.VelocityLoop(drive, Kv, Ki, period=PERIOD, antiwindup=antiwindup, tau_ff=tau_ff)
    return C.simulate(drive.accel, lambda t, q, qd: loop(demand(t), qd), T, [0.0], dt=PERIOD, period=PERIOD, delay=1)


def p_steady_error(drive: C.JointDrive, omega: float, Kv: float, tau_ff: float = 0.0) -> float:
    """Steady speed error of the P loop at speed demand ω > 0:
    e = (Bm·ω* + Tc⁺ + tau_load/G − tau_ff)/(Km·Kv + Bm)."""
    return (drive.Bm * omega + drive.Tc[0] + drive.tau_load / drive.G - tau_ff) / (drive.Km * Kv + drive.Bm)


def _plateau(trace: C.Trace, demand, t0: float, t1: float) -> float:
    sel = (trace.t >= t0) & (trace.t <= t1)
    return float(np.mean(demand(trace.t[sel]) - trace.qd[sel, 0]))


# --------------------------------------------------------------------------- joint control


def velocity_loop(out_dir: Path, quick: bool = False) -> str:
    """P and PI velocity loops of the Puma shoulder: demand, 20 N·m gravity load, torque feedforward."""
    demand = speed_demand(SPEED)
    free, loaded = C.JointDrive(), C.JointDrive(tau_load=LOAD)
    ff = LOAD / loaded.G
    cases = {
        "P, no load": (free, dict(Kv=0.6)),
        "P, 20 N·m load": (loaded, dict(Kv=0.6)),
        "P, load + torque feedforward": (loaded, dict(Kv=0.6, tau_ff=ff)),
        "PI, 20 N·m load": (loaded, dict(Kv=1.0, Ki=10.0)),
    }
    runs = {name: run_velocity_loop(d, demand, 2.0, **kw) for name, (d, kw) in cases.items()}
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = runs["P, no load"].t
    a1.plot(t, demand(t), "k--", lw=1, label="demand")
    for name, tr in runs.items():
        a1.plot(tr.t, tr.qd[:, 0], label=name)
        a2.plot(tr.t, demand(tr.t) - tr.qd[:, 0], label=name)
    a1.set_ylabel("motor speed (rad/s)")
    a1.legend(fontsize=8)
    a1.grid(True)
    a2.set_ylabel("speed error (rad/s)")
    a2.set_xlabel("time (s)")
    a2.grid(True)
    a1.set_title("Puma shoulder velocity loop, 1 kHz, 1 ms delay")
    save(fig, out_dir, "control_velocity_loop")
    lines = [
        "Velocity loop of the Puma shoulder (Table 9.2, J = %.3g kg·m² at the motor), "
        "1 kHz, 1 ms delay; trapezoid 0 -> 50 rad/s, plateau 0.3..1.3 s:" % free.J,
        "  steady speed error at the end of the plateau (mean over 1.2..1.3 s):",
    ]
    for name, (drive, kw) in cases.items():
        e = _plateau(runs[name], demand, 1.2, 1.3)
        expected = (
            f"  (formula (Bm w + Tc+ + tau_load/G - tau_ff)/(Km Kv + Bm) = "
            f"{p_steady_error(drive, 50.0, kw['Kv'], kw.get('tau_ff', 0.0)):.4f})"
            if "Ki" not in kw
            else ""
        )
        lines.append(f"    {name:30s} {e:+.4f} rad/s{expected}")
    lines.append(f"  load at the motor: {LOAD} N·m / G = {ff:.4f} N·m; torque limit {free.tau_max} N·m")
    return finish(out_dir, lines)


def windup(out_dir: Path, quick: bool = False) -> str:
    """PI velocity loop saturating on a steep demand: integral windup and clamping anti-windup."""
    demand = speed_demand(STEEP)
    drive = C.JointDrive(tau_load=LOAD)
    runs = {
        f"PI{' + clamping anti-windup' if aw else ''}": run_velocity_loop(
            drive, demand, 0.6, Kv=1.0, Ki=10.0, antiwindup=aw
        )
        for aw in (False, True)
    }
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = next(iter(runs.values())).t
    a1.plot(t, demand(t), "k--", lw=1, label="demand")
    for name, tr in runs.items():
        a1.plot(tr.t, tr.qd[:, 0], label=name)
        a2.plot(tr.t, tr.tau[:, 0], label=name)
    a2.axhline(drive.tau_max, color="gray", lw=0.8, ls=":")
    a1.set_ylabel("motor speed (rad/s)")
    a1.legend(fontsize=8)
    a1.grid(True)
    a2.set_ylabel("motor torque (N·m)")
    a2.set_xlabel("time (s)")
    a2.grid(True)
    a1.set_title("Integral windup under torque saturation (20 N·m load)")
    save(fig, out_dir, "control_windup")
    lines = [
        "PI velocity loop (Kv = 1, Ki = 10), demand 0 -> 100 rad/s in 20 ms, torque limit "
        f"{drive.tau_max} N·m, 20 N·m load:"
    ]
    for name, tr in runs.items():
        over = tr.qd[:, 0].max() - 100.0
        late = tr.t[np.abs(tr.qd[:, 0] - 100.0) > 2.0]
        lines.append(f"  {name:32s} overshoot {over:6.2f} rad/s, within 2 rad/s of the demand after {late.max():.3f} s")
    return finish(out_dir, lines)


def link_inertia(out_dir: Path, quick: bool = False) -> str:
    """Velocity loop (P and PI) with the shoulder's link inertia at its minimum and maximum."""
    demand = speed_demand(SPEED)
    inertias = {"min 3.66 kg·m²": 3.66, "max 5.21 kg·m²": 5.21}
    lines = [
        "Link inertia seen at the shoulder 3.66..5.21 kg·m², at the motor Jm + Jl/G²; "
        "velocity loop with the 20 N·m load:"
    ]
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for ax, (ctrl, kw) in zip(
        axes, {"P (Kv = 0.6)": dict(Kv=0.6), "PI (Kv = 1, Ki = 10)": dict(Kv=1.0, Ki=10.0)}.items()
    ):
        for name, Jl in inertias.items():
            drive = C.JointDrive(Jl=Jl, tau_load=LOAD)
            tr = run_velocity_loop(drive, demand, 2.0, **kw)
            err = demand(tr.t) - tr.qd[:, 0]
            ramp = _plateau(tr, demand, 0.2, 0.3)
            over = max(0.0, -err[(tr.t > 0.3) & (tr.t < 0.8)].min())
            ax.plot(tr.t, err, label=f"Jl {name}")
            lines.append(
                f"  {ctrl:22s} Jl {name}: J = {drive.J * 1e6:.0f}e-6 kg·m², error on the ramp "
                f"{ramp:+.3f} rad/s, overshoot above the plateau {over:.3f} rad/s"
            )
        ax.set_title(ctrl)
        ax.set_xlabel("time (s)")
        ax.grid(True)
        ax.legend(fontsize=8)
        ax.set_xlim(0, 0.8)
    axes[0].set_ylabel("speed error (rad/s)")
    save(fig, out_dir, "control_link_inertia")
    return finish(out_dir, lines)


def position_loop(out_dir: Path, quick: bool = False) -> str:
    """P position loop (Kp = 40) on an LSPB 0 -> 0.5 rad in 1 s, with and without velocity feedforward."""
    drive = C.JointDrive(tau_load=LOAD)
    traj = functools.partial(C.lspb, 0.0, 0.5, 1.0)
    runs = {}
    for ff in (False, True):
        loop = C.PositionLoop(C.VelocityLoop(drive, 1.0, 10.0, period=PERIOD), traj, 40.0, velocity_ff=ff)
        runs[ff] = C.simulate(drive.accel, loop, 1.5, [0.0], dt=PERIOD, period=PERIOD, delay=1)
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = runs[False].t
    a1.plot(t, traj(t)[0][:, 0], "k--", lw=1, label="demand (LSPB)")
    lines = [
        "Position loop, link angle q = theta_m/G, Kp = 40 /s around the PI velocity loop "
        "(Kv = 1, Ki = 10), 1 kHz, 1 ms delay, 20 N·m load; LSPB 0 -> 0.5 rad in 1 s:"
    ]
    for ff, tr in runs.items():
        label = "with velocity feedforward" if ff else "without feedforward"
        q = tr.q[:, 0] / drive.G
        e = traj(tr.t)[0][:, 0] - q
        a1.plot(tr.t, q, label=label)
        a2.plot(tr.t, e * 1e3, label=label)
        lines.append(f"  {label:27s} max |error| {np.abs(e).max() * 1e3:7.3f} mrad, at 1.5 s {e[-1] * 1e3:+.3f} mrad")
    a1.set_ylabel("link angle (rad)")
    a1.legend(fontsize=8)
    a1.grid(True)
    a2.set_ylabel("error (mrad)")
    a2.set_xlabel("time (s)")
    a2.grid(True)
    a2.legend(fontsize=8)
    save(fig, out_dir, "control_position_loop")
    return finish(out_dir, lines)


# --------------------------------------------------------------------------- whole arm


def puma_scene():
    """The Puma of the arm studies, nofriction() as in RVC3 (viscous kept, Coulomb
    removed: its jump at zero speed makes sampled model-based compensation
    chatter), and its fastest available model (generated code, else CasADi)."""
    puma = arms.load("puma560").nofriction()
    return puma, backend.model(puma)


def torque_control(out_dir: Path, quick: bool = False) -> str:
    """Torque feedforward (Eq. 9.11) and computed torque (Eq. 9.13) on the Puma, qz -> qr, exact and ±10 % models."""
    puma, plant = puma_scene()
    T = 1.0 if quick else 2.0
    horizon = T + 0.5
    traj = functools.partial(C.quintic, puma.qz, puma.qr, T)
    factors = np.array([1.0, 1.1, 0.9])
    controller_model = C.scaled(plant, puma, factors)
    wn = 10.0
    Mqz = np.diag(ref.inertia(puma, puma.qz))
    ff = C.TorqueFeedforward(controller_model, traj, Mqz * wn**2, Mqz * 2 * wn, ff_period=0.05)
    ct = C.ComputedTorque(controller_model, traj, wn**2, 2 * wn)
    both = lambda t, q, qd: np.concatenate([ff(t, q[:3], qd[:3]), ct(t, q[3:], qd[3:])])  # noqa: E731
    accel = lambda t, q, qd, tau: plant.fdyn(q, qd, tau)  # noqa: E731
    tr = C.simulate(
        accel,
        both,
        horizon,
        np.tile(puma.qz, (6, 1)),
        dt=1e-3,
        period=1e-3,
        progress="feedforward and computed torque, 6 runs",
    )
    exact = C.simulate(
        accel,
        C.ComputedTorque(plant, traj, wn**2, 2 * wn),
        horizon,
        puma.qz,
        dt=1e-3,
        progress="computed torque, continuous, exact model",
    )
    err = traj(tr.t)[0][:, None, :] - tr.q  # (K, 6 runs, 6 joints)
    err_exact = traj(exact.t)[0] - exact.q
    names = [f"{c}, model {m}" for c in ("feedforward", "computed torque") for m in ("exact", "+10 %", "-10 %")]
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for k, name in enumerate(names):
        ax = axes[k // 3]
        ax.semilogy(tr.t, np.maximum(np.abs(err[:, k]).max(-1), 1e-12), label=name.split(", ")[1])
    axes[1].semilogy(exact.t, np.maximum(np.abs(err_exact).max(-1), 1e-16), "k:", label="exact, continuous")
    for ax, title in zip(axes, ("torque feedforward (model 20 Hz, PD 1 kHz)", "computed torque (1 kHz)")):
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("time (s)")
        ax.grid(True, which="both")
        ax.legend(fontsize=8)
    axes[0].set_ylabel("max over joints |q* - q| (rad)")
    save(fig, out_dir, "control_torque")
    np.set_printoptions(precision=3)
    lines = [
        f"Puma 560 (nofriction: Coulomb removed), quintic qz -> qr in {T:g} s, plant RK4 at 1 kHz "
        f"({plant.source}); controller model link masses and inertias x 1, 1.1, 0.9.",
        f"Computed torque Kp = {wn**2:g} /s², Kv = {2 * wn:g} /s; feedforward PD Kp = M_ii(qz)·{wn**2:g}, "
        f"Kv = M_ii(qz)·{2 * wn:g}, model part at 20 Hz (ZOH), feedback at 1 kHz.",
        "  max |error| per joint (mrad) over the run:",
    ]
    for k, name in enumerate(names):
        per_joint = " ".join(f"{x:7.3f}" for x in np.abs(err[:, k]).max(0) * 1e3)
        lines.append(f"    {name:30s} [{per_joint}]  max {np.abs(err[:, k]).max() * 1e3:7.3f}")
    lines.append(
        f"  computed torque, exact model, evaluated continuously (at each RK4 stage): max |error| "
        f"{np.abs(err_exact).max():.2e} rad (integration noise)"
    )
    return finish(out_dir, lines)


def start_pose() -> np.ndarray:
    """qn with q5 = -π/4: the same tool position as qn, tool z-axis pointing down."""
    return np.array([0.0, np.pi / 4, np.pi, 0.0, -np.pi / 4, 0.0])


def contact_plant(puma, model: backend.Model, surface: C.Surface):
    """Arm dynamics with the surface's reaction: q̈ = fdyn(q, q̇, τ − Jᵀ W), W the
    wrench the end-effector exerts on the surface (Corke's τ = … + JᵀW)."""

    def accel(t, q, qd, tau):
        W = surface.wrench(ref.fkine(puma, q))
        return model.fdyn(q, qd, tau - np.einsum("...ji,...j->...i", ref.jacob0(puma, q), W))

    return accel


def run_opspace(T: float, dt: float = 5e-3, progress: str | None = None):
    """The operational-space scene: Puma at `start_pose`, hold x, y, orientation,
    press with −5 N in z onto the surface at z = −0.2 m (100 N/m); RVC3's gains
    Kp = 100, Kv = 50, Kf = 20, Kvf = 20.  Returns (trace, poses, sensed wrenches)."""
    puma, m = puma_scene()
    surface = C.Surface(z=-0.2, k=100.0)
    q0 = start_pose()
    goal = ref.fkine(puma, q0)
    sensor = lambda q: surface.wrench(ref.fkine(puma, q))  # noqa: E731
    osc = C.OperationalSpace(m, puma, goal, [0, 0, -5.0, 0, 0, 0], sensor, Kp=100.0, Kv=50.0, Kf=20.0, Kvf=20.0)
    tr = C.simulate(contact_plant(puma, m, surface), osc, T, q0, dt=dt, progress=progress)
    poses = ref.fkine(puma, tr.q)
    return tr, poses, surface.wrench(poses), goal


def opspace(out_dir: Path, quick: bool = False) -> str:
    """Operational-space control (Eq. 9.15): position in x, y and orientation, -5 N force in z onto a compliant surface."""
    tr, poses, W, goal = run_opspace(
        1.2 if quick else 2.0, dt=1e-2 if quick else 5e-3, progress="operational-space control"
    )
    p = poses[:, :3, 3]
    f = W[:, 2]
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for i, axis in enumerate("xyz"):
        a1.plot(tr.t, p[:, i], label=axis)
    a1.axhline(-0.2, color="gray", ls=":", lw=1, label="surface")
    a1.set_ylabel("end-effector position (m)")
    a1.legend(fontsize=8, ncol=4)
    a1.grid(True)
    a2.plot(tr.t, f, label="sensed force z")
    a2.axhline(-5.0, color="k", ls="--", lw=1, label="set-point")
    a2.set_ylabel("force on surface (N)")
    a2.set_xlabel("time (s)")
    a2.grid(True)
    a2.legend(fontsize=8)
    a1.set_title("Operational-space motion/force control of the Puma 560")
    save(fig, out_dir, "control_opspace")
    off = np.abs(f + 5.0) > 0.05
    settle = tr.t[off].max() if off.any() else 0.0
    rot = np.einsum("kij,ij->k", poses[:, :3, :3], goal[:3, :3])
    angle = np.degrees(np.arccos(np.clip((rot - 1) / 2, -1, 1)))
    lines = [
        "Operational-space control (Khatib, Eq. 9.15), Puma 560 (nofriction) from qn with q5 = -pi/4 "
        f"(tool down, z = {goal[2, 3]:+.4f} m); surface z = -0.2 m, 100 N/m; set-point -5 N in z;",
        "  Kp = 100, Kv = 50 (position, orientation), Kf = 20, Kvf = 20 (force); "
        f"RK4 dt = {tr.t[1] - tr.t[0]:g} s, continuous control.",
        f"  contact at t = {tr.t[np.argmax(f < 0)]:.3f} s; force within 0.05 N of -5 N from t = {settle:.3f} s; "
        f"final force {f[-1]:+.4f} N, final z {p[-1, 2]:+.4f} m (expected -0.25)",
        f"  largest drift from the goal: x {np.abs(p[:, 0] - goal[0, 3]).max() * 1e3:.1f} mm, "
        f"y {np.abs(p[:, 1] - goal[1, 3]).max() * 1e3:.2f} mm, orientation {angle.max():.3f} deg; "
        f"at the end x {(p[-1, 0] - goal[0, 3]) * 1e3:+.2f} mm",
    ]
    return finish(out_dir, lines)


# --------------------------------------------------------------------------- series-elastic actuator


def sea(out_dir: Path, quick: bool = False) -> str:
    """Series-elastic actuator with LQR state feedback: unit step of the load, free and against an obstacle at 0.8."""
    lines = []
    plt = pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for obstacle in (None, 0.8):
        act = C.SEA(obstacle=obstacle)
        K = act.lqr()
        control = act.controller(K)
        tr = C.simulate(act.accel, control, 5.0, [0.0, 0.0], dt=1e-3)
        u = tr.tau[:, 0]
        fs = act.spring_force(tr.q)
        label = "free" if obstacle is None else f"obstacle at {obstacle}"
        axes[0].plot(tr.t, tr.q[:, 1], label=label)
        axes[1].plot(tr.t, u, label=label)
        axes[2].plot(tr.t, fs, label=label)
        if obstacle is None:
            lines.append(
                f"SEA: motor {act.m_motor} kg, load {act.m_load} kg, spring {act.k} N/m, |u| <= "
                f"{act.force_limit} N; LQR Q = diag(100, 10, 100, 10), R = 0.01 -> K = {np.round(K, 3).tolist()}"
            )
            settle = tr.t[np.abs(tr.q[:, 1] - 1.0) > 0.02].max()
            lines.append(
                f"  free: final load position {tr.q[-1, 1]:.4f}, within 2 % from t = {settle:.2f} s, "
                f"max |spring force| {np.abs(fs).max():.3f} N"
            )
        else:
            lines.append(
                f"  obstacle at {obstacle}: max load position {tr.q[:, 1].max():.4f}, final spring force "
                f"{fs[-1]:.3f} N (max {np.abs(fs).max():.3f} N), final motor force {u[-1]:.3f} N"
            )
    axes[0].set_ylabel("load position (m)")
    axes[1].set_ylabel("motor force (N)")
    axes[2].set_ylabel("spring force (N)")
    axes[2].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(True)
        ax.legend(fontsize=8)
    axes[0].set_title("Series-elastic actuator, LQR state feedback, unit step")
    save(fig, out_dir, "control_sea")
    return finish(out_dir, lines)


STUDIES = {
    "control-velocity-loop": ("Puma shoulder velocity loop: P vs PI, 20 N·m load, torque feedforward", velocity_loop),
    "control-windup": ("PI velocity loop under torque saturation: windup and clamping anti-windup", windup),
    "control-link-inertia": ("velocity loop with the shoulder link inertia at its min and max", link_inertia),
    "control-position-loop": ("P position loop on an LSPB, with and without velocity feedforward", position_loop),
    "control-torque": ("Puma: torque feedforward vs computed torque, exact and ±10 % models", torque_control),
    "control-opspace": ("Puma: operational-space control, -5 N onto a compliant surface", opspace),
    "control-sea": ("series-elastic actuator, LQR, unit step with and without an obstacle", sea),
}
