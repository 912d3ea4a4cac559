#!/usr/bin/env python3
"""A robot's batch kernels against its scalar function in a loop, ns per state (minutes: the
kernels of Talos' wide outputs take a while to compile).

Run: .venv/bin/python scripts/batch_vs_loop.py talos M C Minv
     .venv/bin/python scripts/batch_vs_loop.py solo12 fdyn_derivatives

The robot is `symdyn bench --task-space`'s (example-robot-data's URDF on a free base,
`symdyn.bench.task_bench.CASES`), its functions built as C, scalar code and SIMD kernel.  For
each function: the scalar function state after state (`<model>_<f>_batch`, one thread) and the
SIMD kernel on one thread at N = 10³, the same loop and the kernel on every core at N = 10⁵;
best of several calls, on the same random states, the kernel's outputs checked against the
loop's first.  A kernel slower than the loop is a defect: a wide one whose lane loop the compiler
left unvectorized (`symdyn.codegen.emit.cunits.WIDE_LOOPS`).
"""

from __future__ import annotations

import argparse
import ctypes
import os
import time

import numpy as np

from symdyn.bench import task_bench
from symdyn.bench.batched import _inputs
from symdyn.codegen.entry import load

#: The batched bench's input names (`_inputs`) of a signature's arguments.
_NAMES = {"v": "qd", "a": "qdd"}


def _best(call, rounds: int) -> float:
    best = float("inf")
    for _ in range(rounds):
        start = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - start)
    return best


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot", choices=["solo12", "talos", "panda"])
    parser.add_argument("functions", nargs="+")
    args = parser.parse_args(argv)
    robot, _ = task_bench.case_robot(task_bench.CASES[args.robot])
    model = load(robot, "c")
    lib, threads = model._library, len(os.sched_getaffinity(0))
    rng = np.random.default_rng(0)
    print(f"{robot.name}, ns per state; loop: the scalar function state after state, one thread")
    for name in args.functions:
        model.build([name], batch=True)
        sig = next(s for s in lib.signatures if s.name == name)
        loop = getattr(ctypes.CDLL(str(lib.library(name))), f"{model.name}_{name}_batch")
        width = sum(int(np.prod(s)) for _, s in sig.outputs)
        row = [f"{name} ({width} outputs)"]
        for size, many in ((1000, 1), (100_000, threads)):
            xs = [_inputs(robot, _NAMES.get(a, a), size, rng) for a, _ in sig.inputs]
            outs = [np.zeros((size, *s)) for _, s in sig.outputs]
            kernel = [np.zeros((size, *s)) for _, s in sig.outputs]
            pointers = [ctypes.c_void_p(a.ctypes.data) for a in (*xs, *outs)]
            f = model.functions[name]
            out = kernel[0] if len(kernel) == 1 else tuple(kernel)
            f(*xs, out=out, threads=many)
            loop(ctypes.c_int(size), *pointers)
            for got, want in zip(kernel, outs):
                np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
            rounds = 10 if size <= 1000 else 3
            per = 1e9 / size
            t_loop = _best(lambda: loop(ctypes.c_int(size), *pointers), rounds) * per
            t_kernel = _best(lambda: f(*xs, out=out, threads=many), rounds) * per
            row.append(f"N = {size}: loop {t_loop:.0f}, kernel on {many} thread(s) {t_kernel:.0f}")
        print("  " + "; ".join(row), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
