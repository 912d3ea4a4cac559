"""`symdyn bench --batched`: ns per state of batched calls, side by side in one run, against the machine.

For each arm (`--model`), function (τ, M, fdyn, `tau_derivatives`) and batch
size N (`--sizes`, default 10, 10³, 10⁵, 10⁶), from Python with preallocated
outputs and C-contiguous float64 (N, n) inputs (q, q̇, q̈ uniform in [−3, 3]; a floating
base's q of nq, its pose a random twist from the neutral one, v and v̇ of nv):

  loop          `<model>_<f>_batch`: the scalar function state after state (through
                ctypes, one thread) — every batched call before the SIMD kernels
  simd/1        `model.f(..., out=, threads=1)`: the SIMD kernel on one thread
  simd/T        the same on T threads (default: the cores this process may use)
  pin/1, pin/T  Pinocchio's `rneaInParallel` (τ) and `abaInParallel` (fdyn) on 1 and T
                threads, on the frictionless arm (Pinocchio has no friction; symdyn's
                functions keep theirs: the comparison favours Pinocchio)
  casadi/T      CasADi's `map(N, "thread", T)` of the plain RNEA compiled by CasADi's
                code generator (τ; its DM inputs built before timing)
  rtb           the Robotics Toolbox's batched `rne` (τ, standard-DH arms)

Each time is the best of several rounds of calls lasting ~0.1 s; every timed
output is first checked against `symdyn.reference`.  Beside them, the machine's
ceilings measured in the same run (`ceilings.c`): a vector mul-add loop
(compute peak) and a streaming copy (memory bandwidth), on 1 and T threads;
each function's bound at T threads is the larger of its operations over the
peak and its bytes over the bandwidth.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import re
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..derivation.cache import cache_dir, writable
from ..numeric import reference as ref

__all__ = ["Ceilings", "ceilings", "function_costs", "run", "format_report", "markdown_report", "plot", "TARGETS"]

FUNCTIONS = ("tau", "M", "fdyn", "tau_derivatives")
SIZES = (10, 1000, 100_000, 1_000_000)
#: The size the targets and the bounds are read at.
AT = 100_000
#: Issue 23's targets at N = 10⁵ on every core, ns per state (simd/T).
TARGETS = {
    "puma560": {"tau": 15, "M": 10, "fdyn": 30, "tau_derivatives": 80},
    "panda": {"tau": 25, "fdyn": 50, "tau_derivatives": 200},
}
#: ... and Pinocchio's parallel batch / ours at equal threads.
PIN_RATIO_TARGET = 30
#: A vector sin/cos pair (`sincosv_` with its range test) is about 62 operations; a header's
#: "fun" (a sin, cos or sign call) counts as half of one — a sign's select costs less.
FUN_OPS = 31
CEILINGS_C = Path(__file__).with_name("ceilings.c")
INPUTS = {"tau": ("q", "qd", "qdd"), "M": ("q",), "fdyn": ("q", "qd", "tau"), "tau_derivatives": ("q", "qd", "qdd")}
VARIANTS = ("loop", "simd/1", "simd/T", "pin/1", "pin/T", "casadi/T", "rtb")


# --------------------------------------------------------------------------- the machine


@dataclass(frozen=True)
class Ceilings:
    """Measured ceilings: operations per second (a mul-add is 2), bytes per second
    (a copied double is 16: read and written) and bytes written per second with plain stores
    (`store`, a double is 8), on 1 and `threads` threads."""

    threads: int
    ops: tuple[float, float]
    bandwidth: tuple[float, float]
    store: tuple[float, float] = (float("nan"), float("nan"))

    def bound_ns(self, ops: float, nbytes: float) -> tuple[float, float]:
        """(compute, memory) bounds in ns per state at `threads` threads."""
        return ops / self.ops[1] * 1e9, nbytes / self.bandwidth[1] * 1e9


def _ceilings_library() -> ctypes.CDLL:
    """ceilings.c compiled once into the cache, with the generated kernels' flags."""
    from ..codegen.emit.cbuild import DEFAULT_FLAGS, compiler

    source = CEILINGS_C.read_text()
    key = hashlib.sha256(f"{compiler()}\n{source}".encode()).hexdigest()[:16]
    folder = writable(cache_dir() / "bench" / "ceilings")
    lib = folder / f"ceilings-{key}.so"
    if not lib.exists():
        tmp = folder / f".{lib.name}.{os.getpid()}"
        flags = [f for f in DEFAULT_FLAGS if not f.startswith("-D")]
        run = subprocess.run([compiler(), *flags, str(CEILINGS_C), "-o", str(tmp)], capture_output=True, text=True)
        if run.returncode != 0:
            raise RuntimeError(f"compiling {CEILINGS_C.name} failed:\n{run.stderr[-2000:]}")
        os.replace(tmp, lib)
    dll = ctypes.CDLL(str(lib))
    dll.ceiling_muladd.argtypes, dll.ceiling_muladd.restype = [ctypes.c_int, ctypes.c_long], ctypes.c_double
    dll.ceiling_copy.argtypes = [ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_long, ctypes.c_long]
    dll.ceiling_copy.restype = ctypes.c_double
    dll.ceiling_store.argtypes = [ctypes.c_int, ctypes.c_void_p, ctypes.c_long, ctypes.c_long]
    dll.ceiling_store.restype = ctypes.c_double
    return dll


def ceilings(threads: int, *, copy_bytes: float = 2e8, iters: int = 2_000_000, rounds: int = 5) -> Ceilings:
    """The mul-add peak, the copy bandwidth and the plain-store bandwidth of this machine on 1 and
    `threads` threads (`iters` rounds of 64 mul-adds per thread; `copy_bytes` copied, and
    written, well beyond the caches by default)."""
    dll = _ceilings_library()
    chains = 64
    n = int(copy_bytes / 8)
    src, dst = np.ones(n), np.zeros(n)

    def best(call) -> float:
        call()
        times = []
        for _ in range(rounds):
            t0 = time.perf_counter()
            call()
            times.append(time.perf_counter() - t0)
        return min(times)

    ops, bandwidth, store = [], [], []
    for t in (1, threads):
        ops.append(2 * chains * iters * t / best(lambda: dll.ceiling_muladd(t, iters)))
        bandwidth.append(16 * n / best(lambda: dll.ceiling_copy(t, src.ctypes.data, dst.ctypes.data, n, 1)))
        store.append(8 * n / best(lambda: dll.ceiling_store(t, dst.ctypes.data, n, 1)))
    return Ceilings(threads, tuple(ops), tuple(bandwidth), tuple(store))


def function_costs(c_path: Path, signatures) -> dict[str, tuple[int, int]]:
    """{function: (operations, bytes per state)}: mul + add + div + FUN_OPS per sin/cos/sign call,
    from the generated .c file's header, and 8 bytes per input and output element."""
    text = Path(c_path).read_text()
    head = text[: text.find("*/") + 1 or 6000]  # the header comment: a whole robot's runs long
    costs = {}
    for m in re.finditer(r"^\s*\*\s+(\w+)\s+([^(\n]*)\((\d+) total\)", head, re.M):
        parts = {k: int(v) for v, k in re.findall(r"(\d+) (mul|add|div|fun)", m[2])}
        costs[m[1]] = parts.get("mul", 0) + parts.get("add", 0) + parts.get("div", 0) + FUN_OPS * parts.get("fun", 0)
    return {
        s.name: (costs[s.name], 8 * (sum(k for _, k in s.inputs) + sum(int(np.prod(sh)) for _, sh in s.outputs)))
        for s in signatures
        if s.name in costs
    }


# --------------------------------------------------------------------------- timing


def _best(call, states: int, rounds: int = 5, budget: float = 0.1) -> float:
    """ns per state of call(): the best of `rounds` rounds of enough calls to last `budget` s."""
    call()
    t0 = time.perf_counter()
    call()
    once = max(time.perf_counter() - t0, 1e-7)
    reps = max(1, int(budget / once))
    best = float("inf")
    for _ in range(rounds if once < 2.0 else 2):
        t0 = time.perf_counter()
        for _ in range(reps):
            call()
        best = min(best, (time.perf_counter() - t0) / reps)
    return best / max(states, 1) * 1e9


def _inputs(robot, argument: str, size: int, rng) -> np.ndarray:
    """`size` random values of one argument, uniform in [−3, 3]: q of nq entries (a floating
    base's pose moved from the neutral one along a random twist: a unit quaternion), the
    others of nv."""
    if argument != "q" or robot.base_joint is None:
        return rng.uniform(-3, 3, (size, robot.nv if argument != "q" else robot.nq))
    q = robot.neutral() + np.zeros((size, 1))
    q[:, robot.nq - robot.n :] = rng.uniform(-3, 3, (size, robot.n))
    twist = np.zeros((size, robot.nv))
    twist[:, : robot.nv - robot.n] = rng.uniform(-3, 3, (size, robot.nv - robot.n))
    return np.ascontiguousarray(robot.integrate(q, twist))


def _agree(label: str, got, want, rtol: float = 1e-9) -> None:
    err = float(np.abs(np.asarray(got) - want).max() / max(1.0, np.abs(want).max()))
    if not err <= rtol:
        raise RuntimeError(f"{label} differs from the reference by {err:.1e} (relative): not timed")


@dataclass
class Result:
    """One arm's measurements: times[(function, N)][variant] = ns per state."""

    model: str
    n: int
    threads: int
    costs: dict
    times: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)


def _peers(robot, threads: int, log):
    """(Pinocchio model pool or None, compiled CasADi RNEA or None, Toolbox robot or None)."""
    from .peers import casadi_rnea_c, toolbox_robot

    bare = robot.nofriction(all=True)
    pool = casadi = None
    try:
        import pinocchio as pin

        from .peers import pinocchio_model

        pool = (pin, pinocchio_model(bare), pin.ModelPool(pinocchio_model(bare), threads))
    except ImportError:
        log("Pinocchio (pin) is not installed: no pin rows (make bench installs it)")
    try:
        import casadi as ca

        from ..codegen.emit.cbuild import compiler

        folder = writable(cache_dir() / "bench" / f"casadi-rnea-{robot.fingerprint()[:16]}")
        lib = folder / "casadi_rnea.so"
        if not lib.exists():
            c = casadi_rnea_c(bare, folder)
            tmp = folder / f".casadi_rnea.{os.getpid()}.so"
            subprocess.run(
                [compiler(), "-O3", "-march=native", "-fPIC", "-shared", str(c), "-o", str(tmp)],
                check=True,
                capture_output=True,
            )
            os.replace(tmp, lib)
        casadi = ca.external("casadi_rnea", str(lib))
    except (subprocess.CalledProcessError, RuntimeError) as exc:
        log(f"CasADi's RNEA could not be compiled: {exc}")
    bot = toolbox_robot(bare) if robot.convention in ("standard",) else None
    return pool, casadi, bot


def run(
    robot,
    *,
    sizes=SIZES,
    functions=FUNCTIONS,
    threads: int | None = None,
    max_bytes: float = 4e8,
    seed: int = 0,
    log=print,
    rounds: int = 5,
    budget: float = 0.1,
) -> Result:
    """Time every variant of `functions` of the C code of `robot` (`symdyn.load(robot, "c")`: the
    shipped code of a shipped arm, else its whole file generated once into the cache); each time the best of
    `rounds` rounds of calls lasting `budget` seconds."""
    from ..codegen.emit.clib import load_library
    from ..codegen.entry import generate, load
    from ..derivation.cache import cache_dir, package_fingerprint, writable

    threads = threads or len(os.sched_getaffinity(0))
    name = robot.name
    model = load(robot, "c")
    cfile = model.folder / f"{model.name}.c"
    if not cfile.is_file():  # generated function by function: the whole file, for its costs and batch loops
        folder = cache_dir() / "bench" / f"{model.name}-{robot.fingerprint()[:16]}-{package_fingerprint()[:12]}"
        if not (folder / cfile.name).is_file():
            generate(robot, "c", writable(folder))
        model = load(robot, "c", folder=folder)
        cfile = model.folder / f"{model.name}.c"
    lib = load_library(cfile, model.folder / f"{model.name}.h")
    result = Result(name, robot.n, threads, function_costs(cfile, lib.signatures))
    pool, casadi, bot = _peers(robot, threads, log)
    bare = robot.nofriction(all=True)
    rng = np.random.default_rng(seed)
    for fname in functions:
        sig = next(s for s in lib.signatures if s.name == fname)
        dll = ctypes.CDLL(str(lib.library(fname)))  # the function's scalar code and its _batch loop
        f, loop = model.functions[fname], getattr(dll, f"{model.name}_{fname}_batch")
        for size in map(int, sizes):
            out_bytes = 8 * size * sum(int(np.prod(s)) for _, s in sig.outputs)
            if out_bytes > max_bytes:
                result.notes.append(f"{fname} at N = {size}: outputs {out_bytes / 1e9:.1f} GB > --max-bytes, skipped")
                continue
            x = {a: _inputs(robot, a, size, rng) for a in INPUTS[fname]}
            xs = [x[a] for a, _ in sig.inputs]
            outs = tuple(np.zeros((size,) + tuple(s)) for _, s in sig.outputs)
            out = outs[0] if len(outs) == 1 else outs
            ptrs = [ctypes.c_void_p(a.ctypes.data) for a in (*xs, *outs)]
            k = slice(0, min(size, 50))
            want = {
                "tau": lambda: ref.rne(robot, x["q"][k], x["qd"][k], x["qdd"][k]),
                "M": lambda: ref.inertia(robot, x["q"][k]),
                "fdyn": lambda: ref.accel(robot, x["q"][k], x["qd"][k], x["tau"][k]),
                "tau_derivatives": lambda: ref.rne(robot, x["q"][k], x["qd"][k], x["qdd"][k]),
            }[fname]()
            f(*xs, out=out, threads=threads)
            _agree(f"{name} {fname}", outs[0][k], want)
            best = lambda call: _best(call, size, rounds, budget)  # noqa: E731
            t = {
                "loop": best(lambda: loop(ctypes.c_int(size), *ptrs)),
                "simd/1": best(lambda: f(*xs, out=out, threads=1)),
                "simd/T": best(lambda: f(*xs, out=out, threads=threads)),
            }
            t.update(_peer_times(fname, size, x, pool, casadi, bot, bare, threads, best))
            result.times[(fname, size)] = t
            log(f"  {name} {fname:16s} N={size:>8d}  " + "  ".join(f"{v} {ns:.1f}" for v, ns in t.items()))
            del x, xs, outs, out, ptrs
    return result


def _peer_times(fname: str, size: int, x: dict, pool, casadi, bot, bare, threads: int, best) -> dict:
    """ns per state of the peers that compute `fname`, checked against the reference first."""
    t = {}
    k = slice(0, min(size, 50))
    if pool is not None and fname in ("tau", "fdyn"):
        pin, pmodel, models = pool
        second = "qdd" if fname == "tau" else "tau"
        Q, V, A = (x[a].T for a in ("q", "qd", second))  # (n, N) Fortran views, no copies
        R = np.zeros_like(V, order="F")  # of nv rows: a floating base's q has more
        call = pin.rneaInParallel if fname == "tau" else pin.abaInParallel
        want = (
            ref.rne(bare, x["q"][k], x["qd"][k], x["qdd"][k])
            if fname == "tau"
            else ref.accel(bare, x["q"][k], x["qd"][k], x["tau"][k])
        )
        call(threads, models, Q, V, A, R)
        _agree(f"pin.{call.__name__}", R.T[k], want)
        t["pin/1"] = best(lambda: call(1, models, Q, V, A, R))
        t["pin/T"] = best(lambda: call(threads, models, Q, V, A, R))
    if casadi is not None and fname == "tau":
        import casadi as ca

        mapped = casadi.map(size, "thread", threads)
        args = [ca.DM(x[a].T) for a in ("q", "qd", "qdd")]
        _agree("CasADi map", np.array(mapped(*args)).T[k], ref.rne(bare, x["q"][k], x["qd"][k], x["qdd"][k]))
        t["casadi/T"] = best(lambda: mapped(*args))
    if bot is not None and fname == "tau" and size <= 100_000:
        _agree(
            "Robotics Toolbox rne",
            bot.rne(x["q"][k], x["qd"][k], x["qdd"][k]),
            ref.rne(bare, x["q"][k], x["qd"][k], x["qdd"][k]),
        )
        t["rtb"] = best(lambda: bot.rne(x["q"], x["qd"], x["qdd"]))
    return t


# --------------------------------------------------------------------------- report


def _cell(ns) -> str:
    return "" if ns is None else f"{ns:.1f}" if ns < 1000 else f"{ns:,.0f}"


def rows(result: Result, ceil: Ceilings) -> tuple[list[list[str]], list[list[str]]]:
    """(timing rows, bound rows) of one arm, as table cells."""
    timing = []
    for (fname, size), t in result.times.items():
        ratio = t["pin/T"] / t["simd/T"] if "pin/T" in t else None
        target = TARGETS.get(result.model, {}).get(fname) if size == AT else None
        met = "" if target is None else ("yes" if t["simd/T"] <= target else "no")
        timing.append(
            [
                fname,
                f"{size:,}",
                *(_cell(t.get(v)) for v in VARIANTS),
                "" if ratio is None else f"{ratio:.0f}×",
                "" if target is None else f"≤ {target}",
                met,
            ]
        )
    bounds = []
    for fname in dict.fromkeys(f for f, _ in result.times):
        size = max(s for f, s in result.times if f == fname)
        ops, nbytes = result.costs[fname]
        compute, memory = ceil.bound_ns(ops, nbytes)
        ns = result.times[(fname, size)]["simd/T"]
        bounds.append(
            [
                fname,
                f"{size:,}",
                str(ops),
                str(nbytes),
                f"{compute:.1f}",
                f"{memory:.1f}",
                f"{max(compute, memory):.1f}",
                f"{ns:.1f}",
                f"{ns / max(compute, memory):.1f}×",
                f"{ops / ns:.1f}",
            ]
        )
    return timing, bounds


TIMING_HEAD = ["function", "N", *VARIANTS, "pin/T ÷ simd/T", "target", "met"]
BOUND_HEAD = [
    "function",
    "at N",
    "ops/state",
    "bytes/state",
    "compute ns",
    "memory ns",
    "bound ns",
    "simd/T ns",
    "÷ bound",
    "Gop/s",
]


def ceiling_lines(ceil: Ceilings) -> list[str]:
    return [
        f"ceilings (measured in this run): mul-add peak {ceil.ops[0] / 1e9:.1f} Gop/s on 1 thread, "
        f"{ceil.ops[1] / 1e9:.1f} on {ceil.threads}; copy bandwidth {ceil.bandwidth[0] / 1e9:.1f} GB/s on 1 "
        f"thread, {ceil.bandwidth[1] / 1e9:.1f} on {ceil.threads}",
        f"ops/state: mul + add + div + {FUN_OPS} per sin/cos/sign call (the header's counts: after one joint "
        "CSE, with the model's friction); bytes/state: inputs "
        "+ outputs; bound = max(ops / peak, bytes / bandwidth) at T threads",
    ]


def _text_table(head, body) -> str:
    widths = [max(len(r[i]) for r in [head, *body]) for i in range(len(head))]
    return "\n".join(
        "  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))) for r in [head, *body]
    )


def _md_table(head, body) -> str:
    return "\n".join(
        ["| " + " | ".join(head) + " |", "|" + "---|" * len(head), *("| " + " | ".join(r) + " |" for r in body)]
    )


def format_report(results: list[Result], ceil: Ceilings) -> str:
    parts = []
    for r in results:
        timing, bounds = rows(r, ceil)
        parts += [
            f"{r.model} ({r.n} joints), ns per state, T = {r.threads} threads:",
            _text_table(TIMING_HEAD, timing),
            "",
            _text_table(BOUND_HEAD, bounds),
            *r.notes,
            "",
        ]
    return "\n".join(parts + ceiling_lines(ceil))


def markdown_report(results: list[Result], ceil: Ceilings) -> str:
    parts = []
    for r in results:
        timing, bounds = rows(r, ceil)
        parts += [
            f"**{r.model}** ({r.n} joints), ns per state, T = {r.threads} threads",
            "",
            _md_table(TIMING_HEAD, timing),
            "",
            _md_table(BOUND_HEAD, bounds),
            "",
            *(f"- {note}" for note in r.notes),
            "",
        ]
    return "\n".join(parts + [f"- {line}" for line in ceiling_lines(ceil)]) + "\n"


def plot(results: list[Result], path: Path) -> Path:
    """ns per state against N, log–log, one panel per arm and function, one line per variant."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [(r, f) for r in results for f in dict.fromkeys(f for f, _ in r.times)]
    cols = min(4, len(panels))
    rows_ = -(-len(panels) // cols)
    fig, axes = plt.subplots(rows_, cols, figsize=(3.6 * cols, 3.0 * rows_), squeeze=False)
    for ax, (r, fname) in zip(axes.flat, panels):
        sizes = sorted(s for f, s in r.times if f == fname)
        for v in VARIANTS:
            pts = [(s, r.times[(fname, s)][v]) for s in sizes if v in r.times[(fname, s)]]
            if pts:
                ax.loglog(*zip(*pts), marker="o", ms=3, label=v)
        ax.set_title(f"{r.model} {fname}", fontsize=9)
        ax.set_xlabel("N states", fontsize=8)
        ax.set_ylabel("ns per state", fontsize=8)
        ax.grid(True, which="both", lw=0.3)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(panels) :]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
