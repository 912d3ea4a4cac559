"""Building C into shared libraries: the system compiler and its flags, a large file split into
parts compiled in parallel, and each library kept in symdyn's cache under the sha256 recorded when
it was built (a truncated one is rebuilt, never loaded).

Part of the C target: `cunits` keeps one unit per generated function, `clib` binds them; nothing
here knows a model.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

import numpy as np

from ...derivation.cache import build_lock, writable
from . import write_atomic

__all__ = [
    "DEFAULT_FLAGS",
    "SPLIT_BYTES",
    "compiler",
    "python_headers",
    "digest",
    "jobs",
    "split_source",
    "library",
    "intact",
    "record",
]

#: -march=native: the library is built for this machine (the cache key includes the host name).
DEFAULT_FLAGS = ("-O3", "-march=native", "-fPIC", "-shared", "-pthread", "-fopenmp-simd", "-DSYMDYN_OPENMP_SIMD")


def compiler() -> str:
    """Path of the C compiler ($CC or cc).

    Raises:
        RuntimeError: no compiler found; the message says what to install.
    """
    cc = os.environ.get("CC", "cc")
    path = shutil.which(cc)
    if path is None:
        raise RuntimeError(
            f"no C compiler found (looked for {cc!r}, set by $CC or default 'cc'): the C target "
            "needs one. Install it (Debian/Ubuntu: apt install gcc; Fedora: dnf install gcc; "
            "macOS: xcode-select --install) or use target='numpy' or 'casadi'."
        )
    return path


def python_headers() -> tuple[str, str] | None:
    """(Python include dir, NumPy include dir) when Python.h exists, else None."""
    inc = sysconfig.get_paths()["include"]
    if not Path(inc, "Python.h").exists():
        return None
    return inc, np.get_include()


# --------------------------------------------------------------------------- building


def digest(*parts: str) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p.encode())
        h.update(b"\0")
    return h.hexdigest()


#: A model source longer than this is compiled in parts, in parallel: -O3 on a seven-joint
#: arm's 0.5 MB of C takes ~6 s in one piece, ~4 s in two on two cores.
SPLIT_BYTES = 100_000


def jobs() -> int:
    """How many compilers to run at once: the cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


#: A function definition at column 0 of a generated C file: `void f(`, `int f(`, static or not
#: (`static SYMDYN_NOINLINE void f(` too: a large function's parts).
_DEFINITION = re.compile(r"(static (\w+ )*)?(void|int) \w+\(")


def split_source(text: str, parts: int) -> list[str]:
    """A generated model's C as up to `parts` translation units of whole functions,
    each with the file's preamble (includes, static helpers), balanced by length;
    [text] when it is short or not laid out as preamble-then-functions (every
    function a `void`/`int` definition at column 0, nothing else static or
    preprocessed after the first public one)."""
    lines = text.splitlines(keepends=True)
    starts = [i for i, line in enumerate(lines) if _DEFINITION.match(line) and not line.startswith("static ")]
    if (
        parts < 2
        or len(text) < SPLIT_BYTES
        or len(starts) < 2
        or any(
            line.startswith("#") or line.startswith("static") and not _DEFINITION.match(line)
            for line in lines[starts[0] :]
        )
    ):
        return [text]
    # a static function (a SIMD kernel's lanes and range) belongs with the next
    # public function after it (its entry point): a chunk starts at the first
    # static function before a public one, if any
    starts = [
        next((j for j in range(prev + 1, i) if _DEFINITION.match(lines[j])), i)
        for prev, i in zip([starts[0] - 1] + starts, starts)
    ]
    head = "".join(lines[: starts[0]])
    chunks = ["".join(lines[a:b]) for a, b in zip(starts, starts[1:] + [len(lines)])]
    bins: list[list[str]] = [[] for _ in range(min(parts, len(chunks)))]
    for chunk in sorted(chunks, key=len, reverse=True):  # longest first, into the lightest part
        min(bins, key=lambda b: sum(map(len, b))).append(chunk)
    return [head + "".join(b) for b in bins]


def compile_sources(cc: str, flags: tuple, sources: list[Path], includes: list[str], target: Path) -> None:
    """cc flags sources -o target, atomically; a RuntimeError with the compiler's message on
    failure.  Long sources are split (`split_source`) and every unit is compiled to an
    object at once, `jobs()` compilers in parallel, then linked."""
    extra = ["-undefined", "dynamic_lookup"] if sys.platform == "darwin" else []
    inc = [f"-I{i}" for i in includes]
    with tempfile.TemporaryDirectory(prefix=f".{target.stem}.", dir=target.parent) as tmp:
        units = []
        for src in sources:
            pieces = split_source(src.read_text(), jobs())
            if len(pieces) == 1:
                units.append(src)
                continue
            for k, text in enumerate(pieces):
                units.append(Path(tmp, f"{src.stem}.part{k}.c"))
                units[-1].write_text(text)
        objects = [Path(tmp, f"{k}.{u.stem}.o") for k, u in enumerate(units)]
        cmds = [[cc, *flags, *inc, "-c", str(u), "-o", str(o)] for u, o in zip(units, objects)]
        run_all(cmds, units)
        linked = Path(tmp, target.name)
        run_all([[cc, *flags, *extra, *map(str, objects), "-o", str(linked), "-lm"]], [target])
        os.replace(linked, target)


def run_all(cmds: list[list[str]], names: list[Path]) -> None:
    """Run the commands, `jobs()` at a time; a RuntimeError with the first failure's message."""
    pending, running, failures = list(zip(cmds, names)), [], []
    while pending or running:
        while pending and len(running) < jobs():
            cmd, name = pending.pop(0)
            running.append(
                (subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True), cmd, name)
            )
        proc, cmd, name = running.pop(0)
        _, err = proc.communicate()
        if proc.returncode != 0:
            failures.append(f"compiling {name.name} failed ({' '.join(cmd)}):\n{err[-2000:]}")
    if failures:
        raise RuntimeError(failures[0])


def build(flags: tuple, files: dict, includes: list[str], target: Path) -> Path:
    """Write the sources (file name → text) beside `target` and compile them
    (without -march=native if the compiler rejects it), then record the
    library's sha256 beside it; in a temporary folder if the cache cannot be
    written.  Returns the library's path."""
    cc = compiler()
    folder = writable(target.parent)
    sources = [write_atomic(folder / name, text) for name, text in files.items()]
    sources = [p for p in sources if p.suffix == ".c"]
    includes = [str(folder), *includes]
    target = folder / target.name
    try:
        compile_sources(cc, flags, sources, includes, target)
    except RuntimeError:
        if "-march=native" not in flags:
            raise
        compile_sources(cc, tuple(f for f in flags if f != "-march=native"), sources, includes, target)
    record(target)
    return target


def _recorded(lib: Path) -> Path:
    """The file beside a built library holding the sha256 it was built with."""
    return lib.with_name(lib.name + ".sha256")


def record(lib: Path) -> None:
    """Write beside a library just built the sha256 that `intact` checks it by."""
    write_atomic(_recorded(lib), _sha256(lib))


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def library(path: Path, flags: tuple, files: dict, includes: list[str]) -> Path:
    """The library at `path` when it is intact, else built (see `build`).
    Intact: its sha256 is the one recorded when it was built.  A truncated or
    altered library would crash the process that loads it (SIGBUS, SIGSEGV)
    rather than raise, so a missing or different hash means rebuild.  Processes
    that want the same library (test workers, a cluster's workers on one
    machine) build it once: the others wait on a lock file beside it."""
    if intact(path):
        return path
    with build_lock(path):
        return path if intact(path) else build(flags, files, includes, path)


def intact(path: Path) -> bool:
    """Whether the library at `path` has the sha256 recorded when it was built (a
    truncated or altered library would crash the process that loads it)."""
    try:
        return _recorded(path).read_text() == _sha256(path)
    except OSError:
        return False
