"""Studies: the chapter's motor-side exercises — root locus of the velocity loop
(ex. 1b), a voltage-driven motor (ex. 1c), a series-elastic actuator (ex. 12).

The numbers come from `symdyn.apps.exercises_motor` and the simulator of
`symdyn.apps.control`; this module sets the scenes, plots and reports.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import signal

from .. import control as C
from .. import exercises_motor as X
from ._plot import finish, pyplot, save

PERIOD = 1e-3


def velocity_step(drive: C.JointDrive, Kv: float, T: float, demand: float = 0.5) -> C.Trace:
    """P velocity loop of `drive` at 1 kHz, one sample of delay, speed step `demand` rad/s at t = 0."""
    loop = C.VelocityLoop(drive, Kv, period=PERIOD)
    return C.simulate(drive.accel, lambda t, q, qd: loop(demand, qd), T, [0.0], dt=PERIOD, period=PERIOD, delay=1)


def decay_per_sample(t, w, early=(0.01, 0.02), late=(0.03, 0.04)) -> float:
    """Growth (> 1) or decay (< 1) factor per sample of an oscillation: the ratio of its
    peak-to-peak over two windows (s), to the power 1/(samples between them)."""
    span = lambda lo, hi: np.ptp(w[(t >= lo - 1e-9) & (t <= hi + 1e-9)])  # noqa: E731
    return (span(*late) / span(*early)) ** (PERIOD / (late[0] - early[0]))


def root_locus(out_dir: Path, quick: bool = False) -> str:
    """Root locus of the sampled shoulder velocity loop, P and PI: the largest stable gain, confirmed by simulation."""
    drive = C.JointDrive(Tc=(0.0, 0.0))
    linear = C.JointDrive(Tc=(0.0, 0.0), tau_max=np.inf)
    loop = X.SampledVelocityLoop(drive, PERIOD)
    k_p, k_pi = loop.max_gain(), loop.max_gain(10.0)
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    circle = np.linspace(0, 2 * np.pi, 200)
    a1.plot(np.cos(circle), np.sin(circle), "k:", lw=0.8, label="unit circle")
    for ratio, kmax, style, name in ((None, k_p, ".", "P"), (10.0, k_pi, "x", "PI, Ki = 10 Kv")):
        ki = lambda K: None if ratio is None else ratio * K  # noqa: E731
        poles = np.array([loop.poles(K, ki(K)) for K in np.linspace(0, 1.5 * kmax, 60)])
        a1.plot(poles.real.ravel(), poles.imag.ravel(), style, ms=3, label=f"{name}, Kv 0 .. 1.5 Kv,max")
        at = loop.poles(kmax, ki(kmax))
        a1.plot(at.real, at.imag, "o", mfc="none", ms=9, label=f"{name} at Kv,max = {kmax:.3f} A·s/rad")
    a1.set_xlabel("Re z")
    a1.set_ylabel("Im z")
    a1.set_aspect("equal")
    a1.grid(True)
    a1.set_title("closed-loop poles, 1 kHz, 1 sample delay")
    a1.legend(fontsize=7, loc="lower left")
    lines = [
        f"Velocity loop of the Puma shoulder (Table 9.2: Km = {drive.Km}, J = {drive.J:.3e} kg·m², "
        f"Bm = {drive.Bm}), 1 kHz, one sample of computation delay, ZOH:",
        f"  sampled motor pole a = exp(-Bm T/J) = {loop.a:.6f}, gain b = Km(1-a)/Bm = {loop.b:.5f} rad/s per A",
        f"  P:  characteristic z^2 - a z + b Kv = 0; largest stable Kv = {k_p:.4f} A·s/rad (1/b = {1 / loop.b:.4f});"
        f" poles there at angle {np.degrees(np.angle(loop.poles(k_p)).max()):.1f} deg "
        f"(oscillation {np.angle(loop.poles(k_p)).max() / (2 * np.pi * PERIOD):.0f} Hz)",
        f"  PI (Ki = 10 Kv): largest stable Kv = {k_pi:.4f} A·s/rad",
        "  without the delay the P loop is first order and stable for every Kv: the delay sets the limit.",
        "  simulation (P, 0.5 rad/s step, no torque limit: the linear loop), speed oscillation's decay per "
        "sample from its peak-to-peak over 10..20 ms and 30..40 ms, against the largest |pole|:",
    ]
    for factor in (0.8, 1.0, 1.2):
        tr = velocity_step(linear, factor * k_p, 0.04)
        rate = decay_per_sample(tr.t, tr.qd[:, 0])
        a2.plot(tr.t * 1e3, tr.qd[:, 0], label=f"Kv = {factor:g} Kv,max ({factor * k_p:.3f})")
        lines.append(
            f"    Kv = {factor:3g} x Kv,max: {rate:.5f} per sample (|pole| {np.abs(loop.poles(factor * k_p)).max():.5f})"
        )
    a2.axhline(0.5, color="k", ls="--", lw=0.8, label="demand")
    a2.set_xlabel("time (ms)")
    a2.set_ylabel("motor speed (rad/s)")
    a2.grid(True)
    a2.legend(fontsize=8)
    a2.set_title("P loop: simulated step response")
    save(fig, out_dir, "ex_root_locus")
    return finish(out_dir, lines)


def voltage_motor(out_dir: Path, quick: bool = False) -> str:
    """Velocity loop of a voltage-driven motor (1 mH, 1.6 Ω, back EMF) against current control."""
    drive = C.JointDrive()
    Kv = 0.6  # A·s/rad, the current loop of control-velocity-loop
    Kvv = Kv * X.VoltageDrive(drive).R  # V·s/rad: the same loop gain through R
    cases = {
        "current control (ideal amplifier)": X.current_loop(drive, Kv),
        "voltage control, with back EMF": X.VoltageDrive(drive).closed_loop(Kvv),
        "voltage control, back EMF ignored": X.VoltageDrive(drive, back_emf=False).closed_loop(Kvv),
    }
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    t = np.linspace(0, 0.03, 600)
    w = np.logspace(0, 4.5, 400)
    lines = [
        f"Puma shoulder motor (Km = Kb = {drive.Km} N·m/A, J = {drive.J:.3e} kg·m², Bm = {drive.Bm} N·m·s/rad), "
        f"winding L = 1 mH, R = 1.6 Ohm; P speed loop: current {Kv} A·s/rad, voltage {Kvv:.2f} V·s/rad "
        "(= R x the current gain: the same loop gain without back EMF)."
    ]
    for name, (num, den) in cases.items():
        _, y = signal.step((num, den), T=t)
        a1.plot(t * 1e3, 10 * y, label=name)
        mag = np.abs(np.polyval(num, 1j * w) / np.polyval(den, 1j * w))
        a2.semilogx(w / (2 * np.pi), 20 * np.log10(mag), label=name)
        bw = X.bandwidth(num, den)
        dc = np.polyval(num, 0) / np.polyval(den, 0)
        poles = np.sort(np.roots(den).real)
        lines.append(
            f"  {name:36s} bandwidth {bw:7.1f} rad/s ({bw / (2 * np.pi):5.1f} Hz), DC gain {dc:.4f}, "
            f"poles {', '.join(f'{p:.1f}' for p in poles)} /s"
        )
    v = X.VoltageDrive(drive)
    lines += [
        f"  open loop: current drive time constant J/Bm = {drive.J / drive.Bm:.3f} s; voltage drive J/(Bm + Km Kb/R)"
        f" = {drive.J / v.damping * 1e3:.2f} ms: back EMF adds Km Kb/R = {drive.Km**2 / 1.6:.4f} N·m·s/rad of"
        f" damping ({drive.Km**2 / 1.6 / drive.Bm:.0f} x Bm); electrical time constant L/R = {1e-3 / 1.6 * 1e3:.3f} ms"
    ]
    a1.axhline(10, color="k", ls="--", lw=0.8, label="demand")
    a1.set_xlabel("time (ms)")
    a1.set_ylabel("motor speed (rad/s)")
    a1.set_title("10 rad/s speed step")
    a2.set_xlabel("frequency (Hz)")
    a2.set_ylabel("|Ω/Ω*| (dB)")
    a2.set_title("closed-loop frequency response")
    a2.axhline(-3, color="gray", ls=":", lw=0.8)
    for ax in (a1, a2):
        ax.grid(True, which="both")
        ax.legend(fontsize=8)
    save(fig, out_dir, "ex_voltage_motor")
    return finish(out_dir, lines)


def touch(sea: C.SEA, T: float, force: float = 5.0) -> tuple[C.Trace, X.GuardedTouch]:
    """The guarded touch of `sea` (obstacle at an unknown distance), sampled at 1 kHz."""
    guard = X.GuardedTouch(sea, force)
    return C.simulate(sea.accel, guard, T, [0.0, 0.0], dt=1e-3, period=1e-3), guard


def collision(sea: C.SEA, K, force: float, T: float, at: float = 3.0) -> C.Trace:
    """The LQR-held SEA at rest at its goal (1 m), hit by a constant force on the load from t = `at`."""
    control = sea.controller(K)

    def accel(t, q, qd, u):
        a = sea.accel(t, q, qd, u)
        a[..., 1] += np.where(t >= at, force / sea.m_load, 0.0)
        return a

    return C.simulate(accel, control, T, [1.0, 1.0], dt=1e-3)


def series_elastic(out_dir: Path, quick: bool = False) -> str:
    """Series-elastic actuator: touch at unknown distance, settle at 5 N; Bode of X2/X1; collision as a force step."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    lines = [
        "Series-elastic actuator (RVC3's: motor 0.5 kg, load 1 kg, spring 5 N/m); motor force limit raised to "
        "10 N (5 N at rest needs u = 5 N; the book's 2 N could not hold it).",
        "  (b) guarded touch: approach at 0.2 m/s, spring-force admittance Ka = 2/sqrt(k m), contact latches "
        "the 5 N set-point:",
    ]
    for obstacle in (0.3, 0.6, 1.0):
        sea = C.SEA(obstacle=obstacle, force_limit=10.0)
        tr, guard = touch(sea, 6.0 if quick else 10.0)
        fs = sea.spring_force(tr.q)
        axes[0, 0].plot(tr.t, tr.q[:, 1], label=f"load, object at {obstacle} m")
        axes[0, 1].plot(tr.t, fs, label=f"object at {obstacle} m")
        inside = np.abs(fs - 5.0) > 0.05
        settle = tr.t[inside].max() if inside.any() else 0.0
        lines.append(
            f"    object at {obstacle} m: contact at {guard.contact_time:.3f} s, spring force within 0.05 N of 5 N "
            f"from {settle:.2f} s, final {fs[-1]:.6f} N, wall force {float(sea.wall_force(tr.q[-1], tr.qd[-1])):.6f} N, "
            f"load at {tr.q[-1, 1]:.6f} m"
        )
    axes[0, 0].set_ylabel("load position (m)")
    axes[0, 0].set_title("(b) touch an object, settle at 5 N")
    axes[0, 1].set_ylabel("spring force (N)")
    axes[0, 1].axhline(5, color="k", ls="--", lw=0.8, label="5 N")
    w = np.logspace(-1, 2, 500)
    lines.append("  (c) X2/X1 = k/(m2 s^2 + c s + k), spring damping ratio 0.05 (the model has none): resonance")
    for k, m in ((5.0, 1.0), (20.0, 1.0), (5.0, 0.25), (80.0, 2.0)):
        H = X.sea_frequency_response(k, m, w)
        axes[1, 0].semilogx(w, 20 * np.log10(np.abs(H)), label=f"k = {k:g} N/m, m2 = {m:g} kg")
        peak = w[np.argmax(np.abs(H))]
        lines.append(
            f"    k = {k:5g} N/m, m2 = {m:4g} kg: peak at {peak:7.3f} rad/s (sqrt(k/m2) = {np.sqrt(k / m):.3f}), "
            f"{20 * np.log10(np.abs(H).max()):.1f} dB; above it the load falls off at -40 dB/decade"
        )
    axes[1, 0].set_xlabel("frequency (rad/s)")
    axes[1, 0].set_ylabel("|X2/X1| (dB)")
    axes[1, 0].set_title("(c) load position / motor position")
    sea = C.SEA()
    K = sea.lqr()
    tr = collision(sea, K, -1.0, 12.0)
    rest = X.collision_steady_state(sea, K, -1.0)
    fs = sea.spring_force(tr.q)
    axes[1, 1].plot(tr.t, tr.q[:, 1], label="load position (m)")
    axes[1, 1].plot(tr.t, tr.tau[:, 0], label="motor force (N)")
    axes[1, 1].plot(tr.t, fs, label="spring force (N)")
    axes[1, 1].set_ylabel("position (m), force (N)")
    axes[1, 1].set_title("(d) collision: -1 N step on the load at 3 s")
    lines.append(
        f"  (d) LQR K = {np.round(K, 3).tolist()} holding x = 1 m; a -1 N step on the load at 3 s: load moves "
        f"to {tr.q[-1, 1]:.4f} m (rest state {rest[1]:.4f}), motor to {tr.q[-1, 0]:.4f} m ({rest[0]:.4f}), "
        f"spring force {fs[-1]:.4f} N, peak load excursion {1 - tr.q[:, 1].min():.4f} m, "
        f"peak |motor force| {np.abs(tr.tau[:, 0]).max():.3f} N"
    )
    for ax in axes.ravel():
        ax.grid(True, which="both")
        ax.legend(fontsize=7)
    for ax in (axes[0, 0], axes[0, 1], axes[1, 1]):
        ax.set_xlabel("time (s)")
    save(fig, out_dir, "ex_sea")
    return finish(out_dir, lines)


STUDIES = {
    "ex-root-locus": ("ex. 1b: root locus of the sampled velocity loop, largest stable P and PI gain", root_locus),
    "ex-voltage-motor": ("ex. 1c: voltage-driven motor with back EMF vs current control", voltage_motor),
    "ex-sea": ("ex. 12: series-elastic actuator: touch and settle at 5 N, Bode of X2/X1, collision", series_elastic),
}
