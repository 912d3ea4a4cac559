"""Studies: the chapter-9 analyses of the Puma 560 and the exercise-3 two-link arm, with figures.

Each study writes `analysis_*.png` and `summary.txt` into its folder and
returns the summary; `quick=True` uses coarse grids (for tests).  The
numbers come from `symdyn.apps.analysis`; this module only sweeps, plots and
reports.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...model import arms
from .. import analysis as A
from ._plot import finish, pyplot, save

PUMA_PAYLOAD = (2.5, (0.0, 0.0, 0.1))  # kg, m in frame {6}: the book's example


# --------------------------------------------------------------------------- plotting


def _surface(fig, where, sweep, k, names, title):
    ax = fig.add_subplot(*where, projection="3d")
    X, Y = np.meshgrid(*sweep.axes, indexing="ij")
    ax.plot_surface(X, Y, sweep.values[..., k], cmap="viridis", linewidth=0)
    ax.set_xlabel(names[0])
    ax.set_ylabel(names[1])
    ax.set_title(title)
    return ax


def _maps_and_curve(out_dir, name, grid, unit, curve, title):
    """Two surfaces of a 2-D sweep (in `unit`) beside one inertia element against
    the second swept joint (a 1-D sweep), saved as out_dir/name.png."""
    names = tuple(f"q{j + 1} (rad)" for j in grid.joints)
    fig = pyplot().figure(figsize=(13, 4))
    for k, label in enumerate(grid.labels):
        _surface(fig, (1, 3, k + 1), grid, k, names, f"{label} ({unit})")
    ax = fig.add_subplot(1, 3, 3)
    ax.plot(curve.axes[0], curve.values[:, 0])
    ax.set_xlabel(names[1])
    ax.set_ylabel(f"{curve.labels[0]} (kg·m²)")
    ax.set_title(title)
    ax.grid(True)
    save(fig, out_dir, name)


def _extreme_line(e: A.Extreme, unit: str, names=("q2", "q3")) -> str:
    at = lambda q: ", ".join(f"{n} = {v:+.2f}" for n, v in zip(names, q))  # noqa: E731
    ratio = "" if np.isnan(e.ratio) else f", max/min {e.ratio:.3f}"
    return (
        f"  {e.label}: min {e.min:+.3f} {unit} at ({at(e.argmin)}), max {e.max:+.3f} {unit} at ({at(e.argmax)}){ratio}"
    )


# --------------------------------------------------------------------------- studies


def gravity_load(out_dir: Path, quick: bool = False) -> str:
    """Puma gravity load of joints 2 and 3 over (q2, q3), on Earth, on the Moon and hanging upside down."""
    puma = arms.load("puma560")
    res = 9 if quick else 73
    cases = {
        "Earth (g = 9.81)": puma,
        "Moon (g = 1.62)": A.with_gravity(puma, A.LUNAR_GRAVITY),
        "inverted base Rx(pi)": A.inverted(puma),
    }
    maps = {name: A.gravity_load_map(robot, resolution=res) for name, robot in cases.items()}
    plt = pyplot()
    fig = plt.figure(figsize=(10, 4.2))
    earth = maps["Earth (g = 9.81)"]
    for k, label in enumerate(earth.labels):
        _surface(fig, (1, 2, k + 1), earth, k, ("q2 (rad)", "q3 (rad)"), f"{label} (N·m), q = [0 q2 q3 0 0 0]")
    save(fig, out_dir, "analysis_gravity_load")
    lines = [f"Puma 560 gravity load of joints 2, 3 over q2, q3 in [-pi, pi] (others 0), {res}x{res} grid:"]
    for name, sweep in maps.items():
        lines.append(f" {name}:")
        lines += [_extreme_line(e, "N·m") for e in sweep.extremes()]
    g_qz = A.model_functions(puma).G(puma.qz)
    lines.append(f" at qz: G2 = {g_qz[1]:.3f} N·m, G3 = {g_qz[2]:.3f} N·m")
    return finish(out_dir, lines)


def inertia_variation(out_dir: Path, quick: bool = False) -> str:
    """Puma M11, M12 over (q2, q3) and M22 over q3, with max/min ratios."""
    puma = arms.load("puma560")
    res = 9 if quick else 73
    grid = A.inertia_map(puma, resolution=res)
    curve = A.inertia_curve(puma, resolution=19 if quick else 181)
    _maps_and_curve(out_dir, "analysis_inertia", grid, "kg·m²", curve, "M22 against q3")
    lines = [f"Puma 560 inertia variation (rotor inertia G²Jm included), {res}x{res} grid over [-pi, pi]:"]
    lines += [_extreme_line(e, "kg·m²") for e in grid.extremes()]
    lines += [_extreme_line(e, "kg·m²", ("q3",)) for e in curve.extremes()]
    lines.append("  (max/min ratio omitted where the element changes sign)")
    return finish(out_dir, lines)


def payload(out_dir: Path, quick: bool = False) -> str:
    """Loaded/unloaded M and G of the Puma at qn for a 2.5 kg payload, both payload semantics."""
    puma = arms.load("puma560")
    m, p = PUMA_PAYLOAD
    effects = {
        "book (replace last link)": A.payload_effect(puma, m, p, puma.qn),
        "additive (point mass added)": A.payload_effect(puma, m, p, puma.qn, additive=True),
    }
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    for ax, (name, e) in zip(axes, effects.items()):
        shown = np.where(np.isnan(e.M_ratio), 1.0, e.M_ratio)
        im = ax.imshow(np.log10(np.abs(shown)), cmap="magma", vmin=0)
        for (i, j), r in np.ndenumerate(e.M_ratio):
            ax.text(j, i, "-" if np.isnan(r) else f"{r:.2g}", ha="center", va="center", fontsize=7, color="c")
        ax.set_title(f"M loaded/unloaded, {name}", fontsize=9)
        ax.set_xticks(range(6), [f"{j + 1}" for j in range(6)])
        ax.set_yticks(range(6), [f"{j + 1}" for j in range(6)])
        fig.colorbar(im, ax=ax, label="log10 ratio")
    width = 0.38
    for k, (name, e) in enumerate(effects.items()):
        axes[2].bar(np.arange(6) + (k - 0.5) * width, e.G_ratio, width, label=name)
    axes[2].set_xticks(range(6), [f"G{j + 1}" for j in range(6)])
    axes[2].set_yscale("log")
    axes[2].set_ylabel("loaded / unloaded")
    axes[2].set_title("gravity load ratio (none where unloaded G = 0)")
    axes[2].legend(fontsize=8)
    save(fig, out_dir, "analysis_payload")
    lines = [f"Puma 560 at qn with a {m} kg payload at {p} m (frame 6):"]
    for name, e in effects.items():
        fmt = lambda v: "  ".join("   -  " if np.isnan(x) else f"{x:6.3f}" for x in v)  # noqa: E731
        lines.append(f" {name}:")
        lines.append(f"  diag(M1)/diag(M0) = {fmt(np.diag(e.M_ratio))}")
        lines.append(f"  G1/G0             = {fmt(e.G_ratio)}")
    return finish(out_dir, lines)


def base_wrench(out_dir: Path, quick: bool = False) -> str:
    """The wrench the base exerts on the Puma at rest (qz, qn) and moving (qn, 1 rad/s on every joint)."""
    puma = arms.load("puma560")
    states = {
        "qz at rest": (puma.qz, None, None),
        "qn at rest": (puma.qn, None, None),
        "qn, qd = 1 rad/s": (puma.qn, np.ones(6), None),
    }
    wrenches = {name: A.base_wrench(puma, *state) for name, state in states.items()}
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    width = 0.27
    for k, (name, W) in enumerate(wrenches.items()):
        axes[0].bar(np.arange(3) + (k - 1) * width, W[:3], width, label=name)
        axes[1].bar(np.arange(3) + (k - 1) * width, W[3:], width, label=name)
    axes[0].set_xticks(range(3), ["fx", "fy", "fz"])
    axes[0].set_ylabel("N")
    axes[0].set_title("base force")
    axes[1].set_xticks(range(3), ["nx", "ny", "nz"])
    axes[1].set_ylabel("N·m")
    axes[1].set_title("base moment about frame {0}")
    axes[0].legend(fontsize=8)
    save(fig, out_dir, "analysis_base_wrench")
    mass = A.total_mass(puma)
    lines = [
        f"Puma 560 total mass {mass:.2f} kg, weight {mass * A.EARTH_GRAVITY:.2f} N",
        "base wrench [fx fy fz (N)  nx ny nz (N·m)] on link 1, frame {0}:",
    ]
    lines += [f"  {name:18s} {np.array2string(W, precision=2, suppress_small=True)}" for name, W in wrenches.items()]
    return finish(out_dir, lines)


def manipulability(out_dir: Path, quick: bool = False) -> str:
    """Puma acceleration ellipsoid at qn (3-D) and Asada's measure over translational, rotational and all axes."""
    puma = arms.load("puma560")
    e = A.acceleration_ellipsoid(puma, puma.qn)
    measures = {axes: float(A.dynamic_manipulability(puma, puma.qn, axes)) for axes in A.AXES}
    _, q = A.joint_grid(puma, (2,), 19 if quick else 121, pose=puma.qn, span=(-np.pi, 0.0))
    plt = pyplot()
    fig = plt.figure(figsize=(10, 4.2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    ax.plot_surface(*e.surface(), alpha=0.5, color="tab:blue", linewidth=0)
    for k in range(3):
        ax.plot(*np.outer([-1, 1], e.axes[:, k] * e.radii[k]).T, color="k")
    lim = e.radii.max()
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_zlim(-lim, lim)
    ax.set_xlabel("ẍ")
    ax.set_ylabel("ÿ")
    ax.set_zlabel("z̈")
    ax.set_title("acceleration ellipsoid at qn\n(m/s² per N·m, world frame)", fontsize=9)
    ax = fig.add_subplot(1, 2, 2)
    for axes in A.AXES:
        ax.semilogy(q[:, 2], A.dynamic_manipulability(puma, q, axes), label=axes)
    ax.set_xlabel("q3 (rad), other joints at qn")
    ax.set_ylabel("Asada measure min/max eig Mx")
    ax.legend()
    ax.grid(True)
    save(fig, out_dir, "analysis_manipulability")
    lines = ["Puma 560 dynamic manipulability at qn (Asada, min/max eigenvalue of pinv(J)' M pinv(J)):"]
    lines += [
        f"  {axes:13s} {value:.4f}" + ("  (default)" if axes == "translational" else "")
        for axes, value in measures.items()
    ]
    lines.append(f" acceleration ellipsoid (translational, J M^-1 M^-T J'): radii {np.round(e.radii, 4)} m/s² per N·m")
    lines.append(f"  longest axis {np.round(e.axes[:, -1], 3)}, shortest {np.round(e.axes[:, 0], 3)} (world)")
    return finish(out_dir, lines)


def joint_dynamics(out_dir: Path, quick: bool = False) -> str:
    """Motor-side transfer functions 1/(J's + B') of the Puma's joints at qn, and J' against q3."""
    puma = arms.load("puma560")
    tf = A.joint_transfer_functions(puma, puma.qn)
    _, q = A.joint_grid(puma, (2,), 19 if quick else 121, pose=puma.qn)
    J_sweep = np.array([A.joint_transfer_functions(puma, qi).J for qi in q])
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    w = np.logspace(-1, 3, 200)
    for j in range(puma.n):
        axes[0].loglog(w, 1 / np.abs(1j * w * tf.J[j] + tf.B[j]), label=f"joint {j + 1}")
    axes[0].set_xlabel("ω (rad/s)")
    axes[0].set_ylabel("|Ω/U| (rad/s per N·m)")
    axes[0].set_title("motor side 1/(J's + B') at qn")
    axes[0].legend(fontsize=7)
    axes[0].grid(True)
    for j in range(3):
        axes[1].plot(q[:, 2], J_sweep[:, j] / tf.J[j], label=f"joint {j + 1}")
    axes[1].set_xlabel("q3 (rad), other joints at qn")
    axes[1].set_ylabel("J'(q) / J'(qn)")
    axes[1].set_title("effective motor inertia")
    axes[1].legend()
    axes[1].grid(True)
    save(fig, out_dir, "analysis_joint_dynamics")
    lines = [
        "Puma 560 motor-side joint dynamics at qn: J' = Jm + M_jj,link/G² (rotor counted once), B' = B",
        " joint     J' (kg·m²)   B' (N·m·s/rad)  pole (rad/s)  tau (s)   M_jj,link (kg·m²)",
    ]
    lines += [
        f"  {j + 1}    {tf.J[j]:.4e}    {tf.B[j]:.4e}    {tf.pole[j]:8.3f}   {tf.time_constant[j]:7.4f}"
        f"    {tf.M_link[j]:.4e}"
        for j in range(puma.n)
    ]
    span = J_sweep.max(0) / J_sweep.min(0)
    lines.append(
        f" J' max/min over q3 (others at qn): joint 1 {span[0]:.3f}, joint 2 {span[1]:.3f}, joint 3 {span[2]:.3f}"
    )
    return finish(out_dir, lines)


def twolink_exercise(out_dir: Path, quick: bool = False) -> str:
    """Exercise 3: the small two-link arm's gravity load over (q1, q2) and its M11 against q2."""
    arm = A.twolink_exercise_arm()
    res = 9 if quick else 73
    grid = A.gravity_load_map(arm, joints=(0, 1), resolution=res)
    curve = A.inertia_curve(arm, element=(0, 0), joint=1, resolution=19 if quick else 181)
    _maps_and_curve(out_dir, "analysis_twolink", grid, "N·m", curve, "joint-1 inertia against q2")
    link1, link2 = arm.links
    lines = [
        f"Exercise 3 arm: m1 = {link1.m} kg, m2 = {link2.m} kg, COM 8 cm from each joint, "
        f"a1 = {link1.a} m, a2 = {link2.a} m (our choice: COM at mid-link), g = 9.81:"
    ]
    lines += [_extreme_line(e, "N·m", ("q1", "q2")) for e in grid.extremes()]
    lines += [_extreme_line(e, "kg·m²", ("q2",)) for e in curve.extremes()]
    return finish(out_dir, lines)


STUDIES = {
    "gravity-load": ("Puma gravity load of joints 2, 3 over (q2, q3); lunar and inverted", gravity_load),
    "inertia-variation": ("Puma M11, M12 over (q2, q3), M22 over q3, max/min ratios", inertia_variation),
    "payload": ("loaded/unloaded M and G of the Puma at qn, both payload semantics", payload),
    "base-wrench": ("wrench on the Puma's base at rest and moving; total mass", base_wrench),
    "manipulability": ("acceleration ellipsoid and Asada's dynamic manipulability", manipulability),
    "joint-dynamics": ("motor-side transfer functions 1/(J's + B') of the Puma's joints", joint_dynamics),
    "twolink-exercise": ("exercise 3: two-link gravity load over (q1, q2), M11 against q2", twolink_exercise),
}
