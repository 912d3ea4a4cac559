"""The C harnesses' shared pieces: their flags, the pool of states they cycle (a file of
doubles), the compiler and the content key of a cached build.  Used by `compare` (the
joint space) and `task_bench` (the task space)."""

from __future__ import annotations

import hashlib
import os
import platform
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from .. import __version__
from ..codegen.emit import write_atomic
from ..derivation.cache import cache_dir, writable
from ..numeric import reference as ref
from .pin_peer import FD_RTOL, central_jacobian, read_report

__all__ = [
    "CFLAGS",
    "POOL",
    "write_states",
    "cached_program",
    "frictionless_sources",
    "build_harness",
    "run_harness",
    "check_harness",
]

POOL = 1024  # states cycled by the C harnesses (a power of two, as pin_bench.cpp)
HARNESS = Path(__file__).with_name("harness.c")
CFLAGS = ("-O3", "-march=native")


def _digest(*parts: str | bytes) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p.encode() if isinstance(p, str) else p)
        h.update(b"\0")
    return h.hexdigest()[:16]


def _compiler() -> str:
    from ..codegen.emit.cbuild import compiler

    return compiler()


def write_states(path: Path, q, qd, qdd, tau) -> Path:
    """The first POOL states as the harness reads them: per state q, q̇, q̈, τ (doubles; on a
    floating base q has nq entries, the others nv)."""
    data = np.concatenate([np.asarray(x[:POOL], dtype=np.float64) for x in (q, qd, qdd, tau)], axis=1)
    if len(data) < 4 or len(data) & (len(data) - 1):
        raise ValueError(f"the harness needs a power-of-two pool of at least 4 states, got {len(data)}")
    path.parent.mkdir(parents=True, exist_ok=True)
    np.ascontiguousarray(data, dtype=np.float64).tofile(path)
    return path


def cached_program(label: str, sources: dict, flags=(), log=None) -> Path:
    """The C `sources` ({file name: text}) compiled into one program with CFLAGS and `flags`, once
    into the cache (keyed by the compiler, the flags, the host for -march=native and the texts).

    Raises:
        RuntimeError: the compile fails (its command and the compiler's message).
    """
    cc = _compiler()
    key = _digest(cc, *CFLAGS, *flags, platform.node(), *(f"{k}\n{v}" for k, v in sorted(sources.items())))
    folder = writable(cache_dir() / "bench" / f"{label}-{key}")
    binary = folder / "harness"
    if binary.exists():
        return binary
    for name, text in sources.items():
        write_atomic(folder / name, text)
    c_files = [str(folder / name) for name in sources if name.endswith(".c")]
    cmd = [cc, *CFLAGS, *flags, f"-I{folder}", *c_files, "-o", str(folder / "harness.tmp"), "-lm"]
    if log is not None:
        log(f"compiling {label} ...")
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"compiling {label} failed ({' '.join(cmd)}):\n{run.stderr[-2000:]}")
    os.replace(folder / "harness.tmp", binary)
    return binary


def frictionless_sources(robot, shipped: Path | None = None) -> dict[str, Path]:
    """Generated C (.c, .h) and NumPy (.py) of `robot.nofriction(all=True)` in the cache.

    Regenerated (≈ 10 s) whenever the shipped generated code in `shipped`
    (default generated/<name>), the emitters' source or the model changes, so it
    never lags behind the emitter (robots with no checked-in files included).
    """
    from ..codegen.emit import c as c_emit, identifier, numpy as np_emit
    from ..codegen.entry import GENERATED, bundle

    bare = robot.nofriction(all=True)
    name = identifier(bare.name)
    shipped = Path(shipped) if shipped is not None else GENERATED / name
    texts = [p.read_bytes() for p in sorted(shipped.glob(f"{name}.*"))] if shipped.is_dir() else []
    emitters = [p.read_bytes() for p in sorted((Path(__file__).parent.parent / "codegen" / "emit").glob("*.py"))]
    key = _digest(__version__, bare.fingerprint(), *texts, *emitters)
    folder = writable(cache_dir() / "bench" / f"{name}-nofriction-{key}")
    paths = {"c": folder / f"{name}.c", "h": folder / f"{name}.h", "py": folder / f"{name}.py"}
    if not all(p.exists() for p in paths.values()):
        print(f"generating the frictionless {name} into {folder} (once per generated code)", file=sys.stderr)
        b = bundle(bare)
        write_atomic(paths["h"], c_emit.h_source(b))
        write_atomic(paths["c"], c_emit.c_source(b))
        write_atomic(paths["py"], np_emit.module_source(b))
    return paths


def build_harness(c_path: Path, h_path: Path, casadi_c: Path | None = None) -> Path:
    """The harness compiled with a generated model (and CasADi's RNEA), cached by content."""
    c_path, h_path = Path(c_path), Path(h_path)
    model, h_text = h_path.stem, h_path.read_text()
    ndof = re.search(rf"#define {model.upper()}_NDOF (\d+)", h_text)
    if ndof is None:
        raise ValueError(f"{h_path} defines no {model.upper()}_NDOF: not a symdyn header")
    floating = [
        f"-D{k}={m[1]}" for k in ("NQ", "NV") if (m := re.search(rf"#define {model.upper()}_{k} (\d+)", h_text))
    ]
    sources = {HARNESS.name: HARNESS.read_text(), c_path.name: c_path.read_text(), h_path.name: h_text}
    if casadi_c is not None:
        sources.update({p.name: p.read_text() for p in (casadi_c, casadi_c.with_suffix(".h"))})
    flags = [
        f"-DMODEL={model}",
        f"-DNDOF={ndof[1]}",
        f'-DMODEL_HEADER="{h_path.name}"',
        *floating,
        *([] if f"{model}_C(" in h_text else ["-DWITHOUT_C"]),
        *(["-DWITH_CASADI"] if casadi_c is not None else []),
        *(["-DWITH_DERIVATIVES"] if f"{model}_tau_derivatives(" in h_text else []),
    ]
    try:
        return cached_program(f"harness-{model}", sources, tuple(flags))
    except RuntimeError as exc:
        raise RuntimeError(str(exc).replace(f"compiling harness-{model}", "compiling the C harness", 1)) from None


def run_harness(binary: Path, states: Path, ncalls: int, reps: int, functions=()) -> tuple[dict, dict]:
    """({function: ns per call}, {function: outputs at state 3}) from one harness run."""
    run = subprocess.run(
        [str(binary), str(states), str(int(ncalls)), str(int(reps)), *functions], capture_output=True, text=True
    )
    if run.returncode != 0:
        raise RuntimeError(f"{binary} failed ({run.returncode}): {run.stderr.strip()}")
    return read_report(run.stdout)


def check_harness(robot, checks: dict, q, qd, qdd, tau, k: int = 3, rtol: float = 1e-9) -> float:
    """Largest relative error of the harness outputs at state k against the reference (the
    derivatives' dtau/dq and dqdd/dq against central differences, to FD_RTOL); a RuntimeError
    if above rtol (timing wrong code would be worthless)."""
    q, qd, qdd, tau = q[k], qd[k], qdd[k], tau[k]
    expected = {
        "tau": lambda: ref.rne(robot, q, qd, qdd),
        "casadi_rnea": lambda: ref.rne(robot.nofriction(all=True), q, qd, qdd),
        "M": lambda: ref.inertia(robot, q),
        "C": lambda: ref.coriolis(robot, q, qd),
        "G": lambda: ref.gravload(robot, q),
        "Cqd": lambda: ref.coriolis(robot, q, qd) @ qd,
        "fdyn": lambda: ref.accel(robot, q, qd, tau),
        "Minv": lambda: np.linalg.inv(ref.inertia(robot, q)),
        "tau_derivatives": lambda: central_jacobian(lambda x: ref.rne(robot, x, qd, qdd), q),
        "fdyn_derivatives": lambda: central_jacobian(lambda x: ref.accel(robot, x, qd, tau), q),
    }
    worst = 0.0
    for name, got in checks.items():
        want = np.ravel(expected[name]())
        err = float(np.abs(got - want).max() / max(1.0, np.abs(want).max()))
        if not err <= (FD_RTOL if name.endswith("derivatives") else rtol):
            raise RuntimeError(f"C harness: {name} at state {k} differs from the reference by {err:.1e} (relative)")
        worst = max(worst, err)
    return worst


#: Titles of the row groups: which code is compared with which, so no row passes for what it is not.
