"""`symdyn bench`: the generated code of an arm against Pinocchio and the Robotics Toolbox.

One run, one set of random states (q, q̇, q̈ uniform in [−3, 3]; τ by the
reference RNEA) and the frictionless arm (Pinocchio has no friction) — the
Puma 560 unless `--model` names others (panda, iiwa14, ur5, …, or URDF files
read with the URDF options; the peers are built from the same Robot) —
compared like with like:

- C level, no Python: `harness.c` compiled with the generated C and
  `pin_peer.cpp` (Pinocchio C++, built once into the cache by `pin_peer`)
  time 10⁶ and 10⁵ calls per function on the same states file; a plain
  CasADi RNEA through CasADi's C code generator is a baseline, labelled so.
  Rounds alternate the harnesses (the machine is noisy); medians are reported.
- From Python: one call of the C target vs `pin.rnea`; per state in batches:
  the C target vs `pin.rneaInParallel` (one thread), the NumPy target vs the
  Robotics Toolbox's batched `rne`.

Speed-up = peer time / symdyn time; the targets are issue 4's for the Puma,
issue 15's for the Panda and the iiwa (`TARGETS`).  For any arm but the Puma
the report is the C level and the one call from Python (the Toolbox's `rne`
takes DH arms only; the with-friction rows are the Puma's).  Every timed
output, symdyn's and the peers', is first checked against `symdyn.reference`.
A peer that is not installed makes no row: the report says what to install
(`make bench` installs them all).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import platform
import re
import shutil
import subprocess
import sys
import timeit
from pathlib import Path

import numpy as np

from ..derivation.cache import cache_dir, writable
from ..model import arms
from ..numeric import reference as ref
from . import pin_peer
from .peers import casadi_rnea_c, toolbox_robot
from .harness import (
    POOL,
    _digest,
    build_harness,
    check_harness,
    frictionless_sources,
    run_harness,
    write_states,
)
from .pin_peer import PeerUnavailable
from .rows import OPS_NOTE, OPS_NOTE_ARM, Row, format_table, markdown_table

__all__ = [
    "Row",
    "main",
    "configure_parser",
    "frictionless_sources",
    "random_states",
    "write_states",
    "build_harness",
    "run_harness",
    "check_harness",
    "op_counts",
    "casadi_op_count",
    "TARGETS",
    "format_table",
    "markdown_table",
]

MODEL = "puma560"
#: Issue 15's targets for the 7-joint arms (speed-up ≥, keyed by the peer algorithm; "pin.rnea": the one
#: call from Python).  The Puma's (issue 4's) are in the row tables; an arm not listed here has none.
TARGETS = {
    arm: {"rnea": 4, "crba": 4, "aba": 4, "computeCoriolisMatrix": 2, "pin.rnea": 3} for arm in ("panda", "iiwa14")
}


# --------------------------------------------------------------------------- inputs


def random_states(robot, count: int, seed: int = 0):
    """(q, q̇, q̈, τ), each (count, n): uniform in [−3, 3] like pin_bench.cpp, τ = reference RNEA."""
    rng = np.random.default_rng(seed)
    q, qd, qdd = (rng.uniform(-3.0, 3.0, (count, robot.n)) for _ in range(3))
    return q, qd, qdd, ref.rne(robot, q, qd, qdd)


def op_counts(c_path: Path) -> dict[str, int]:
    """Total op count per function from the header comment of a generated .c file."""
    head = Path(c_path).read_text()[:4000]
    return {m[1]: int(m[2]) for m in re.finditer(r"^\s*\*\s+(\w+)\s+.*\((\d+) total\)", head, re.M)}


# --------------------------------------------------------------------------- C level


def casadi_op_count(robot) -> int:
    """Operations of the plain SX RNEA (symdyn.numeric.casadi_rnea, no friction) counted as symdyn counts
    its own (`op_counts`): every arithmetic or function instruction of CasADi's algorithm, negation free,
    inputs, outputs and constants not counted."""
    import casadi as ca

    from ..numeric.casadi_rnea import rnea_function

    f = rnea_function(robot.nofriction(all=True), friction=False)
    free = {ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST, ca.OP_PARAMETER, ca.OP_ASSIGN, ca.OP_NEG}
    return sum(f.instruction_id(k) not in free for k in range(f.n_instructions()))


C_PEER = "C level, same run: symdyn generated C vs Pinocchio C++ (symdyn/bench/pin_peer.cpp)"
C_BASELINE = (
    "C level, same run, baseline (not a peer): symdyn generated C vs a plain recursive Newton–Euler "
    "(symdyn.numeric.casadi_rnea) through CasADi's C code generator"
)
PY_ONE = "From Python, one call: symdyn C target vs Pinocchio's Python bindings"

# (group, label, symdyn harness, symdyn function, peer label, pin_peer.cpp algorithm or casadi_rnea, target)
C_ROWS = (
    (C_PEER, "tau", "bare", "tau", "Pinocchio rnea", "rnea", 8),
    (C_PEER, "M", "bare", "M", "Pinocchio crba", "crba", 6),
    (C_PEER, "fdyn", "bare", "fdyn", "Pinocchio aba", "aba", 6),
    (C_PEER, "fdyn", "bare", "fdyn", "Pinocchio crba + nonLinearEffects + Cholesky", "crba_cholesky", None),
    (C_PEER, "C", "bare", "C", "Pinocchio computeCoriolisMatrix", "computeCoriolisMatrix", 6),
    (C_PEER, "G", "bare", "G", "Pinocchio computeGeneralizedGravity", "computeGeneralizedGravity", None),
    (C_PEER, "Cqd", "bare", "Cqd", "Pinocchio nonLinearEffects (C q̇ + G)", "nonLinearEffects", None),
    (
        C_PEER,
        "tau_derivatives (τ, ∂τ/∂q, ∂τ/∂q̇)",
        "bare",
        "tau_derivatives",
        "Pinocchio computeRNEADerivatives",
        "computeRNEADerivatives",
        None,
    ),
    (
        C_PEER,
        "fdyn_derivatives (q̈, ∂q̈/∂q, ∂q̈/∂q̇, M⁻¹)",
        "bare",
        "fdyn_derivatives",
        "Pinocchio computeABADerivatives",
        "computeABADerivatives",
        None,
    ),
    (C_PEER, "Minv", "bare", "Minv", "Pinocchio computeMinverse", "computeMinverse", None),
    (C_PEER, "tau +friction (shipped)", "shipped", "tau", "Pinocchio rnea (no friction)", "rnea", None),
    (C_PEER, "fdyn +friction (shipped)", "shipped", "fdyn", "Pinocchio aba (no friction)", "aba", None),
    (C_BASELINE, "tau", "bare", "tau", "plain RNEA, CasADi C codegen", "casadi_rnea", 1),
)


def _title(group: str, name: str) -> str:
    """A row group's title: the Puma's as it always was, any other arm's named first."""
    return group if name == MODEL else f"{name}: {group}"


def c_level(robot, src: dict, states, args, log, missing: list, name: str = MODEL) -> list[Row]:
    """Rows of the C-level comparison (src: frictionless_sources) for the shipped arm `name`:
    symdyn's harnesses and the Pinocchio C++ peer on one states file, in alternating rounds; a
    peer that cannot be had is added to `missing` with what to install.  The Puma's rows keep
    issue 4's targets and its with-friction rows; another arm gets `TARGETS[name]` (if any) and
    the CasADi baseline's own op count beside symdyn's."""
    from ..codegen.entry import GENERATED
    from .peers import pinocchio_model

    q, qd, qdd, tau = states
    bare = robot.nofriction(all=True)
    work = writable(cache_dir() / "bench")
    states_file = write_states(work / f"states-{os.getpid()}.bin", q, qd, qdd, tau)
    casadi_c = None
    if not args.no_casadi:
        casadi_c = casadi_rnea_c(robot, work / f"casadi-{_digest(bare.fingerprint())}")
    harnesses = {"bare": (build_harness(src["c"], src["h"], casadi_c), (), bare)}
    shipped = GENERATED / MODEL
    if name == MODEL and (shipped / f"{MODEL}.c").exists():  # the with-friction rows are the Puma's
        harnesses["shipped"] = (build_harness(shipped / f"{MODEL}.c", shipped / f"{MODEL}.h"), ("tau", "fdyn"), robot)
    elif name == MODEL:
        log(f"no {shipped}: the with-friction rows are left out")
    peer, arm = None, None
    if args.no_pin:
        missing.append("Pinocchio C++: skipped (--no-pin)")
    else:
        try:
            joints, gravity = pin_peer.arm_joints(pinocchio_model(bare))
            peer = pin_peer.peer_binary(log)
        except PeerUnavailable as exc:
            missing.append(f"Pinocchio C++: not measured: {exc}")
        except ImportError:
            missing.append(f"Pinocchio C++: not measured: Pinocchio is not installed (pin): {pin_peer.HOW_TO_INSTALL}")
        else:
            arm = pin_peer.write_arm(work / f"arm-{os.getpid()}.txt", joints, gravity)
    algorithms = sorted({row[5] for row in C_ROWS if row[5] != "casadi_rnea"})
    times = {key: [] for key in harnesses}
    peer_times = []

    def time_peer():
        t, checks = pin_peer.run_peer(peer, arm, states_file, args.pin_calls, args.reps, algorithms)
        pin_peer.check_peer(bare, checks, q, qd, qdd, tau)
        peer_times.append(t)

    try:
        for r in range(args.rounds):
            if peer is not None and r % 2:  # ABAB… → ABBA…: slow drifts of load cancel
                time_peer()
            for key, (binary, functions, model) in harnesses.items():
                t, checks = run_harness(binary, states_file, args.calls, args.reps, functions)
                check_harness(model, checks, q, qd, qdd, tau)
                times[key].append(t)
            if peer is not None and not r % 2:
                time_peer()
            log(f"{name}: C level: round {r + 1}/{args.rounds} done")
    finally:
        states_file.unlink(missing_ok=True)
        if arm is not None:
            arm.unlink(missing_ok=True)
    samples = lambda runs, name: tuple(t[name] for t in runs if name in t)  # noqa: E731
    ops = {"bare": op_counts(src["c"]), "shipped": op_counts(shipped / f"{MODEL}.c") if "shipped" in harnesses else {}}
    rows = []
    for group, label, key, fn, peer_label, algo, target in C_ROWS:
        peer_ns = samples(times["bare"] if algo == "casadi_rnea" else peer_times, algo)
        if key in harnesses and peer_ns:
            if name != MODEL:
                target = TARGETS.get(name, {}).get(algo)
                if algo == "casadi_rnea":
                    peer_label = f"{peer_label} ({casadi_op_count(robot)} ops)"
            rows.append(
                Row(_title(group, name), label, samples(times[key], fn), peer_label, peer_ns, ops[key].get(fn), target)
            )
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


def python_level(robot, src: dict, states, args, log, missing: list, name: str = MODEL) -> list[Row]:
    """Rows of the comparison from Python (src: frictionless_sources): single calls, batches;
    a peer that is not installed is added to `missing` with what to install.  An arm other
    than the Puma gets the one call of the C target vs `pin.rnea` only."""
    from ..codegen.emit.clib import load_library
    from ..codegen.entry import GENERATED

    q, qd, qdd, _ = states
    bare = robot.nofriction(all=True)
    fast_tau = load_library(src["c"], src["h"]).functions["tau"]
    npmod = _import_path(src["py"], f"_symdyn_bench_{src['py'].parent.name.replace('-', '_')}")
    ops = op_counts(src["c"]).get("tau")
    want = ref.rne(bare, q, qd, qdd)
    N = len(q)
    batch = f"From Python, N={N} states per call, ns per state: symdyn C and NumPy targets vs Pinocchio, the Toolbox"
    q1, qd1, qdd1 = (np.ascontiguousarray(x[0]) for x in (q, qd, qdd))
    _agree("C target tau", fast_tau(q, qd, qdd), want)
    _agree("NumPy target tau", npmod.tau(q, qd, qdd), want)
    rows = []
    if name != MODEL and importlib.util.find_spec("pinocchio") is None:
        missing.append(f"Pinocchio (Python): not installed (pin): {pin_peer.HOW_TO_INSTALL}")
        return rows
    try:
        import pinocchio as pin

        from .peers import pinocchio_model
    except ImportError:
        missing.append(f"Pinocchio (Python): not installed (pin): {pin_peer.HOW_TO_INSTALL}")
    else:
        model = pinocchio_model(bare)
        data, pool = model.createData(), pin.ModelPool(model, 1)
        Q, V, A = (np.asfortranarray(x.T) for x in (q, qd, qdd))
        _agree("pin.rnea", pin.rnea(model, data, q1, qd1, qdd1), want[0])
        _agree("pin.rneaInParallel", pin.rneaInParallel(1, pool, Q, V, A).T, want)
        one = lambda: pin.rnea(model, data, q1, qd1, qdd1)  # noqa: E731
        ours, peer = _paired_ns(lambda: fast_tau(q1, qd1, qdd1), one, 20000, 7)
        if name != MODEL:
            return [
                Row(
                    _title(PY_ONE, name),
                    "tau (C target)",
                    ours,
                    "pin.rnea",
                    peer,
                    ops,
                    TARGETS.get(name, {}).get("pin.rnea"),
                )
            ]
        rows.append(Row(PY_ONE, "tau (C target)", ours, "pin.rnea", peer, ops, 3))
        shipped = _shipped_model()
        if shipped is not None:
            _agree("symdyn.load(...).tau", shipped.tau(q1, qd1, qdd1), ref.rne(robot, q1, qd1, qdd1))
            ours, peer = _paired_ns(lambda: shipped.tau(q1, qd1, qdd1), one, 20000, 7)
            rows.append(
                Row(
                    PY_ONE,
                    "tau +friction (symdyn.load)",
                    ours,
                    "pin.rnea (no friction)",
                    peer,
                    op_counts(GENERATED / MODEL / f"{MODEL}.c").get("tau"),
                    None,
                )
            )
        many = lambda: pin.rneaInParallel(1, pool, Q, V, A)  # noqa: E731
        ours, peer = _paired_ns(lambda: fast_tau(q, qd, qdd), many, 3, 7, N)
        rows.append(Row(batch, "tau (C target)", ours, "pin.rneaInParallel, 1 thread", peer, ops, 4))
    bot = toolbox_robot(bare)
    if bot is None:
        missing.append(f"Robotics Toolbox: not installed (roboticstoolbox-python): {pin_peer.HOW_TO_INSTALL}")
    else:
        import roboticstoolbox as rtb

        _agree("Robotics Toolbox rne", bot.rne(q, qd, qdd), want)
        ours, peer = _paired_ns(lambda: npmod.tau(q, qd, qdd), lambda: bot.rne(q, qd, qdd), 1, 5, N)
        rows.append(
            Row(batch, "tau (NumPy target)", ours, f"Robotics Toolbox {rtb.__version__} rne (batched)", peer, ops, 3)
        )
    return rows


# --------------------------------------------------------------------------- report


def machine() -> str:
    """CPU, compiler and peer versions, for the record."""
    cpu = platform.processor() or platform.machine()
    try:
        cpu = next(
            l.split(":", 1)[1].strip()
            for l in Path("/proc/cpuinfo").read_text().splitlines()
            if l.startswith("model name")
        )
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
    from ..model import command_line

    p.add_argument(
        "--model",
        nargs="+",
        metavar="NAME",
        default=None,
        help=f"arms to compare, one report each: shipped ({', '.join(arms.NAMES)}; default {MODEL}) "
        "or URDF files (the URDF options below apply to each)",
    )
    p.add_argument("--calls", type=int, default=1_000_000, help="C-level calls per repetition (default 10^6)")
    p.add_argument(
        "--pin-calls",
        type=int,
        default=100_000,
        help="Pinocchio C++ calls per repetition (default 10^5: its calls are ~10x slower, "
        "so each repetition still lasts > 0.1 s)",
    )
    p.add_argument("--reps", type=int, default=9, help="repetitions per C harness run, median (default 9)")
    p.add_argument(
        "--rounds",
        type=int,
        default=3,
        help="alternating runs of the symdyn and Pinocchio harnesses, median (default 3)",
    )
    p.add_argument("--batch", type=int, default=10_000, help="states per batched Python call (default 10^4)")
    p.add_argument("--seed", type=int, default=0, help="random states' seed (default 0)")
    p.add_argument("--no-pin", action="store_true", help="skip the Pinocchio C++ peer")
    p.add_argument("--no-casadi", action="store_true", help="skip the plain CasADi RNEA in C")
    p.add_argument("--no-python", action="store_true", help="skip the comparisons from Python")
    p.add_argument("--markdown", metavar="FILE", help="also write the table as Markdown to FILE")
    p.add_argument(
        "--batched",
        action="store_true",
        help="also the batched section: ns per state at --sizes against the loop, Pinocchio's "
        "*InParallel, CasADi's map, the Toolbox and this machine's ceilings (shipped arms)",
    )
    p.add_argument("--no-call", action="store_true", help="skip the per-call section (with --batched)")
    p.add_argument(
        "--task-space",
        nargs="*",
        metavar="CASE",
        default=None,
        help="the task-space table instead of the per-call section: frame poses, Jacobians and drifts, "
        "centre of mass and centroidal map against Pinocchio's C++ per call, and the batch per state "
        "with its memory bound; cases (example-robot-data's robots but the Panda): solo12 (four feet, one "
        "call), solo12-separate (three calls), panda (the hand), talos (com + A_G, one call), talos-separate "
        "(com_jacobian + centroidal_map), solo12-contacts, solo12-contact-derivatives, talos-contacts, "
        "talos-contact-derivatives (contact dynamics and their derivatives); default: all",
    )
    p.add_argument(
        "--sizes",
        nargs="+",
        type=float,
        default=None,
        metavar="N",
        help="batch sizes of the batched section (default 10 1e3 1e5 1e6)",
    )
    p.add_argument(
        "--max-bytes",
        type=float,
        default=4e8,
        metavar="BYTES",
        help="the batched section skips a function and size whose outputs take more memory (default 4e8)",
    )
    p.add_argument(
        "--threads",
        type=int,
        default=None,
        help="threads of the batched section (default: the cores this process may use)",
    )
    p.add_argument("--plot", metavar="PNG", help="with --batched: ns per state against N, log-log, to PNG")
    command_line.add_urdf_options(p)
    p.set_defaults(func=main)


def model_names(names) -> list[str]:
    """The arms `--model` names (default: the Puma 560), each once, in order; a ValueError naming
    the known models for any other name."""
    from ..model.command_line import is_urdf

    names = list(dict.fromkeys(names or [MODEL]))
    unknown = [n for n in names if n not in arms.NAMES and not is_urdf(n)]
    if unknown:
        raise ValueError(
            f"symdyn bench --model: unknown model{'s' if len(unknown) > 1 else ''} "
            f"{', '.join(map(repr, unknown))}: known models are {', '.join(arms.NAMES)}, "
            "or give a URDF file (a path ending in .urdf)"
        )
    return names


def _batched(robots: list, args, log) -> str:
    """The batched section (`batched`): printed; its Markdown returned, its plot written (--plot)."""
    from . import batched

    threads = args.threads or len(os.sched_getaffinity(0))
    log(f"batched section: measuring this machine's ceilings on 1 and {threads} threads")
    ceil = batched.ceilings(threads)
    results = [
        batched.run(
            robot,
            sizes=args.sizes or batched.SIZES,
            threads=threads,
            max_bytes=args.max_bytes,
            seed=args.seed,
            log=log,
        )
        for robot in robots
    ]
    print(batched.format_report(results, ceil), flush=True)
    if args.plot:
        log(f"plot: {batched.plot(results, Path(args.plot))}")
    return batched.markdown_report(results, ceil)


def _whole(robots: list, args, log) -> str:
    """The C-level section of whole robots (trees, floating bases: `whole`): printed; its Markdown returned."""
    from . import whole

    rows: list[Row] = []
    missing: list[str] = []
    for _, robot in robots:
        if args.no_pin:
            missing.append(f"{robot.name}: Pinocchio C++ skipped (--no-pin): a whole robot is compared with it only")
            continue
        try:
            rows += whole.compare_robot(
                robot, calls=max(1, args.pin_calls // 5), reps=args.reps, rounds=args.rounds, seed=args.seed, log=log
            )
        except PeerUnavailable as exc:
            missing.append(f"{robot.name}: Pinocchio C++ not measured: {exc}")
    note = "whole robots: the generated C against Pinocchio's C++ on the same states (symdyn.bench.whole)"
    print(format_table(rows, missing, note), flush=True)
    return markdown_table(rows, missing, note)


def _task_space(args, log) -> str:
    """The task-space section (`task_bench`): printed; its Markdown returned."""
    from . import task_bench

    cases = args.task_space or list(task_bench.CASES)
    unknown = [c for c in cases if c not in task_bench.CASES]
    if unknown:
        raise ValueError(f"symdyn bench --task-space: unknown cases {unknown}: expected {list(task_bench.CASES)}")
    rows: list[Row] = []
    missing: list[str] = []
    for case in cases:
        try:
            rows += task_bench.bench_case(
                case, calls=max(1, args.pin_calls // 5), reps=args.reps, rounds=args.rounds, log=log
            )
        except (FileNotFoundError, PeerUnavailable) as exc:
            missing.append(f"{case}: not measured: {exc}")
    note = "per call: one step of the case's functions (symdyn) against Pinocchio's algorithms (peer), same states"
    print(format_table(rows, missing, note), flush=True)
    return markdown_table(rows, missing, note)


def main(args=None) -> int:
    """`symdyn bench`: args is an argparse.Namespace from configure_parser, or argv strings."""
    if not isinstance(args, argparse.Namespace):
        parser = argparse.ArgumentParser(prog="symdyn bench", description=__doc__.split("\n\n")[0])
        configure_parser(parser)
        args = parser.parse_args(args)
    if min(args.batch, args.calls, args.pin_calls, args.reps, args.rounds) < 1:
        raise ValueError("--batch, --calls, --pin-calls, --reps and --rounds must be at least 1")
    if not args.max_bytes > 0:
        raise ValueError(f"--max-bytes must be a positive number of bytes, got {args.max_bytes}")
    from ..model import command_line

    names = model_names(getattr(args, "model", None))
    log = lambda msg: print(msg, file=sys.stderr, flush=True)  # noqa: E731
    tables: list[str] = []
    robots = [
        command_line.load(name, **command_line.urdf_options(args)) if command_line.is_urdf(name) else arms.load(name)
        for name in names
    ]
    if args.task_space is not None:
        tables.append(_task_space(args, log))
    whole = [(n, r) for n, r in zip(names, robots) if not r.is_chain]  # trees, floating bases
    if whole and not (args.no_call or args.task_space is not None):
        tables.append(_whole(whole, args, log))
    chains = [(n, r) for n, r in zip(names, robots) if r.is_chain]
    for name, robot in chains if not (args.no_call or args.task_space is not None) else ():
        # a URDF file's arm is titled by its path; the peers build it from the same Robot
        # the C harnesses cycle a pool of POOL states; the Python batches take the first --batch of them
        states = random_states(robot.nofriction(all=True), max(args.batch, POOL), args.seed)
        src = frictionless_sources(robot)
        note = OPS_NOTE if name == MODEL else OPS_NOTE_ARM
        title = (
            f"{robot.name}, frictionless unless marked; ns per call (per state for batches), medians; "
            f"speed-up = peer / symdyn, range = its lowest–highest over paired rounds or repetitions"
        )
        found: list[str] = []
        these: list[Row] = []
        if not args.no_python:  # at once: the Python-level peers need no build
            batch = tuple(x[: args.batch] for x in states)
            these = python_level(robot, src, batch, args, log, found, name)
            print(f"{title}\n(from Python; the C level follows)", flush=True)
            print(format_table(these, found, note), flush=True)
        # the C level: the Pinocchio C++ peer is built once per machine (minutes), with its progress
        c_rows = c_level(robot, src, states, args, log, found, name)
        print(title, flush=True)
        print(format_table(c_rows + these, found, note), flush=True)
        tables.append(markdown_table(c_rows + these, found, note))
    if args.batched:
        tables.append(_batched(robots, args, log))
    print(f"machine: {machine()}")
    if args.markdown:
        prog = "symdyn" if Path(sys.argv[0]).name == "symdyn" else f"python {sys.argv[0]}"
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        text = (
            f"Measured with `{' '.join([prog, *sys.argv[1:]])}` on {machine()}; load average "
            f"{load:.1f} at the end of the run.\n\n" + "\n\n".join(tables) + "\n"
        )
        Path(args.markdown).write_text(text)
    return 0
