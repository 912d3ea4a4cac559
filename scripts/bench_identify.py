"""Time identification's least squares: N samples of a shipped arm (default 10⁵ of the Panda) by WLS and OLS.

    .venv/bin/python scripts/bench_identify.py [--model panda] [--samples 100000] [--repeats 3] [--consistent]

Simulated data (a random Fourier trajectory, the arm perturbed ±20 %, torque noise); the generated C
regressor is loaded (and compiled, once) before the clock starts; each fit is timed from its call to
its return (base map from the cache, Y in chunks, the Gram pass, the residual pass).  Prints the
median and the spread, and the recovered parameters' calibration on this one draw.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", default="panda")
    p.add_argument("--samples", type=int, default=100_000)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--consistent", action="store_true", help="also time the physically consistent step")
    args = p.parse_args()

    from symdyn import load
    from symdyn.identify import fit, simulate
    from symdyn.identify.parameters import base_map
    from symdyn.identify.simulate import fourier
    from symdyn.model import arms

    robot = arms.load(args.model)
    load(args.model, "c")
    base_map(robot)
    period = 10.0
    traj = fourier(robot, period=period, harmonics=5, rate=args.samples / period, seed=1)
    clean = simulate(robot, traj, seed=3)
    noise = 0.02 * np.sqrt(np.mean(clean.tau**2, axis=0))
    data = simulate(robot, traj, truth=clean.truth, noise=noise, seed=4)
    true = base_map(robot).values(clean.truth)
    print(
        f"{args.model}: {data.N} samples × {robot.n} joints, {len(true)} base parameters; "
        f"{os.cpu_count()} CPUs, OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}, "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    for method in ("wls", "ols"):
        times = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            res = fit(robot, data, method, consistent=False)
            times.append(time.perf_counter() - start)
        z = (res.base.values - true) / res.base.std
        print(
            f"  {method.upper()}: median {np.median(times):.3f} s (min {min(times):.3f}, max {max(times):.3f}); "
            f"condition {res.condition:.4g}; {np.mean(np.abs(z) <= 1.96):.0%} of the truth inside the 95 % "
            "intervals"
        )
    if args.consistent:
        start = time.perf_counter()
        res = fit(robot, data, "wls", consistent=True)
        print(
            f"  WLS + consistent: {time.perf_counter() - start:.2f} s (consistent step "
            f"{res.consistent_seconds:.2f} s, moved {res.consistent.moved:.3g})"
        )


if __name__ == "__main__":
    main()
