"""The C harnesses' shared pieces: their flags, the pool of states they cycle (a file of
doubles), the compiler and the content key of a cached build.  Used by `compare` (the
joint space) and `task_bench` (the task space)."""

from __future__ import annotations

import hashlib
import os
import platform
import subprocess
from pathlib import Path

import numpy as np

__all__ = ["CFLAGS", "POOL", "write_states", "cached_program"]

POOL = 1024  # states cycled by the C harnesses (a power of two, as pin_bench.cpp)
CFLAGS = ("-O3", "-march=native")


def _digest(*parts: str | bytes) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p.encode() if isinstance(p, str) else p)
        h.update(b"\0")
    return h.hexdigest()[:16]


def _compiler() -> str:
    from ..codegen.emit.clib import compiler

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
    from ..codegen.emit import write_atomic
    from ..derivation.cache import cache_dir, writable

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
