"""Studies of identification: the whole loop on a shipped arm (`symdyn study identify-puma`, `identify-panda`).

excite (an optimised Fourier trajectory) → simulate (the arm with every
inertial and friction parameter off by up to ±20 %, a 17-bit encoder,
torque noise of 2 % of each joint's rms torque) → load the CSV as a user's
(q only: low-passed and differentiated) → fit (WLS, physically consistent
parameters) → validate on a held-out random trajectory; the estimates are
compared with the truth the simulation drew.  Registered beside the
chapter's studies by the command line (`symdyn study --list`).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

__all__ = ["STUDIES", "run", "loop"]

#: 17-bit encoder (rad per count).
ENCODER = 2 * np.pi / 2**17
#: Torque noise, as a fraction of each joint's rms torque along the excitation.
NOISE = 0.02
RATE = 500.0


def loop(name: str, out_dir: Path, *, period: float = 10.0, harmonics: int = 5, seed: int = 1) -> str:
    """The loop on shipped model `name`, written into out_dir; returns the summary."""
    from ..apps.studies._plot import finish, pyplot, save
    from ..model import arms
    from .data import load_data
    from .estimate import fit
    from .parameters import base_map
    from .simulate import Trajectory, fourier, perturbed, simulate, write, write_trajectory

    out = Path(out_dir)
    robot = arms.load(name)
    lines = [f"identification of the {name} ({robot.n} joints): excite → simulate → fit → validate"]
    start = time.perf_counter()
    try:
        from .excitation import excitation

        exc = excitation(robot, period=period, harmonics=harmonics, seed=seed)
        exc.write(out / "excitation", rate=RATE)
        traj = Trajectory(*exc.sample(RATE))
        lines.append(
            f"excitation: {harmonics} harmonics, period {period:g} s, optimised in {exc.seconds:.1f} s "
            f"({exc.status}): condition number {exc.condition:.4g} (random start {exc.random_condition:.4g})"
        )
    except (ImportError, RuntimeError, ValueError) as exc_error:
        traj = fourier(robot, period=period, harmonics=harmonics, rate=RATE, seed=seed, rest=0.5)
        lines.append(f"excitation: none optimised ({exc_error}); a fixed random Fourier trajectory instead")
    excite_seconds = time.perf_counter() - start
    truth = perturbed(robot, 0.2, seed)
    clean = simulate(robot, traj, truth=truth)
    noise = NOISE * np.sqrt(np.mean(clean.tau**2, axis=0))
    data = simulate(robot, traj, truth=truth, noise=noise, quantisation=ENCODER, seed=seed)
    path = write(out / "data.csv", data, derivatives=False, robot=robot)
    check_traj = fourier(robot, period=period, harmonics=harmonics, rate=RATE, seed=seed + 100, fill=0.4)
    write_trajectory(out / "validation-trajectory.csv", check_traj)
    check = simulate(robot, check_traj, truth=truth, noise=noise, quantisation=ENCODER, seed=seed + 1)
    check_path = write(out / "validation.csv", check, derivatives=False, robot=robot)
    lines.append(
        f"simulated: every inertial and friction parameter ±20 % (seed {seed}), encoder "
        f"{ENCODER:.3g} rad, torque noise σ = {NOISE:.0%} of each joint's rms torque: "
        + ", ".join(f"{x:.3g}" for x in noise)
    )
    measured = load_data(path, joints=robot)
    held_out = load_data(check_path, joints=robot)
    result = fit(robot, measured, "wls", consistent=True)
    validation = result.validate(held_out)
    result.write(out, validation)
    true = base_map(robot).values(truth)
    z = (result.base.values - true) / result.base.std
    rel = np.abs(result.base.values - true) / np.maximum(np.abs(true), 1e-12)
    inside = np.mean(np.abs(z) <= 1.96)
    lines += [
        f"fit: {result.samples} samples, WLS in {result.seconds:.2f} s, consistent parameters in "
        f"{result.consistent_seconds:.2f} s; condition number {result.condition:.4g}",
        f"base parameters vs the truth: {inside:.0%} inside their 95 % intervals; median relative error "
        f"{np.median(rel):.2g}, median relative σ {np.median(result.base.relative):.2g} %",
        "residual rms per joint: " + ", ".join(f"{x:.3g}" for x in result.rms),
        *validation.lines(),
        f"consistent model: base parameters moved by {result.consistent.moved:.3g}; smallest pseudo-inertia "
        f"eigenvalue {min(result.consistent.margins):.3g}",
        f"excitation (or fallback) {excite_seconds:.1f} s; details in summary.txt, parameters.json and the figures",
    ]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(max(6, 0.12 * len(z)), 3))
    ax.bar(range(len(z)), z, color=np.where(np.abs(z) <= 1.96, "C0", "C3"))
    ax.axhline(1.96, color="0.5", lw=0.6, ls="--")
    ax.axhline(-1.96, color="0.5", lw=0.6, ls="--")
    ax.set_xticks(range(len(z)), result.base.names, rotation=90, fontsize=6)
    ax.set_ylabel("(estimate − truth) / σ")
    ax.set_title(f"{name}: base parameter errors in standard deviations ({inside:.0%} within ±1.96)", fontsize=9)
    save(fig, out, "errors")
    report = finish(out, lines + ["", (out / "summary.txt").read_text()])
    return report


STUDIES = {
    "identify-puma": (
        "identification loop on the Puma 560: excite, simulate, fit, validate",
        lambda out: loop("puma560", out),
    ),
    "identify-panda": (
        "identification loop on the Panda: excite, simulate, fit, validate",
        lambda out: loop("panda", out),
    ),
}


def run(name: str, out_dir: Path) -> str:
    """Run study `name` into out_dir/name; return its summary."""
    if name not in STUDIES:
        raise KeyError(f"unknown study {name!r}: identification studies are {', '.join(sorted(STUDIES))}")
    folder = Path(out_dir) / name
    folder.mkdir(parents=True, exist_ok=True)
    return STUDIES[name][1](folder)
