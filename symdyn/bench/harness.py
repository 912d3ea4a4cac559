"""The C harnesses' shared pieces: their flags, the pool of states they cycle (a file of
doubles), the compiler and the content key of a cached build.  Used by `compare` (the
joint space) and `task_bench` (the task space)."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

__all__ = ["CFLAGS", "POOL", "write_states"]

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
