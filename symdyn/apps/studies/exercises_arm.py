"""Studies: the chapter's whole-arm exercises on the Puma 560 — six independent
joint controllers (ex. 1e), force vs dynamic manipulability ellipsoids (ex. 10),
slower torque feedforward (ex. 11b), operational-space control on an inclined
surface of unknown height (ex. 11d).

Controllers and simulator: `symdyn.apps.control` and `symdyn.apps.exercises_arm`;
the arm's dynamics: `symdyn.numeric.backend.model` (the checked-in generated C
code of the Puma, else its generated NumPy code).  This module sets the scenes,
plots and reports.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from ...model import arms
from ...numeric import backend
from ...numeric import reference as ref
from .. import analysis
from .. import control as C
from .. import exercises_arm as X
from ._plot import finish, pyplot, save

JOINT_MOVE = np.array([1.0, -0.5, -0.6, 1.0, 0.5, 1.0])  # rad, from qn, every joint moving
FF_RATES = (1000, 200, 100, 50, 20, 10, 5)  # Hz, torque feedforward update rates


# --------------------------------------------------------------------------- ex. 1e


def independent_joint_runs(T: float = 1.5, horizon: float = 2.0, joints=range(6)):
    """The Puma (all friction) from qn along a quintic to qn + JOINT_MOVE in T s under
    `IndependentJoints` (1 kHz, one sample delay, integrators started holding gravity).
    Batch row 0 moves every joint; row 1 + k moves joint `joints[k]` alone.
    Returns (trace, demand (K, rows, 6), gains (Kv, Ki, J′), plant)."""
    puma = arms.load("puma560")
    plant = backend.model(puma)
    q0 = puma.qn
    masks = np.vstack([np.ones(6), np.eye(6)[list(joints)]])

    def trajectory(t):
        q, qd, qdd = C.quintic(q0, q0 + JOINT_MOVE, T, t)
        return q0 + masks * (q - q0), masks * qd, masks * qdd

    Kv, Ki, J = X.independent_gains(puma, q0)
    G = np.array([float(l.G) for l in puma.links])
    hold = np.broadcast_to(plant.G(q0) / (G * Ki), masks.shape)
    ctrl = X.IndependentJoints(G, trajectory, Kv, Ki, 40.0, integral=hold)
    tr = C.simulate(
        lambda t, q, qd, tau: plant.fdyn(q, qd, tau),
        ctrl,
        horizon,
        np.tile(q0, (len(masks), 1)),
        dt=1e-3,
        period=1e-3,
        delay=1,
    )
    demand = np.stack([trajectory(t)[0] for t in tr.t])
    return tr, demand, (Kv, Ki, J), plant


def puma_joints(out_dir: Path, quick: bool = False) -> str:
    """Every Puma joint under its own PI velocity and P position loop: tracking error, all joints vs one at a time."""
    tr, demand, (Kv, Ki, J), plant = independent_joint_runs()
    err = (demand - tr.q) * 1e3  # mrad, (K, 7, 6)
    alone = err[:, 1:, :].diagonal(axis1=1, axis2=2)  # joint j when it moves alone
    plt = pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(11, 6), sharex=True)
    for j, ax in enumerate(axes.ravel()):
        ax.plot(tr.t, err[:, 0, j], label="all joints move")
        ax.plot(tr.t, alone[:, j], "--", label="this joint alone")
        ax.set_title(f"joint {j + 1}", fontsize=10)
        ax.grid(True)
        if j % 3 == 0:
            ax.set_ylabel("error q* - q (mrad)")
        if j >= 3:
            ax.set_xlabel("time (s)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Puma 560, six independent joint controllers (PI velocity 300 rad/s, P position 40 /s)", fontsize=10)
    save(fig, out_dir, "ex_puma_joints")
    fmt = lambda v: " ".join(f"{x:8.3f}" for x in v)  # noqa: E731
    lines = [
        f"Puma 560 with all its friction ({plant.source}), quintic from qn by {JOINT_MOVE.tolist()} rad in 1.5 s, "
        "2 s simulated, RK4 1 kHz;",
        "  per joint, motor side: PI velocity loop Kv = J'·300 rad/s, Ki = 10 Kv, P position loop Kp = 40 /s, velocity "
        "feedforward, 1 kHz, one sample delay; integrators start holding gravity at qn;",
        "  gains in motor torque (Km, not in the reference data, only scales the current demand tau_m/Km).",
        f"  J' at qn (kg·m², motor side)        {fmt(J * 1e3)} e-3",
        f"  Kv (N·m·s/rad, motor side)         {fmt(Kv)}",
        f"  max |error|, all joints move (mrad) {fmt(np.abs(err[:, 0]).max(0))}",
        f"  max |error|, joint alone (mrad)     {fmt(np.abs(alone).max(0))}",
        f"  coupling: error all/alone           {fmt(np.abs(err[:, 0]).max(0) / np.abs(alone).max(0))}",
        f"  final |error| all joints (mrad)     {fmt(np.abs(err[-1, 0]))}",
    ]
    return finish(out_dir, lines)


# --------------------------------------------------------------------------- ex. 10

ELLIPSOID_POSES = {
    "qn": (0.0, np.pi / 4, np.pi, 0.0, np.pi / 4, 0.0),
    "reach": (0.0, 0.0, -np.pi / 4, 0.0, np.pi / 4, 0.0),
    "low": (0.0, -np.pi / 4, 0.0, 0.0, np.pi / 4, 0.0),
    "close": (0.0, np.pi / 4, 3 * np.pi / 4, 0.0, np.pi / 4, 0.0),
}


def ellipse_xz(P: np.ndarray, points: int = 100) -> np.ndarray:
    """Outline (2, points) of the projection onto world x–z of {x : xᵀ P⁻¹ x ≤ 1}."""
    sub = P[np.ix_([0, 2], [0, 2])]
    eig, vec = np.linalg.eigh(sub)
    a = np.linspace(0, 2 * np.pi, points)
    return vec @ (np.sqrt(eig)[:, None] * np.stack([np.cos(a), np.sin(a)]))


def ellipsoids(out_dir: Path, quick: bool = False) -> str:
    """Force ellipsoid vs dynamic manipulability (acceleration) ellipsoid of the Puma at four poses."""
    puma = arms.load("puma560")
    plt = pyplot()
    fig, axes = plt.subplots(1, len(ELLIPSOID_POSES), figsize=(12, 3.6))
    lines = [
        "Puma 560, translational rows of jacob0 at the tool point; ||tau|| <= 1 N·m, from rest, no gravity:",
        "  force ellipsoid {f: f' J J' f <= 1} radii 1/sqrt(eig(J J')) (N); acceleration ellipsoid J M^-1 tau, "
        "radii sqrt(eig(J M^-1 M^-T J')) (m/s²); M from the generated model.",
        "  angles: force major axis vs acceleration major axis, and vs acceleration minor axis (90 and 0 if M were "
        "a multiple of 1)",
    ]
    for ax, (name, q) in zip(axes, ELLIPSOID_POSES.items()):
        f = X.force_ellipsoid(puma, q)
        acc = analysis.acceleration_ellipsoid(puma, np.array(q))
        Pf = f.axes @ np.diag(f.radii**2) @ f.axes.T
        for P, radii, label in ((Pf, f.radii, "force"), (acc.matrix, acc.radii, "acceleration")):
            xy = ellipse_xz(P) / radii.max()
            ax.plot(xy[0], xy[1], label=f"{label} (/ {radii.max():.3g})")
        ax.set_aspect("equal")
        ax.grid(True)
        ax.legend(fontsize=7, loc="lower right")
        ax.set_title(f"{name} {np.round(np.degrees(q[:3])).astype(int).tolist()} deg", fontsize=9)
        ax.set_xlabel("world x (normalised, -)")
        lines.append(
            f"  {name:6s} force radii {np.round(f.radii, 2).tolist()} N, acceleration radii "
            f"{np.round(acc.radii, 3).tolist()} m/s²; ratio max/min force {f.radii.max() / f.radii.min():.2f}, "
            f"acceleration {acc.radii.max() / acc.radii.min():.2f}; angle major-major "
            f"{X.major_axis_angle(f.major, acc.axes[:, -1]):.1f} deg, force major-acceleration minor "
            f"{X.major_axis_angle(f.major, acc.axes[:, 0]):.1f} deg"
        )
    axes[0].set_ylabel("world z (normalised, -)")
    fig.suptitle("x-z projections, each ellipsoid scaled by its largest radius", fontsize=10)
    save(fig, out_dir, "ex_ellipsoids")
    return finish(out_dir, lines)


# --------------------------------------------------------------------------- ex. 11b


def feedforward_runs(rates=FF_RATES, T: float = 2.0, horizon: float = 2.5):
    """Torque feedforward (Eq. 9.11) on the Puma (nofriction), quintic qz -> qr in T s, the
    model part updated at each of `rates` (Hz, zero-order hold), PD at 1 kHz with the gains of
    control-torque (M_ii(qz)·100, M_ii(qz)·20).  Returns (trace with a row per rate, demand)."""
    puma = arms.load("puma560").nofriction()
    plant = backend.model(puma)
    traj = functools.partial(C.quintic, puma.qz, puma.qr, T)
    Mqz = np.diag(ref.inertia(puma, puma.qz))
    ffs = [C.TorqueFeedforward(plant, traj, Mqz * 100.0, Mqz * 20.0, ff_period=1.0 / r) for r in rates]
    control = lambda t, q, qd: np.stack([ff(t, q[k], qd[k]) for k, ff in enumerate(ffs)])  # noqa: E731
    tr = C.simulate(
        lambda t, q, qd, tau: plant.fdyn(q, qd, tau),
        control,
        horizon,
        np.tile(puma.qz, (len(rates), 1)),
        dt=1e-3,
        period=1e-3,
    )
    return tr, traj(tr.t)[0]


def slow_feedforward(out_dir: Path, quick: bool = False) -> str:
    """Torque feedforward with its model part updated ever more slowly: tracking error against the update rate."""
    tr, demand = feedforward_runs()
    err = np.abs(demand[:, None, :] - tr.q).max(-1) * 1e3  # (K, rates) mrad
    worst = err.max(0)
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    for k, r in enumerate(FF_RATES):
        a1.semilogy(tr.t, np.maximum(err[:, k], 1e-6), label=f"{r} Hz")
    a1.set_xlabel("time (s)")
    a1.set_ylabel("max over joints |q* - q| (mrad)")
    a1.legend(fontsize=7, ncol=2)
    a1.set_title("tracking error, quintic qz -> qr in 2 s")
    a2.loglog(FF_RATES, worst, "o-", label="simulated")
    a2.loglog(FF_RATES, worst[-1] * FF_RATES[-1] / np.array(FF_RATES), "k:", label="proportional to 1/rate")
    a2.set_xlabel("feedforward update rate (Hz)")
    a2.set_ylabel("max |error| (mrad)")
    a2.legend(fontsize=8)
    a2.set_title("largest error against the update rate")
    for ax in (a1, a2):
        ax.grid(True, which="both")
    save(fig, out_dir, "ex_slow_feedforward")
    lines = [
        "Torque feedforward (Eq. 9.11), Puma 560 (nofriction), quintic qz -> qr in 2 s, 2.5 s simulated, RK4 1 kHz; "
        "PD Kp = M_ii(qz)·100, Kv = M_ii(qz)·20 at 1 kHz; exact model; model part M q* + C q* + G at the rate, "
        "zero-order hold:",
        "  rate (Hz)   max |error| (mrad)   error x rate (mrad·Hz)",
    ]
    lines += [f"  {r:8d}   {e:18.4f}   {e * r:10.1f}" for r, e in zip(FF_RATES, worst)]
    lines.append(
        "  the held torque lags the demand by half a period on average: below ~100 Hz the error grows as 1/rate."
    )
    return finish(out_dir, lines)


# --------------------------------------------------------------------------- ex. 11d


def incline_scene(
    T: float,
    dt: float = 5e-3,
    radius: float = 0.05,
    period: float = 2.0,
    start: float = 1.0,
    surface: X.InclinedSurface | None = None,
):
    """The Puma (nofriction) at qn with q5 = −π/4 (tool down) over a 10° incline 5 cm below the tool
    (100 N/m; its height unknown to the controller), pressing −5 N in z while its x, y trace a circle
    of `radius` (m) in `period` s, begun at t = `start`.  RVC3's gains (as control-opspace).
    Returns (trace, poses, wrenches, surface, path)."""
    puma = arms.load("puma560").nofriction()
    model = backend.model(puma)
    q0 = np.array([0.0, np.pi / 4, np.pi, 0.0, -np.pi / 4, 0.0])
    goal = ref.fkine(puma, q0)
    centre = goal[:3, 3]
    surface = surface or X.InclinedSurface(point=(centre[0], centre[1], centre[2] - 0.05))

    def path(t):
        s = np.clip(t - start, 0.0, None)
        w = 2 * np.pi / period
        ramp = np.where(t >= start, 1.0, 0.0)  # circle begins with the tool at its centre + radius·x
        c, si = np.cos(w * s), np.sin(w * s)
        p = centre + ramp * radius * np.array([c - 1, si, 0.0])
        v = ramp * radius * w * np.array([-si, c, 0.0])
        a = ramp * radius * w**2 * np.array([-c, -si, 0.0])
        return p, v, a

    sensor = lambda q: surface.wrench(ref.fkine(puma, q))  # noqa: E731
    osc = X.CircleOperationalSpace(
        model, puma, goal, [0, 0, -5.0, 0, 0, 0], sensor, path, Kp=100.0, Kv=50.0, Kf=20.0, Kvf=20.0
    )

    def accel(t, q, qd, tau):
        W = surface.wrench(ref.fkine(puma, q))
        return model.fdyn(q, qd, tau - ref.jacob0(puma, q).T @ W)

    tr = C.simulate(accel, osc, T, q0, dt=dt)
    poses = ref.fkine(puma, tr.q)
    return tr, poses, surface.wrench(poses), surface, path


def opspace_incline(out_dir: Path, quick: bool = False) -> str:
    """Operational-space control tracing a circle on a 10° incline of unknown height while pressing with -5 N."""
    tr, poses, W, surface, path = incline_scene(3.0 if quick else 5.0)
    p = poses[:, :3, 3]
    fz = W[:, 2]
    below = surface.height(p[:, 0]) - p[:, 2]  # vertical depth under the plane (m)
    circling = tr.t >= 1.5
    target = np.array([path(t)[0] for t in tr.t])
    xy_err = np.linalg.norm(p[:, :2] - target[:, :2], axis=1) * 1e3
    plt = pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    axes[0].plot(tr.t, p[:, 2], label="tool z")
    axes[0].plot(tr.t, surface.height(p[:, 0]), "--", label="surface height under the tool")
    axes[0].set_ylabel("height (m)")
    axes[1].plot(tr.t, fz, label="sensed force z")
    axes[1].axhline(-5.0, color="k", ls="--", lw=1, label="set-point")
    axes[1].set_ylabel("force on surface (N)")
    axes[2].plot(tr.t, xy_err, label="|p_xy - p*_xy|")
    axes[2].set_ylabel("circle error (mm)")
    axes[2].set_xlabel("time (s)")
    axes[0].set_title("Operational-space control on a 10° incline: 5 cm circle in 2 s, -5 N in z")
    for ax in axes:
        ax.grid(True)
        ax.legend(fontsize=8)
    save(fig, out_dir, "ex_opspace_incline")
    n_z = surface.normal[2]
    lines = [
        "Operational-space control (Eq. 9.15), Puma 560 (nofriction) from qn with q5 = -pi/4 (tool down); "
        "x, y follow a 5 cm circle in 2 s from t = 1 s, orientation held, z force-controlled at -5 N;",
        f"  surface: 10 deg incline rising along +x, 100 N/m, frictionless, 5 cm under the start (its height is "
        f"not known to the controller); Kp = 100, Kv = 50, Kf = 20, Kvf = 20; RK4 dt = {tr.t[1] - tr.t[0]:g} s.",
        f"  contact at t = {tr.t[np.argmax(fz < 0)]:.3f} s; while circling (t >= 1.5 s): force z {fz[circling].mean():+.3f} N "
        f"mean, {fz[circling].min():+.3f} .. {fz[circling].max():+.3f} N",
        f"  tool z {p[circling, 2].min():+.4f} .. {p[circling, 2].max():+.4f} m follows the surface "
        f"({surface.height(p[circling, 0]).min():+.4f} .. {surface.height(p[circling, 0]).max():+.4f} m): "
        f"depth under it {below[circling].min() * 1e3:.2f} .. {below[circling].max() * 1e3:.2f} mm "
        f"(static: 5 N / (k cos^2 10deg) = {5.0 / (surface.k * n_z**2) * 1e3:.2f} mm)",
        f"  circle error while circling: max {xy_err[circling].max():.2f} mm, mean {xy_err[circling].mean():.2f} mm",
    ]
    return finish(out_dir, lines)


STUDIES = {
    "ex-puma-joints": ("ex. 1e: every Puma joint under its own velocity and position loop, coupling", puma_joints),
    "ex-ellipsoids": ("ex. 10: force ellipsoid vs dynamic manipulability ellipsoid of the Puma", ellipsoids),
    "ex-slow-feedforward": ("ex. 11b: torque feedforward updated at 1000 .. 5 Hz, tracking error", slow_feedforward),
    "ex-opspace-incline": ("ex. 11d: operational-space circle on an incline of unknown height, -5 N", opspace_incline),
}
