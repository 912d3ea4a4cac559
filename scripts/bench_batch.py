"""Batched C evaluation, ns per state (issue 23): the old per-state loop against the SIMD kernels.

    .venv/bin/python scripts/bench_batch.py [--models puma560 panda] [--sizes 10 1000 100000 1000000]
                                            [--functions tau M fdyn tau_derivatives] [--threads 2]

For each model, function and batch size N, from Python with preallocated
outputs (inputs C-contiguous float64 (N, n), drawn uniformly in [-3, 3]):

  loop     <model>_<f>_batch: the scalar function state after state (what every
           batched call ran before the SIMD kernels), through ctypes
  simd/1   the SIMD kernel on one thread: model.f(..., out=..., threads=1)
  simd/T   the same on T threads (default: the cores this process may use)

The best of several rounds, each timing enough calls to last ~0.1 s.  The
machine may be shared: on a loaded machine extra threads help little.
Functions whose outputs for N = 1e6 would exceed --max-bytes are skipped at
that size (tau_derivatives of a 7-joint arm: 0.8 GB).
"""

from __future__ import annotations

import argparse
import ctypes
import os
import time

import numpy as np

from symdyn.codegen import entry as codegen
from symdyn.codegen.emit import c as c_emit
from symdyn.codegen.emit import clib

INPUTS = {"tau": "q qd qdd", "M": "q", "fdyn": "q qd tau", "tau_derivatives": "q qd qdd", "G": "q",
          "Cqd": "q qd", "F": "qd", "Minv": "q", "C": "q qd", "Y": "q qd qdd",
          "fdyn_derivatives": "q qd tau"}


def _best(call, states: int, rounds: int = 5, budget: float = 0.1) -> float:
    """ns per state of call(): the best of `rounds` rounds of enough calls to last `budget` s."""
    call()
    t0 = time.perf_counter()
    call()
    once = max(time.perf_counter() - t0, 1e-7)
    reps = max(1, int(budget / once))
    best = float("inf")
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(reps):
            call()
        best = min(best, (time.perf_counter() - t0) / reps)
    return best / max(states, 1) * 1e9


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--models", nargs="+", default=["puma560", "panda"])
    ap.add_argument("--functions", nargs="+", default=["tau", "M", "fdyn", "tau_derivatives"])
    ap.add_argument("--sizes", nargs="+", type=float, default=[10, 1e3, 1e5, 1e6])
    ap.add_argument("--threads", type=int, default=len(os.sched_getaffinity(0)))
    ap.add_argument("--max-bytes", type=float, default=4e8)
    args = ap.parse_args()
    print(f"ns per state; simd/T: T = {args.threads} threads; {os.cpu_count()} cpus, "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"{'model':8s} {'function':16s} {'N':>8s} {'loop':>8s} {'simd/1':>8s} {'simd/T':>8s} {'loop/simdT':>10s}")
    for name in args.models:
        folder = codegen.GENERATED / name
        lib = clib.load_library(folder / f"{name}.c", folder / f"{name}.h")
        dll = ctypes.CDLL(str(lib.path))
        sigs = {s.name: s for s in c_emit.read_signatures((folder / f"{name}.h").read_text())}
        n = sigs["tau"].inputs[0][1]
        rng = np.random.default_rng(0)
        for fname in args.functions:
            sig, f = sigs[fname], lib.functions[fname]
            loop = getattr(dll, f"{name}_{fname}_batch")
            for size in map(int, args.sizes):
                out_bytes = 8 * size * sum(int(np.prod(s)) for _, s in sig.outputs)
                if out_bytes > args.max_bytes:
                    print(f"{name:8s} {fname:16s} {size:8d}   (outputs {out_bytes / 1e9:.1f} GB > --max-bytes: skipped)")
                    continue
                ins = {a: rng.uniform(-3, 3, (size, n)) for a in INPUTS[fname].split()}
                xs = [ins[a] for a, _ in sig.inputs]
                outs = tuple(np.zeros((size,) + s) for _, s in sig.outputs)
                out = outs[0] if len(outs) == 1 else outs
                ptrs = [ctypes.c_void_p(a.ctypes.data) for a in (*xs, *outs)]
                t_loop = _best(lambda: loop(ctypes.c_int(size), *ptrs), size)
                t_one = _best(lambda: f(*xs, out=out, threads=1), size)
                t_all = _best(lambda: f(*xs, out=out, threads=args.threads), size)
                print(f"{name:8s} {fname:16s} {size:8d} {t_loop:8.1f} {t_one:8.1f} {t_all:8.1f} "
                      f"{t_loop / t_all:9.1f}x", flush=True)
                del ins, xs, outs, out, ptrs


if __name__ == "__main__":
    main()
