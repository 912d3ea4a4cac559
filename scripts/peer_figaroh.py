"""Side by side with a peer: symdyn.identify and FIGAROH on the same simulated UR5 data (issue 24).

    .venv/bin/python scripts/peer_figaroh.py [--figaroh-python /tmp/figv/bin/python] [--out /tmp/peer_figaroh]

symdyn simulates the shipped UR5 (symdyn/model/arms/data/ur5.urdf, tip tool0) with its friction and
rotor inertia set to zero — FIGAROH's Pinocchio regressor models rigid bodies only unless told
otherwise, so both tools see the same physics — perturbed ±20 % (seed 0) as the "true" arm, along
two fixed Fourier trajectories (10 s at 100 Hz: seed 1 to fit, seed 2 held out), with 2 % Gaussian
torque noise per joint.  The data go to OUT/data.npz (and the true arm to OUT/truth.urdf); FIGAROH
(installed in its own venv, never in symdyn's) runs `scripts/peer_figaroh_side.py` on them.  Prints
one Markdown table: base parameters, condition number, residual RMS per joint on the fitting and
the held-out data, relative σ, the estimates' calibration against each tool's own true base
parameters, and the fit's wall time (regressor + solve; the median of --repeats runs, NumPy on one BLAS
thread in both tools).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
#: FIGAROH's NumPy on one BLAS thread, as symdyn's fit runs by default (blas_threads=1): on shared cores
#: OpenBLAS's waiting threads cost more than they save, and the two tools are timed alike
ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--figaroh-python", default="/tmp/figv/bin/python")
    p.add_argument("--out", default="/tmp/peer_figaroh")
    p.add_argument("--noise", type=float, default=0.02, help="torque noise σ as a fraction of each joint's RMS")
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    from symdyn.identify import fit, simulate
    from symdyn.identify.parameters import base_map
    from symdyn.identify.simulate import fourier, perturbed
    from symdyn.model import arms

    robot = arms.load("ur5").nofriction(all=True)
    robot = dataclasses.replace(robot, links=tuple(dataclasses.replace(l, Jm=0) for l in robot.links))
    truth = perturbed(robot, 0.2, seed=0)
    sets = {}
    for name, seed in (("fit", 1), ("val", 2)):
        traj = fourier(robot, period=10.0, harmonics=5, rate=100.0, seed=seed)
        clean = simulate(robot, traj, truth=truth)
        sigma = args.noise * np.sqrt(np.mean(clean.tau**2, axis=0))
        sets[name] = (simulate(robot, traj, truth=truth, noise=sigma, seed=10 + seed), clean)
    np.savez(
        out / "data.npz",
        **{f"{k}_{a}": getattr(d, a) for k, (d, _) in sets.items() for a in ("t", "q", "qd", "qdd", "tau")},
        **{f"{k}_tau_clean": c.tau for k, (_, c) in sets.items()},
    )
    (out / "truth.urdf").write_text(truth.to_urdf())
    data, val = sets["fit"][0], sets["val"][0]
    clean_val = sets["val"][1].tau

    # ---- symdyn: the generated C regressor is compiled and the base map cached before the clock
    fit(robot, data, "ols", consistent=False)
    bmap = base_map(robot)
    sym = {}
    for method in ("ols", "wls"):
        times = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            res = fit(robot, data, method, consistent=False)
            times.append(time.perf_counter() - t0)
        pred = res.validate(val).predicted
        sym[method] = dict(
            res=res,
            seconds=float(np.median(times)),
            pred=pred,
            rms_fit=res.rms,
            rms_val=np.sqrt(np.mean((pred - val.tau) ** 2, axis=0)),
        )
    sym_true, sym_nom = bmap.values(truth), bmap.values(robot)

    # ---- FIGAROH, in its own environment
    urdf = ROOT / "symdyn/model/arms/data/ur5.urdf"
    t0 = time.perf_counter()
    run = subprocess.run(
        [
            args.figaroh_python,
            str(ROOT / "scripts/peer_figaroh_side.py"),
            str(out / "data.npz"),
            str(urdf),
            str(out / "truth.urdf"),
            str(out / "figaroh.json"),
            str(args.repeats),
        ],
        capture_output=True,
        text=True,
        env={**os.environ, **ONE_THREAD},
    )
    if run.returncode:
        sys.exit(f"FIGAROH's side failed:\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}")
    fig_wall = time.perf_counter() - t0
    fig = json.loads((out / "figaroh.json").read_text())
    fig_pred = np.load(out / "figaroh.npz")

    def joints(x):
        return " / ".join(f"{v:.3g}" for v in x)

    def calib(values, std, true):
        z = np.abs((np.asarray(values) - true) / np.asarray(std))
        return f"{np.mean(z <= 1.96):.0%}"

    rows = []
    for method in ("ols", "wls"):
        s = sym[method]
        r = s["res"]
        rel = np.abs(r.base.relative)[np.abs(sym_true) > 1e-9]
        rows.append(
            (
                f"symdyn {method.upper()} (IA, FV, FS, FO in)",
                len(r.base),
                f"{_cond_unweighted(r):.3g}",
                joints(s["rms_fit"]),
                joints(s["rms_val"]),
                f"{np.median(rel):.2g} / {np.max(rel):.3g}",
                calib(r.base.values, r.base.std, sym_true),
                joints(np.sqrt(np.mean((s["pred"] - clean_val) ** 2, axis=0))),
                f"{s['seconds']:.3f}",
            )
        )
    for label, text in (("rigid", "rigid bodies only"), ("motor", "+ fv, fs, Ia, off")):
        c = fig["configs"][label]
        for method in ("ols", "wls"):
            m = c["methods"][method]
            rel = np.abs(np.asarray(m["relative"]))[np.abs(np.asarray(c["true"])) > 1e-9]
            pred = fig_pred[f"{label}_{method}"]
            secs = c["seconds_regressor"] + c["seconds_qr_ols"] + (c["seconds_wls"] if method == "wls" else 0)
            rows.append(
                (
                    f"FIGAROH {method.upper()} ({text})",
                    len(m["values"]),
                    f"{c['condition']:.3g}",
                    joints(m["rms_fit"]),
                    joints(m["rms_val"]),
                    f"{np.median(rel):.2g} / {np.max(rel):.3g}",
                    calib(m["values"], m["std"], np.asarray(c["true"])),
                    joints(np.sqrt(np.mean((pred - clean_val) ** 2, axis=0))),
                    f"{secs:.3f} ({c['seconds_regressor']:.2f} regressor)",
                )
            )
    head = (
        "tool, least squares",
        "base parameters",
        "condition (unweighted base regressor)",
        "residual RMS per joint, fit data (N·m)",
        "RMS vs measured τ, held-out (N·m)",
        "relative σ % median / max (true value ≠ 0)",
        "true base parameters inside ±1.96σ",
        "RMS vs noise-free τ, held-out (N·m)",
        "fit wall time (s)",
    )
    print(
        f"UR5 (symdyn/model/arms/data/ur5.urdf, tip tool0), no friction, no rotor inertia; true arm the URDF "
        f"±20 % (seed 0); {data.N} samples to fit, {val.N} held out; torque noise {args.noise:.0%} of each "
        f"joint's RMS: σ = {joints(np.sqrt(np.mean(sets['fit'][1].tau ** 2, axis=0)) * args.noise)} N·m"
    )
    print(
        f"FIGAROH {fig['figaroh']} with Pinocchio {fig['pinocchio']}; its RNEA on truth.urdf vs symdyn's "
        f"noise-free τ: max rel. difference {fig['physics_max_rel']:.1e}; its subprocess took {fig_wall:.1f} s; load average "
        f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs"
    )
    print()
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for row in rows:
        print("| " + " | ".join(str(x) for x in row) + " |")
    print()

    # ---- the estimates: predicted torques agree; coinciding base parameters
    for label in ("rigid", "motor"):
        for method in ("ols", "wls"):
            d = np.sqrt(np.mean((fig_pred[f"{label}_{method}"] - sym[method]["pred"]) ** 2, axis=0))
            print(
                f"held-out τ, FIGAROH {label} {method.upper()} − symdyn {method.upper()}: RMS per joint {joints(d)} N·m"
            )
    c = fig["configs"]["motor"]
    ft, fn = np.asarray(c["true"]), np.asarray(c["nominal"])
    matched = []
    for i, name in enumerate(bmap.names):
        for k in range(len(ft)):
            for sign in (1, -1):
                if (
                    abs(sym_true[i] - sign * ft[k]) <= 1e-9 * max(1, abs(ft[k]))
                    and abs(sym_nom[i] - sign * fn[k]) <= 1e-9 * max(1, abs(fn[k]))
                    and abs(ft[k]) > 1e-12
                ):
                    matched.append((i, k, sign))
    print(
        f"coinciding base parameters (same true and nominal value, up to sign): {len(matched)} of "
        f"{len(bmap.names)} (symdyn) and {len(ft)} (FIGAROH with fv, fs, Ia, off)"
    )
    for method in ("ols", "wls"):
        r, m = sym[method]["res"], c["methods"][method]
        dz = [abs(r.base.values[i] - s * m["values"][k]) / r.base.std[i] for i, k, s in matched]
        if dz:
            print(
                f"  {method.upper()}: |symdyn − FIGAROH| / σ_symdyn over those: median {np.median(dz):.2g}, "
                f"max {np.max(dz):.2g}"
            )
    for i, k, s in matched:
        print(f"    {bmap.names[i]:>5} = {'' if s > 0 else '−'}[{c['names'][k][:70]}]")


def _cond_unweighted(res) -> float:
    """Condition number of the unweighted base regressor, from the fit's data (as FIGAROH's np.linalg.cond)."""
    from symdyn.identify.estimate import regressor_rows

    d = res.data
    Yb = regressor_rows(res.prior, d.q, d.qd, d.qdd)  # (N, n, b); row order leaves cond alone
    return float(np.linalg.cond(Yb.reshape(-1, Yb.shape[-1])))


if __name__ == "__main__":
    main()
