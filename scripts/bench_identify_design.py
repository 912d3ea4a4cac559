"""Measure identification's two optimisations: the excitation design and the consistent parameters.

    .venv/bin/python scripts/bench_identify_design.py [--models puma560 panda] [--skip-excitation]
        [--skip-consistent] [--period 10] [--harmonics 5]

Excitation: both criteria (cond, logdet) per model — wall time, IPOPT iterations, the condition
number and log det of the stacked base regressor against the random start of the same family,
and the condition number on a 100 Hz grid of the result.  Wall and CPU time are both printed:
on a shared machine the wall time is the CPU time times the contention.  Consistent: the SDP (Clarabel)
and the CasADi NLP (log-Cholesky) on (a) noise-free base parameters of the arm perturbed ±20 %
from the prior and (b) the same with one base parameter made impossible — time, how far the
base parameters moved, the largest relative error against the truth, the smallest pseudo-inertia
eigenvalue.  The base-parameter analysis is done (and cached) before the clocks start.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

# one BLAS thread: on a shared machine OpenBLAS's threads made a 69×69 eigh 300× slower
# (0.12 s against 0.35 ms) and IPOPT's linear algebra 2× slower; set it to measure otherwise
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402


def perturbed(robot, seed: int, amount: float = 0.2):
    rng = np.random.default_rng(seed)
    links = []
    for link in robot.links:
        k = 1 + amount * rng.uniform(-1, 1)
        I = np.array(link.I, dtype=float) * k + 1e-3 * np.eye(3)
        links.append(
            dataclasses.replace(
                link,
                m=float(link.m) * k,
                r=tuple(float(x) * (1 + amount * rng.uniform(-1, 1)) + 0.01 for x in link.r),
                I=tuple(map(tuple, I)),
                B=float(link.B) * (1 + amount * rng.uniform(-1, 1)),
            )
        )
    return dataclasses.replace(robot, links=tuple(links))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--models", nargs="+", default=["puma560", "panda"])
    p.add_argument("--period", type=float, default=10.0)
    p.add_argument("--harmonics", type=int, default=5)
    p.add_argument("--skip-excitation", action="store_true")
    p.add_argument("--skip-consistent", action="store_true")
    args = p.parse_args()

    from symdyn import models
    from symdyn.codegen.entry import load
    from symdyn.identify.consistent import _base, base_vector, physical
    from symdyn.identify.excitation import excitation

    for name in args.models:
        robot = models.load(name)
        base = _base(robot)
        model = load(robot, "casadi")
        if not args.skip_excitation:
            Y = model.functions["Y"]
            cols = list(base.independent)
            for criterion in ("cond", "logdet"):
                start, cpu = time.perf_counter(), time.process_time()
                e = excitation(robot, period=args.period, harmonics=args.harmonics, criterion=criterion, model=model)
                wall, cpu = time.perf_counter() - start, time.process_time() - cpu
                t, q, qd, qdd = e.sample(100)
                W = np.vstack([np.asarray(Y(a, b, c))[:, cols] for a, b, c in zip(q, qd, qdd)])
                print(
                    f"excitation {name} {criterion:6s}: {wall:6.1f} s ({cpu:.1f} s CPU), {e.iterations} iterations ({e.status}); "
                    f"cond {e.condition:.4g} (random start {e.random_condition:.4g}), "
                    f"log det {e.logdet:.4g} (random {e.random_logdet:.4g}); cond at 100 Hz {np.linalg.cond(W):.4g}",
                    flush=True,
                )
        if not args.skip_consistent:
            truth = perturbed(robot, seed=1)
            names, values = base_vector(truth, base)
            impossible = values.copy()
            k = names.index(next(b for b in names if b.startswith("ZZ") and b != "ZZ1"))
            impossible[k] = -abs(impossible[k]) - 0.01
            for case, target in (("feasible", values), ("impossible", impossible)):
                for method in ("sdp", "casadi"):
                    physical(robot, names, target, base=base, method=method)  # imports and first calls
                    start, cpu = time.perf_counter(), time.process_time()
                    r = physical(robot, names, target, base=base, method=method)
                    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
                    err = np.max(np.abs(r.achieved - values) / np.maximum(np.abs(values), 1e-3 * np.abs(values).max()))
                    print(
                        f"consistent {name} {case:10s} {method:6s}: {wall:6.2f} s ({cpu:.2f} s CPU, {r.status}); moved {r.moved:.3g}; "
                        f"max rel. error vs truth {err:.2e}; smallest pseudo-inertia eigenvalue {r.margins.min():.3g}",
                        flush=True,
                    )


if __name__ == "__main__":
    main()
