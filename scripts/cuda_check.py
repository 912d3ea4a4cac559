#!/usr/bin/env python3
"""Issue 45's GPU check in one run: the CUDA target against the C target, and its speed beside the
card's copy bandwidth, symdyn's JAX path and (given an MJCF file) MuJoCo MJX.

    python scripts/cuda_check.py                      # everything; a markdown report on stdout
    python scripts/cuda_check.py --models iiwa14 --sizes 10000 1000000 --report out/cuda.md

Needs a GPU and `pip install -e '.[cuda]'`; JAX with CUDA for its rows (`jax[cuda12]`), and
`--mjcf FILE` with `mujoco-mjx` for MJX's.  Each part that cannot run (a library missing, a
model too large for the time) prints its reason and the run goes on.

1. Correctness: every function of each model on 10⁴ random states, the GPU's values against the
   C target's on the CPU, largest error relative to the output's largest entry (goal ≤ 1e-12).
2. Speed: ns per state of tau, M, fdyn, tau_derivatives and fdyn_derivatives at each size,
   float64 and float32 (the kernel alone, `CudaFunction.run`, timed by CUDA events, the best of
   repeated launches), and the share of the copy bandwidth it reaches (bytes in and out of one
   state over the time, against a device-to-device copy of 2 GB).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import symdyn
from symdyn.model import Robot, arms

MODELS = ("iiwa14", "panda", "go2", "talos")
TIMED = ("tau", "M", "fdyn", "tau_derivatives", "fdyn_derivatives")
SIZES = (10_000, 100_000, 1_000_000, 4_000_000)


def model(name: str) -> Robot:
    """A shipped arm, or a whole robot of example-robot-data on a free base."""
    if name in arms.NAMES:
        return arms.load(name)
    from symdyn.model.example_robots import robots_folder

    files = {"go2": "go2_description/urdf/go2.urdf", "talos": "talos_data/robots/talos_full_v2.urdf"}
    return Robot.from_urdf(str(robots_folder() / files[name]), tips="all", base_joint="free")


def inputs(cp, sig, n: int, dtype, seed: int = 0) -> list:
    rng = cp.random.default_rng(seed)
    return [rng.uniform(-1.5, 1.5, (n, k)).astype(dtype) for _, k in sig.inputs]


def check(cp, name: str, gpu, cpu, states: int) -> list[str]:
    rows = []
    for f, function in gpu.functions.items():
        try:
            xs = inputs(cp, function.signature, states, cp.float64)
            got = function(*xs)
            want = cpu.functions[f](*(x.get() for x in xs))
            got, want = (got, want) if isinstance(got, tuple) else ((got,), (want,))
            error = max(float(np.abs(g.get() - w).max()) / max(1.0, float(np.abs(w).max())) for g, w in zip(got, want))
            rows.append(f"| {name} | `{f}` | {error:.1e} | {'PASS' if error <= 1e-12 else 'FAIL'} |")
        except Exception as exc:  # noqa: BLE001 - a report, not a test: say what failed and go on
            rows.append(f"| {name} | `{f}` | – | {type(exc).__name__}: {str(exc)[:60]} |")
    return rows


def kernel_seconds(cp, function, n: int, dtype) -> float:
    xs = inputs(cp, function.signature, n, dtype)
    outs = [cp.empty((n, *shape), dtype=dtype) for _, shape in function.signature.outputs]
    bad = cp.zeros(1, dtype=cp.int32)
    function.run(n, xs, outs, bad)  # warm-up
    best = float("inf")
    start, stop = cp.cuda.Event(), cp.cuda.Event()
    for _ in range(20):
        start.record()
        function.run(n, xs, outs, bad)
        stop.record()
        stop.synchronize()
        best = min(best, cp.cuda.get_elapsed_time(start, stop) / 1e3)
    return best


def bandwidth(cp) -> float:
    """Bytes per second of a device-to-device copy of 2 GB (read + write)."""
    a = cp.ones(2**28, dtype=cp.float64)
    b = cp.empty_like(a)
    b[...] = a
    start, stop = cp.cuda.Event(), cp.cuda.Event()
    best = float("inf")
    for _ in range(10):
        start.record()
        b[...] = a
        stop.record()
        stop.synchronize()
        best = min(best, cp.cuda.get_elapsed_time(start, stop) / 1e3)
    return 2 * a.nbytes / best


def jax_seconds(name: str, f: str, sig, n: int, dtype) -> float | None:
    try:
        import jax

        if jax.default_backend() == "cpu":
            return None
        jax.config.update("jax_enable_x64", True)
        fn = getattr(symdyn.load(model(name), "jax"), f)
        xs = [
            jax.numpy.asarray(np.random.default_rng(0).uniform(-1.5, 1.5, (n, k)), dtype=dtype) for _, k in sig.inputs
        ]
        jax.block_until_ready(fn(*xs))
        best = float("inf")
        for _ in range(10):
            t = time.perf_counter()
            jax.block_until_ready(fn(*xs))
            best = min(best, time.perf_counter() - t)
        return best
    except Exception:  # noqa: BLE001 - JAX absent or out of memory: its cell says –
        return None


def mjx_seconds(path: str, n: int) -> dict:
    """MJX's inverse and forward dynamics on the model of an MJCF file, n states, float64 (s)."""
    import jax
    import mujoco
    from mujoco import mjx

    jax.config.update("jax_enable_x64", True)
    m = mujoco.MjModel.from_xml_path(path)
    mx = mjx.put_model(m)
    rng = np.random.default_rng(0)
    data = jax.vmap(lambda q, v, a: mjx.make_data(mx).replace(qpos=q, qvel=v, qacc=a, ctrl=jax.numpy.zeros(m.nu)))(
        *(jax.numpy.asarray(rng.uniform(-0.5, 0.5, (n, k))) for k in (m.nq, m.nv, m.nv))
    )
    out = {}
    for label, step in (("inverse", mjx.inverse), ("forward", mjx.forward)):
        call = jax.jit(jax.vmap(step, in_axes=(None, 0)))
        jax.block_until_ready(call(mx, data))
        best = float("inf")
        for _ in range(5):
            t = time.perf_counter()
            jax.block_until_ready(call(mx, data))
            best = min(best, time.perf_counter() - t)
        out[label] = best
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--models", nargs="+", default=list(MODELS))
    p.add_argument("--sizes", nargs="+", type=int, default=list(SIZES))
    p.add_argument("--states", type=int, default=10_000, help="states of the correctness check")
    p.add_argument("--mjcf", help="an MJCF file of the first model, for MJX's rows")
    p.add_argument("--report", help="also write the report to this file")
    args = p.parse_args(argv)
    from symdyn.codegen.emit import cudalib

    cp, arch = cudalib.device()
    lines = [f"# CUDA target: {cp.cuda.runtime.getDeviceProperties(0)['name'].decode()} (sm_{arch})", ""]
    copy = bandwidth(cp)
    lines += [f"Device-to-device copy: {copy / 1e12:.2f} TB/s.", ""]
    lines += ["| model | function | max rel. error vs C | |", "|---|---|---:|---|"]
    timing = ["", "| model | function | dtype | " + " | ".join(f"{n:.0e}" for n in args.sizes) + " | JAX (largest) |"]
    timing.append("|---|---|---|" + "---:|" * (len(args.sizes) + 1))
    for name in args.models:
        robot = model(name)
        t = time.perf_counter()
        gpu = symdyn.load(robot, "cuda")
        print(f"{name}: generated and compiled in {time.perf_counter() - t:.1f} s", file=sys.stderr)
        lines += check(cp, name, gpu, symdyn.load(robot, "c"), args.states)
        for f in TIMED:
            function = gpu.functions[f]
            for dtype in (cp.float64, cp.float32):
                if dtype == cp.float32 and not function.launch.staged:
                    continue
                cells = []
                for n in args.sizes:
                    try:
                        seconds = kernel_seconds(cp, function, n, dtype)
                        row = sum(k for _, k in function.signature.inputs) + sum(
                            int(np.prod(s)) for _, s in function.signature.outputs
                        )
                        share = row * np.dtype(dtype).itemsize * n / seconds / copy
                        cells.append(f"{seconds / n * 1e9:.3f} ({share:.0%})")
                    except Exception as exc:  # noqa: BLE001 - out of memory at 4e6: the cell says so
                        cells.append(type(exc).__name__)
                jax_s = jax_seconds(name, f, function.signature, args.sizes[-1], np.dtype(dtype).name)
                jax_cell = "–" if jax_s is None else f"{jax_s / args.sizes[-1] * 1e9:.2f}"
                timing.append(f"| {name} | `{f}` | {np.dtype(dtype).name} | " + " | ".join(cells) + f" | {jax_cell} |")
    lines += timing
    lines += ["", "ns per state (share of the copy bandwidth); JAX: symdyn's jax target at the largest size."]
    if args.mjcf:
        try:
            mjx = mjx_seconds(args.mjcf, args.sizes[-1])
            lines += [
                f"MJX on {args.mjcf}: " + ", ".join(f"{k} {v / args.sizes[-1] * 1e9:.1f} ns" for k, v in mjx.items())
            ]
        except Exception as exc:  # noqa: BLE001
            lines += [f"MJX: not run ({type(exc).__name__}: {exc})"]
    report = "\n".join(lines)
    print(report)
    if args.report:
        with open(args.report, "w") as out:
            out.write(report + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
