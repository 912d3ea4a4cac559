"""`symdyn bench`: the generated Puma 560 code against Pinocchio and the Robotics Toolbox.

One run, one set of random states (q, q̇, q̈ uniform in [−3, 3], as the
Pinocchio C++ peer draws its own; τ by the reference RNEA) and the
frictionless Puma 560 (Pinocchio has no friction), compared like with like:

- C level, no Python: `harness.c` compiled with the generated C times
  10⁶ calls per function; `shared/bench/pin_bench.cpp` times Pinocchio C++
  the same way; a plain CasADi RNEA goes through CasADi's C code generator.
  Rounds alternate the harnesses (the machine is noisy); medians are reported.
- From Python: one call of the C target vs `pin.rnea`; per state in batches:
  the C target vs `pin.rneaInParallel` (one thread), the NumPy target vs the
  Robotics Toolbox's batched `rne`.

Speed-up = peer time / symdyn time; the targets are issue 4's.  Every timed
output is first checked against `symdyn.reference`.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import timeit
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import __version__
from ..codegen.emit import write_atomic
from ..derivation.cache import cache_dir
from ..model import arms
from ..numeric import reference as ref

__all__ = ["Row", "main", "configure_parser", "frictionless_sources", "random_states", "write_states",
           "build_harness", "run_harness", "check_harness", "pin_harness", "run_pin", "op_counts",
           "format_table", "markdown_table"]

MODEL = "puma560"
POOL = 1024                      # states cycled by the C harnesses (a power of two, as pin_bench.cpp)
HARNESS = Path(__file__).with_name("harness.c")
REPO = Path(__file__).resolve().parents[2]
SHARED_BENCH = REPO.parent / "shared" / "bench"
CFLAGS = ("-O3", "-march=native")


@dataclass
class Row:
    """One comparison: paired samples (one per round or repetition) of ns per call
    (per state for batches) of symdyn and the peer (none: peer not measured), the
    op count of the symdyn function and the speed-up (peer/symdyn) issue 4 asks for."""

    level: str
    function: str
    symdyn: tuple
    peer: str
    peer_samples: tuple = ()
    ops: int | None = None
    target: float | None = None

    @property
    def symdyn_ns(self) -> float:
        return statistics.median(self.symdyn)

    @property
    def peer_ns(self) -> float | None:
        return statistics.median(self.peer_samples) if self.peer_samples else None

    @property
    def ratio(self) -> float | None:
        """Speed-up: median peer time / median symdyn time."""
        return None if self.peer_ns is None else self.peer_ns / self.symdyn_ns

    @property
    def spread(self) -> tuple[float, float] | None:
        """(lowest, highest) speed-up of the paired samples: how much the machine's noise moves it."""
        if len(self.peer_samples) < 2:
            return None
        ratios = [p / s for s, p in zip(self.symdyn, self.peer_samples)]
        return min(ratios), max(ratios)

    @property
    def met(self) -> str:
        if self.target is None or self.ratio is None:
            return ""
        return "yes" if self.ratio >= self.target else "no"


# --------------------------------------------------------------------------- inputs

def _digest(*parts: str | bytes) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p.encode() if isinstance(p, str) else p)
        h.update(b"\0")
    return h.hexdigest()[:16]


def frictionless_sources(robot, shipped: Path | None = None) -> dict[str, Path]:
    """Generated C (.c, .h) and NumPy (.py) of `robot.nofriction(all=True)` in the cache.

    Regenerated (≈ 10 s) whenever the shipped generated code in `shipped`
    (default generated/<name>) or the model changes, so it never lags behind
    the emitter that produced the checked-in files.
    """
    from ..codegen.emit import c as c_emit, identifier, numpy as np_emit
    from ..codegen.entry import GENERATED, bundle

    bare = robot.nofriction(all=True)
    name = identifier(bare.name)
    shipped = Path(shipped) if shipped is not None else GENERATED / name
    texts = [p.read_bytes() for p in sorted(shipped.glob(f"{name}.*"))] if shipped.is_dir() else []
    folder = cache_dir() / "bench" / f"{name}-nofriction-{_digest(__version__, bare.fingerprint(), *texts)}"
    paths = {"c": folder / f"{name}.c", "h": folder / f"{name}.h", "py": folder / f"{name}.py"}
    if not all(p.exists() for p in paths.values()):
        print(f"generating the frictionless {name} into {folder} (once per generated code)", file=sys.stderr)
        b = bundle(bare)
        write_atomic(paths["h"], c_emit.h_source(b))
        write_atomic(paths["c"], c_emit.c_source(b))
        write_atomic(paths["py"], np_emit.module_source(b))
    return paths


def random_states(robot, count: int, seed: int = 0):
    """(q, q̇, q̈, τ), each (count, n): uniform in [−3, 3] like pin_bench.cpp, τ = reference RNEA."""
    rng = np.random.default_rng(seed)
    q, qd, qdd = (rng.uniform(-3.0, 3.0, (count, robot.n)) for _ in range(3))
    return q, qd, qdd, ref.rne(robot, q, qd, qdd)


def write_states(path: Path, q, qd, qdd, tau) -> Path:
    """The first POOL states as the harness reads them: per state q, q̇, q̈, τ (doubles)."""
    data = np.stack([q[:POOL], qd[:POOL], qdd[:POOL], tau[:POOL]], axis=1)
    if len(data) < 4 or len(data) & (len(data) - 1):
        raise ValueError(f"the harness needs a power-of-two pool of at least 4 states, got {len(data)}")
    path.parent.mkdir(parents=True, exist_ok=True)
    np.ascontiguousarray(data, dtype=np.float64).tofile(path)
    return path


def op_counts(c_path: Path) -> dict[str, int]:
    """Total op count per function from the header comment of a generated .c file."""
    head = Path(c_path).read_text()[:4000]
    return {m[1]: int(m[2]) for m in re.finditer(r"^\s*\*\s+(\w+)\s+.*\((\d+) total\)", head, re.M)}


# --------------------------------------------------------------------------- C level

def casadi_rnea_c(robot, folder: Path) -> Path:
    """CasADi's C code of the plain SX RNEA (symdyn.numeric.casadi_rnea, no friction) as casadi_rnea.c/.h."""
    import casadi as ca

    from ..numeric.casadi_rnea import rnea_function

    f = rnea_function(robot.nofriction(all=True), friction=False)
    x = f.sx_in()
    g = ca.Function("casadi_rnea", x, f.call(x), f.name_in(), f.name_out())
    folder.mkdir(parents=True, exist_ok=True)
    cg = ca.CodeGenerator("casadi_rnea.c", {"with_header": True})
    cg.add(g)
    return Path(cg.generate(str(folder) + os.sep))


def _compiler() -> str:
    from ..codegen.emit.clib import compiler
    return compiler()


def build_harness(c_path: Path, h_path: Path, casadi_c: Path | None = None) -> Path:
    """The harness compiled with a generated model (and CasADi's RNEA), cached by content."""
    c_path, h_path = Path(c_path), Path(h_path)
    model, h_text = h_path.stem, h_path.read_text()
    ndof = re.search(rf"#define {model.upper()}_NDOF (\d+)", h_text)
    if ndof is None:
        raise ValueError(f"{h_path} defines no {model.upper()}_NDOF: not a symdyn header")
    cc = _compiler()
    sources = {HARNESS.name: HARNESS.read_text(), c_path.name: c_path.read_text(), h_path.name: h_text}
    if casadi_c is not None:
        sources.update({p.name: p.read_text() for p in (casadi_c, casadi_c.with_suffix(".h"))})
    key = _digest(cc, *CFLAGS, platform.node(), *(f"{k}\n{v}" for k, v in sorted(sources.items())))
    folder = cache_dir() / "bench" / f"harness-{model}-{key}"
    binary = folder / "harness"
    if binary.exists():
        return binary
    for name, text in sources.items():
        write_atomic(folder / name, text)
    cmd = [cc, *CFLAGS, f"-DMODEL={model}", f"-DNDOF={ndof[1]}", f'-DMODEL_HEADER="{h_path.name}"',
           *(["-DWITH_CASADI"] if casadi_c is not None else []), f"-I{folder}",
           *(str(folder / n) for n in sources if n.endswith(".c")), "-o", str(folder / "harness.tmp"), "-lm"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"compiling the C harness failed ({' '.join(cmd)}):\n{run.stderr[-2000:]}")
    os.replace(folder / "harness.tmp", binary)
    return binary


def run_harness(binary: Path, states: Path, ncalls: int, reps: int, functions=()) -> tuple[dict, dict]:
    """({function: ns per call}, {function: outputs at state 3}) from one harness run."""
    run = subprocess.run([str(binary), str(states), str(int(ncalls)), str(int(reps)), *functions],
                         capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"{binary} failed ({run.returncode}): {run.stderr.strip()}")
    times, checks = {}, {}
    for line in run.stdout.splitlines():
        kind, name, *values = line.split()
        if kind == "time":
            times[name] = float(values[0])
        elif kind == "check":
            checks[name] = np.array(values, dtype=float)
    return times, checks


def check_harness(robot, checks: dict, q, qd, qdd, tau, k: int = 3, rtol: float = 1e-9) -> float:
    """Largest relative error of the harness outputs at state k against the reference;
    a RuntimeError if above rtol (timing wrong code would be worthless)."""
    q, qd, qdd, tau = q[k], qd[k], qdd[k], tau[k]
    expected = {"tau": ref.rne(robot, q, qd, qdd), "casadi_rnea": ref.rne(robot.nofriction(all=True), q, qd, qdd),
                "M": ref.inertia(robot, q), "C": ref.coriolis(robot, q, qd), "G": ref.gravload(robot, q),
                "Cqd": ref.coriolis(robot, q, qd) @ qd, "fdyn": ref.accel(robot, q, qd, tau)}
    worst = 0.0
    for name, got in checks.items():
        want = np.ravel(expected[name])
        err = float(np.abs(got - want).max() / max(1.0, np.abs(want).max()))
        if not err <= rtol:
            raise RuntimeError(f"C harness: {name} at state {k} differs from the reference by {err:.1e} (relative)")
        worst = max(worst, err)
    return worst


def pin_harness(bench_dir: Path = SHARED_BENCH) -> tuple[Path | None, str]:
    """The Pinocchio C++ peer binary (cached; built by bench_dir/build.sh if missing, minutes),
    or (None, what is missing and how to fix it)."""
    try:
        import cmeel
        import pinocchio
    except ImportError:
        return None, "Pinocchio is not installed: pip install pin (or pip install symdyn[test])"
    binary = cache_dir() / "bench" / f"pin-{pinocchio.__version__}" / "pin_bench"
    if binary.exists():
        return binary, ""
    build = Path(bench_dir) / "build.sh"
    if not build.exists():
        return None, (f"{build} not found: the Pinocchio C++ peer lives in shared/bench beside the "
                      "repository (give its folder with --pin-bench-dir)")
    prefix = Path(cmeel.__file__).resolve().parent.parent / "cmeel.prefix"
    if not (prefix / "include" / "pinocchio").is_dir():
        return None, f"Pinocchio's C++ headers are not in {prefix / 'include'}: reinstall the wheel (pip install pin)"
    if not Path("/usr/include/eigen3/Eigen").is_dir():
        return None, "Eigen's headers are missing (/usr/include/eigen3): apt-get install libeigen3-dev"
    print(f"building the Pinocchio C++ peer into {binary.parent} (several minutes, once)", file=sys.stderr)
    binary.parent.mkdir(parents=True, exist_ok=True)
    run = subprocess.run(["sh", str(build)], capture_output=True, text=True,
                         env={**os.environ, "PY": sys.executable, "OUT_DIR": str(binary.parent)})
    if run.returncode != 0 or not binary.exists():
        return None, f"building the Pinocchio C++ peer failed:\n{run.stderr[-2000:]}"
    return binary, ""


def run_pin(binary: Path, dh_table: Path, ncalls: int) -> dict[str, float]:
    """{algorithm: ns per call} from pin_bench (median of its 9 repetitions)."""
    run = subprocess.run([str(binary), str(dh_table), str(int(ncalls))], capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"{binary} failed ({run.returncode}): {run.stderr.strip()}")
    check = re.search(r"check \|aba\(rnea\(a\)\) - a\| = (\S+)", run.stdout)
    if check is None or not float(check[1]) < 1e-8:
        raise RuntimeError(f"pin_bench's own check failed:\n{run.stdout}")
    return {m[1]: float(m[2]) for m in re.finditer(r"^(\S.*?)\s+([0-9.]+) ns$", run.stdout, re.M)}


# (label, symdyn harness, symdyn function, peer label, pin_bench algorithm or casadi, target)
C_ROWS = (
    ("tau", "bare", "tau", "Pinocchio rnea", "rnea", 8),
    ("tau", "bare", "tau", "plain CasADi RNEA (CasADi C codegen)", "casadi_rnea", 1),
    ("M", "bare", "M", "Pinocchio crba", "crba", 6),
    ("fdyn", "bare", "fdyn", "Pinocchio aba", "aba", 6),
    ("fdyn", "bare", "fdyn", "Pinocchio crba+nle+cholesky", "crba+nle+cholesky (FD)", None),
    ("C", "bare", "C", "Pinocchio computeCoriolisMatrix", "computeCoriolisMatrix", 6),
    ("G", "bare", "G", "Pinocchio computeGeneralizedGravity", "computeGeneralizedGravity", None),
    ("Cqd", "bare", "Cqd", "Pinocchio nonLinearEffects (C q̇ + G)", "nonLinearEffects", None),
    ("tau +friction (shipped)", "shipped", "tau", "Pinocchio rnea (no friction)", "rnea", None),
    ("fdyn +friction (shipped)", "shipped", "fdyn", "Pinocchio aba (no friction)", "aba", None),
)


def c_level(robot, src: dict, states, args, log) -> list[Row]:
    """Rows of the C-level comparison (src: frictionless_sources): harnesses in alternating rounds."""
    from ..codegen.entry import GENERATED

    q, qd, qdd, tau = states
    bare = robot.nofriction(all=True)
    work = cache_dir() / "bench"
    states_file = write_states(work / f"states-{os.getpid()}.bin", q, qd, qdd, tau)
    casadi_c = None
    if not args.no_casadi:
        casadi_c = casadi_rnea_c(robot, work / f"casadi-{_digest(bare.fingerprint())}")
    harnesses = {"bare": (build_harness(src["c"], src["h"], casadi_c), (), bare)}
    shipped = GENERATED / MODEL
    if (shipped / f"{MODEL}.c").exists():
        harnesses["shipped"] = (build_harness(shipped / f"{MODEL}.c", shipped / f"{MODEL}.h"), ("tau", "fdyn"), robot)
    else:
        log(f"no {shipped}: the with-friction rows are left out")
    pin_bin, why = (None, "--no-pin") if args.no_pin else pin_harness(Path(args.pin_bench_dir))
    if pin_bin is None:
        log(f"Pinocchio C++ peer skipped: {why}")
    dh = None
    if pin_bin is not None:
        from .peers import pin_dh_table
        dh = pin_dh_table(bare, work / f"dh-{os.getpid()}.txt")
    times = {key: [] for key in harnesses}
    pin_times = []
    try:
        for r in range(args.rounds):
            if pin_bin is not None and r % 2:       # ABAB… → ABBA…: slow drifts of load cancel
                pin_times.append(run_pin(pin_bin, dh, args.pin_calls))
            for key, (binary, functions, model) in harnesses.items():
                t, checks = run_harness(binary, states_file, args.calls, args.reps, functions)
                check_harness(model, checks, q, qd, qdd, tau)
                times[key].append(t)
            if pin_bin is not None and not r % 2:
                pin_times.append(run_pin(pin_bin, dh, args.pin_calls))
            log(f"C level: round {r + 1}/{args.rounds} done")
    finally:
        states_file.unlink(missing_ok=True)
        if dh is not None:
            dh.unlink(missing_ok=True)
    samples = lambda runs, name: tuple(t[name] for t in runs if name in t)  # noqa: E731
    ops = {"bare": op_counts(src["c"]), "shipped": op_counts(shipped / f"{MODEL}.c") if "shipped" in harnesses else {}}
    rows = []
    for label, key, fn, peer, algo, target in C_ROWS:
        if key not in harnesses or (algo == "casadi_rnea" and casadi_c is None):
            continue
        peer_ns = samples(times["bare"] if algo == "casadi_rnea" else pin_times, algo)
        rows.append(Row("C", label, samples(times[key], fn), peer, peer_ns, ops[key].get(fn), target))
    return rows


# --------------------------------------------------------------------------- from Python

def _paired_ns(ours, peer, number: int, repeat: int, per: int = 1) -> tuple[tuple, tuple]:
    """ns per call (divided by `per` states) of ours() and peer(), timed in alternation
    `repeat` times, `number` calls each (peer None: not timed)."""
    a, b = [], []
    for _ in range(repeat):
        a.append(timeit.timeit(ours, number=number) * 1e9 / number / per)
        if peer is not None:
            b.append(timeit.timeit(peer, number=number) * 1e9 / number / per)
    return tuple(a), tuple(b)


def _import_path(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def toolbox_robot(robot):
    """The robot as a Robotics Toolbox DHRobot (standard DH, revolute), or None if not installed."""
    try:
        import roboticstoolbox as rtb
    except ImportError:
        return None
    links = [rtb.RevoluteDH(d=float(l.d), a=float(l.a), alpha=float(l.alpha), offset=float(l.offset),
                            m=float(l.m), r=np.array(l.r, float), I=np.array(l.I, float), Jm=float(l.Jm),
                            G=float(l.G), B=float(l.B), Tc=np.array(l.Tc, float)) for l in robot.links]
    return rtb.DHRobot(links, name=robot.name, gravity=-np.array(robot.gravity, float))


def _agree(label: str, got, want, rtol: float = 1e-9) -> None:
    err = float(np.abs(np.asarray(got) - want).max() / max(1.0, np.abs(want).max()))
    if not err <= rtol:
        raise RuntimeError(f"{label} differs from the reference by {err:.1e} (relative): not timed")


def _shipped_model():
    """`symdyn.load(MODEL, "c")` as a user gets it (with friction), or None outside a checkout."""
    from ..codegen.entry import GENERATED, load

    if not (GENERATED / MODEL / f"{MODEL}.c").exists():
        return None
    return load(MODEL, "c")


def python_level(robot, src: dict, states, args, log) -> list[Row]:
    """Rows of the comparison from Python (src: frictionless_sources): single calls, batches."""
    from ..codegen.emit.clib import load_library
    from ..codegen.entry import GENERATED

    q, qd, qdd, _ = states
    bare = robot.nofriction(all=True)
    fast_tau = load_library(src["c"], src["h"]).functions["tau"]
    npmod = _import_path(src["py"], f"_symdyn_bench_{src['py'].parent.name.replace('-', '_')}")
    ops = op_counts(src["c"]).get("tau")
    want = ref.rne(bare, q, qd, qdd)
    N = len(q)
    q1, qd1, qdd1 = (np.ascontiguousarray(x[0]) for x in (q, qd, qdd))
    _agree("C target tau", fast_tau(q, qd, qdd), want)
    _agree("NumPy target tau", npmod.tau(q, qd, qdd), want)
    one = many = None
    try:
        import pinocchio as pin

        from .peers import pinocchio_model
    except ImportError:
        log("Pinocchio (Python) skipped: pip install pin")
    else:
        model = pinocchio_model(bare)
        data, pool = model.createData(), pin.ModelPool(model, 1)
        Q, V, A = (np.asfortranarray(x.T) for x in (q, qd, qdd))
        _agree("pin.rnea", pin.rnea(model, data, q1, qd1, qdd1), want[0])
        _agree("pin.rneaInParallel", pin.rneaInParallel(1, pool, Q, V, A).T, want)
        one = lambda: pin.rnea(model, data, q1, qd1, qdd1)  # noqa: E731
        many = lambda: pin.rneaInParallel(1, pool, Q, V, A)  # noqa: E731
    batch = f"Python, N={N}, per state"
    ours, peer = _paired_ns(lambda: fast_tau(q1, qd1, qdd1), one, 20000, 7)
    rows = [Row("Python, 1 call", "tau (C target)", ours, "pin.rnea", peer, ops, 3)]
    shipped = _shipped_model()
    if shipped is not None:
        _agree("symdyn.load(...).tau", shipped.tau(q1, qd1, qdd1), ref.rne(robot, q1, qd1, qdd1))
        ours, peer = _paired_ns(lambda: shipped.tau(q1, qd1, qdd1), one, 20000, 7)
        rows.append(Row("Python, 1 call", "tau +friction (symdyn.load)", ours, "pin.rnea (no friction)", peer,
                        op_counts(GENERATED / MODEL / f"{MODEL}.c").get("tau"), None))
    ours, peer = _paired_ns(lambda: fast_tau(q, qd, qdd), many, 3, 7, N)
    rows.append(Row(batch, "tau (C target)", ours, "pin.rneaInParallel, 1 thread", peer, ops, 4))
    bot = toolbox_robot(bare)
    if bot is not None:
        import roboticstoolbox as rtb
        _agree("Robotics Toolbox rne", bot.rne(q, qd, qdd), want)
        ours, peer = _paired_ns(lambda: npmod.tau(q, qd, qdd), lambda: bot.rne(q, qd, qdd), 1, 5, N)
        rows.append(Row(batch, "tau (NumPy target)", ours, f"Robotics Toolbox {rtb.__version__} rne (batched)",
                        peer, ops, 3))
    else:
        log("Robotics Toolbox not installed (pip install roboticstoolbox-python): "
            "the NumPy target is compared with symdyn.reference.rne instead")
        ours, peer = _paired_ns(lambda: npmod.tau(q, qd, qdd), lambda: ref.rne(bare, q, qd, qdd), 1, 5, N)
        rows.append(Row(batch, "tau (NumPy target)", ours, "symdyn.reference.rne (NumPy RNEA; not the Toolbox)",
                        peer, ops, None))
    return rows


# --------------------------------------------------------------------------- report

COLUMNS = ("level", "function", "symdyn ns", "peer", "peer ns", "speed-up", "range", "ops", "target", "met")
RIGHT = {2, 4, 5, 6, 7}


def _cells(row: Row) -> list[str]:
    num = lambda x, fmt: "n/a" if x is None else format(x, fmt)  # noqa: E731
    spread = row.spread
    return [row.level, row.function, num(row.symdyn_ns, ".1f"), row.peer, num(row.peer_ns, ".1f"),
            num(row.ratio, ".2f") + ("×" if row.ratio is not None else ""),
            f"{spread[0]:.2f}–{spread[1]:.2f}" if spread else "", num(row.ops, "d"),
            f"≥ {row.target}×" if row.target else "", row.met]


def format_table(rows: list[Row]) -> str:
    """A plain-text table, one line per comparison."""
    cells = [list(COLUMNS)] + [_cells(r) for r in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(len(COLUMNS))]
    lines = ["  ".join(c.rjust(w) if i in RIGHT else c.ljust(w) for i, (c, w) in enumerate(zip(line, widths)))
             for line in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(line.rstrip() for line in lines)


def markdown_table(rows: list[Row]) -> str:
    """The same table in Markdown."""
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "|".join("---:" if i in RIGHT else "---"
                                                           for i in range(len(COLUMNS))) + "|"]
    lines += ["| " + " | ".join(_cells(r)) + " |" for r in rows]
    return "\n".join(lines)


def machine() -> str:
    """CPU, compiler and peer versions, for the record."""
    cpu = platform.processor() or platform.machine()
    try:
        cpu = next(l.split(":", 1)[1].strip() for l in Path("/proc/cpuinfo").read_text().splitlines()
                   if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    cc = shutil.which(os.environ.get("CC", "cc"))
    ccv = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0] if cc else "no cc"
    parts = [f"{cpu}, {os.cpu_count()} cores", ccv, f"Python {platform.python_version()}", f"NumPy {np.__version__}"]
    for module, label in (("pinocchio", "Pinocchio"), ("casadi", "CasADi"), ("roboticstoolbox", "Robotics Toolbox")):
        try:
            parts.append(f"{label} {__import__(module).__version__}")
        except ImportError:
            pass
    return "; ".join(parts)


# --------------------------------------------------------------------------- command line

def configure_parser(p: argparse.ArgumentParser) -> None:
    """Arguments of `symdyn bench`."""
    p.add_argument("--calls", type=int, default=1_000_000, help="C-level calls per repetition (default 10^6)")
    p.add_argument("--pin-calls", type=int, default=100_000,
                   help="Pinocchio C++ calls per repetition (default 10^5: its calls are ~10x slower, "
                        "so each repetition still lasts > 0.1 s)")
    p.add_argument("--reps", type=int, default=9, help="repetitions per C harness run, median (default 9)")
    p.add_argument("--rounds", type=int, default=3,
                   help="alternating runs of the symdyn and Pinocchio harnesses, median (default 3)")
    p.add_argument("--batch", type=int, default=10_000, help="states per batched Python call (default 10^4)")
    p.add_argument("--seed", type=int, default=0, help="random states' seed (default 0)")
    p.add_argument("--no-pin", action="store_true", help="skip the Pinocchio C++ peer")
    p.add_argument("--no-casadi", action="store_true", help="skip the plain CasADi RNEA in C")
    p.add_argument("--no-python", action="store_true", help="skip the comparisons from Python")
    p.add_argument("--pin-bench-dir", default=str(SHARED_BENCH),
                   help="folder of pin_bench.cpp and build.sh (default: shared/bench beside the repository)")
    p.add_argument("--markdown", metavar="FILE", help="also write the table as Markdown to FILE")
    p.set_defaults(func=main)


def main(args=None) -> int:
    """`symdyn bench`: args is an argparse.Namespace from configure_parser, or argv strings."""
    if not isinstance(args, argparse.Namespace):
        parser = argparse.ArgumentParser(prog="symdyn bench", description=__doc__.split("\n\n")[0])
        configure_parser(parser)
        args = parser.parse_args(args)
    if args.batch < POOL or min(args.calls, args.pin_calls, args.reps, args.rounds) < 1:
        raise ValueError(f"--batch must be at least {POOL} and --calls, --pin-calls, --reps, --rounds positive")
    log = lambda msg: print(msg, file=sys.stderr, flush=True)  # noqa: E731
    robot = arms.load(MODEL)
    states = random_states(robot.nofriction(all=True), args.batch, args.seed)
    src = frictionless_sources(robot)
    rows = c_level(robot, src, states, args, log)
    if not args.no_python:
        rows += python_level(robot, src, states, args, log)
    print(f"{robot.name}, frictionless unless marked; ns per call (per state for batches), medians; "
          f"speed-up = peer / symdyn, range = its lowest–highest over paired rounds or repetitions")
    print(format_table(rows))
    print(f"machine: {machine()}")
    if args.markdown:
        prog = "symdyn" if Path(sys.argv[0]).name == "symdyn" else f"python {sys.argv[0]}"
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        text = (f"Measured with `{' '.join([prog, *sys.argv[1:]])}` on {machine()}; load average "
                f"{load:.1f} at the end of the run.\n\n{markdown_table(rows)}\n")
        Path(args.markdown).write_text(text)
    return 0
