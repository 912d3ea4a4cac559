"""Per-state cost of the array-API target on whatever device JAX and PyTorch see (issue 25).

τ, M, fdyn and tau_derivatives of the Puma 560, the Panda and the iiwa14 (and, beside
tau_derivatives, the frameworks' own autodiff of τ: jax.jacfwd and torch.func.jacrev under
vmap), for batches of 1 … 10⁶ states, float64 and float32, in ns per state (the best of
repeated calls, after a warm-up call that compiles; JAX compiles once per batch size).  The
published GPU figures for a 7-joint arm (iiwa, H100) are printed beside the iiwa's rows as
context, not as a like-for-like comparison: GRiD (CUDA) inverse dynamics 16 ns per state at a
batch of 65536, its gradient 116 ns; MuJoCo MJX (JAX) ~20 ns.

    python scripts/bench_gpu.py                         # everything: jax and torch, all batches
    python scripts/bench_gpu.py --batches 1 100 10000 --libraries jax --dtypes float64

Needs `pip install -e '.[jax]'` and/or `'.[torch]'`; on a machine with one NVIDIA GPU,
`jax[cuda12]` and the default `torch` wheel, unchanged.  Without a GPU it runs on the CPU and
says so in one line (XLA on CPU compiles large programs slowly: expect minutes for 10⁶).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import symdyn
from symdyn.model import arms

ARMS = ("puma560", "panda", "iiwa14")
FUNCTIONS = ("tau", "M", "fdyn", "tau_derivatives", "autodiff")
BATCHES = (1, 10, 100, 1000, 10_000, 65_536, 100_000, 1_000_000)
#: Published GPU figures (ns per state), iiwa on an H100: (source, function) → (ns, note).
PUBLISHED = {
    "tau": "GRiD ID 16 ns @65k, MJX ~20 ns",
    "tau_derivatives": "GRiD grad 116 ns @65k",
    "autodiff": "GRiD grad 116 ns @65k",
}


def states(robot, batch: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    return (
        rng.uniform(lo, hi, (batch, robot.n)),
        rng.uniform(-2, 2, (batch, robot.n)),
        rng.uniform(-5, 5, (batch, robot.n)),
        rng.uniform(-20, 20, (batch, robot.n)),
    )


def best(call, sync, budget: float) -> float:
    """Seconds of one call: the best of as many calls as fit in `budget` (at least 2)."""
    times = []
    start = time.perf_counter()
    while len(times) < 2 or (time.perf_counter() - start < budget and len(times) < 50):
        t = time.perf_counter()
        sync(call())
        times.append(time.perf_counter() - t)
    return min(times)


class Jax:
    name = "jax"

    def __init__(self):
        import jax

        jax.config.update("jax_enable_x64", True)
        from symdyn.codegen.emit.array_api import CPU_COMPILER_OPTIONS

        self.jax, self.jnp = jax, jax.numpy
        self.gpu = jax.default_backend() != "cpu"
        self.device = f"{jax.default_backend()}: {jax.devices()[0].device_kind}"
        self.options = None if self.gpu else CPU_COMPILER_OPTIONS

    def functions(self, name):
        jax = self.jax
        f = symdyn.load(name, "jax", jit=False)
        jitted = {fn: jax.jit(getattr(f, fn), compiler_options=self.options) for fn in FUNCTIONS[:-1]}
        jitted["autodiff"] = jax.jit(jax.vmap(jax.jacfwd(f.tau, argnums=(0, 1))), compiler_options=self.options)
        return jitted

    def array(self, x, dtype):
        return self.jax.device_put(self.jnp.asarray(x, dtype=getattr(self.jnp, dtype)))

    def sync(self, out):
        self.jax.block_until_ready(out)


class Torch:
    name = "torch"

    def __init__(self):
        import torch

        self.torch = torch
        self.gpu = torch.cuda.is_available()
        self.dev = "cuda" if self.gpu else "cpu"
        self.device = f"{self.dev}: {torch.cuda.get_device_name() if self.gpu else 'CPU'}"

    def functions(self, name):
        from torch.func import jacrev, vmap

        f = symdyn.load(name, "torch")
        funcs = {fn: getattr(f, fn) for fn in FUNCTIONS[:-1]}
        funcs["autodiff"] = vmap(jacrev(f.tau, argnums=(0, 1)))
        return funcs

    def array(self, x, dtype):
        return self.torch.as_tensor(x, dtype=getattr(self.torch, dtype), device=self.dev)

    def sync(self, out):
        if self.gpu:
            self.torch.cuda.synchronize()


def libraries(names):
    found = []
    for lib in names:
        try:
            found.append({"jax": Jax, "torch": Torch}[lib]())
        except ImportError as exc:
            print(f"{lib}: not installed ({exc.name}); pip install -e '.[{lib}]'")
    return found


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--libraries", nargs="+", default=["jax", "torch"], choices=("jax", "torch"))
    p.add_argument("--arms", nargs="+", default=list(ARMS))
    p.add_argument("--functions", nargs="+", default=list(FUNCTIONS), choices=FUNCTIONS)
    p.add_argument("--batches", nargs="+", type=int, default=list(BATCHES))
    p.add_argument("--dtypes", nargs="+", default=["float64", "float32"], choices=("float64", "float32"))
    p.add_argument("--budget", type=float, default=0.3, help="seconds of timed calls per point (default 0.3)")
    args = p.parse_args(argv)
    libs = libraries(args.libraries)
    if not libs:
        return 1
    if not any(lib.gpu for lib in libs):
        print("no GPU: running on CPU")
    print(
        f"symdyn {symdyn.__version__}; ns per state (best of repeated calls; compile: the first call at the "
        f"largest batch, s); published context for the iiwa on an H100: {', '.join(sorted(set(PUBLISHED.values())))}"
    )
    for lib in libs:
        print(f"\n{lib.name} on {lib.device}")
        head = f"{'arm':8s} {'function':16s} {'dtype':7s} " + " ".join(f"{b:>9d}" for b in args.batches)
        print(head + f" {'compile':>8s}  published (iiwa, H100)")
        for name in args.arms:
            robot = arms.load(name)
            funcs = lib.functions(name)
            for fn in args.functions:
                for dtype in args.dtypes:
                    cells, compile_s = [], 0.0
                    for batch in args.batches:
                        q, qd, qdd, tau = (lib.array(x, dtype) for x in states(robot, batch))
                        call_args = {"M": (q,), "fdyn": (q, qd, tau)}.get(fn, (q, qd, qdd))
                        try:
                            t = time.perf_counter()
                            lib.sync(funcs[fn](*call_args))
                            compile_s = time.perf_counter() - t
                            seconds = best(lambda: funcs[fn](*call_args), lib.sync, args.budget)
                            cells.append(f"{seconds / batch * 1e9:9.1f}")
                        except (RuntimeError, MemoryError) as exc:  # out of device memory: say so, go on
                            cells.append(f"{'oom':>9s}")
                            print(
                                f"  {name} {fn} {dtype} batch {batch}: {type(exc).__name__}: {str(exc)[:80]}",
                                file=sys.stderr,
                            )
                    label = (
                        "jacfwd(tau)"
                        if fn == "autodiff" and lib.name == "jax"
                        else "jacrev(tau)"
                        if fn == "autodiff"
                        else fn
                    )
                    note = PUBLISHED.get(fn, "") if name == "iiwa14" else ""
                    print(
                        f"{name:8s} {label:16s} {dtype:7s} " + " ".join(cells) + f" {compile_s:8.2f}  {note}",
                        flush=True,
                    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
