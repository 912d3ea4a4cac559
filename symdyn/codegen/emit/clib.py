"""Compile a generated .c/.h into shared libraries, function by function when
first called, and call them from Python.

`load_library` splits the model's C file into translation units, two per
function: its scalar code (the public `void <model>_<f>(` and its `_batch`
loop, with any `static` parts before them) and its SIMD kernel
(`<model>_<f>_simd` with its static `_lanes`/`_range` helpers), each with the
file's preamble (includes and static helpers) in front (`function_units`).
Nothing is compiled then: a function's scalar unit is compiled the first time
it is called with one state, its SIMD unit the first time it is called with a
batch (with the scalar unit, which the kernel calls for the states it cannot
take: see `_Units`), so that the first `tau` does not wait for
`fdyn_derivatives`.  `CLibrary.build` compiles them all ahead, in parallel.

Every unit is built with the system C compiler (`$CC`, else `cc`) into its
own shared object in symdyn's cache folder
(`symdyn.derivation.cache.cache_dir()`, outside the repository) under a name
from the sha256 of everything that affects it (the unit's text, compiler,
flags, the host for -march=native): an unchanged function is never rebuilt,
two models with the same function text share it, and a unit is reused once
its sha256, recorded beside it when it was built, is verified (a truncated
library would crash Python when loaded).  A cache that cannot be written
means a temporary folder; two processes wanting the same unit build it once.

Two bindings: a small CPython extension (per-call overhead well under a
microsecond once a function is bound; needs Python.h), compiled once for all
models (it holds no model code: each function's address is bound into its
table on first use), and ctypes (no headers needed, a few µs per call).  Both
follow the contract of `symdyn.codegen.contract` (shapes, broadcasting,
keyword arguments, bad input) and return new arrays.
"""

from __future__ import annotations

import atexit
import concurrent.futures
import contextlib
import ctypes
import dataclasses
import hashlib
import importlib.machinery
import importlib.util
import os
import platform
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import threading
import weakref
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...derivation import progress
from ...derivation.cache import build_lock, cache_dir, fork_safe, writable
from .. import contract
from . import write_atomic
from .c import Signature, read_signatures

__all__ = ["CompileOptions", "CLibrary", "load_library", "load_units", "compiler", "function_units"]

#: -march=native: the library is built for this machine (the cache key includes the host name).
DEFAULT_FLAGS = ("-O3", "-march=native", "-fPIC", "-shared", "-pthread", "-fopenmp-simd", "-DSYMDYN_OPENMP_SIMD")


@dataclass(frozen=True)
class CompileOptions:
    """How to build: compiler flags and binding ("auto": the extension when
    Python.h is available, else ctypes; or "extension" / "ctypes")."""

    flags: tuple = DEFAULT_FLAGS
    binding: str = "auto"

    def __post_init__(self) -> None:
        if self.binding not in ("auto", "extension", "ctypes"):
            raise ValueError(f"binding must be 'auto', 'extension' or 'ctypes', got {self.binding!r}")


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


def _python_headers() -> tuple[str, str] | None:
    """(Python include dir, NumPy include dir) when Python.h exists, else None."""
    inc = sysconfig.get_paths()["include"]
    if not Path(inc, "Python.h").exists():
        return None
    return inc, np.get_include()


# --------------------------------------------------------------------------- the extension glue

#: The binding's C source, a real C file shipped beside this module (`runtime/glue.c`).
GLUE_C = Path(__file__).with_name("runtime") / "glue.c"


def _glue_source(module: str) -> str:
    """The CPython extension that binds every model's functions (`runtime/glue.c`): the
    contract's fast path in C, each function's compiled code bound on first use; `module` its name."""
    return f"#define SYMDYN_MODULE {module}\n" + GLUE_C.read_text()


def _doc(sig: Signature) -> str:
    """A function's docstring, with its signature for `inspect.signature`."""
    return (
        f"{sig.name}($module, {', '.join(a for a, _ in sig.inputs)}, *, out=None, threads=None)\n--\n\n"
        f"{sig.line()[len('function: ') :]}; batched over leading axes (SIMD across states, "
        f"on `threads` threads), into out= if given"
    )


def _glue(flags: tuple, headers: tuple[str, str]):
    """The extension module (imported), built once into the cache for this Python, NumPy,
    compiler and flags (without -march=native: it holds no model code)."""
    flags = tuple(f for f in flags if f != "-march=native")
    key = _digest(_glue_source("MODULE"), os.environ.get("CC", "cc"), " ".join(flags), sys.version, np.__version__)
    module = f"_symdyn_glue_{key[:16]}"
    if module in sys.modules:
        return sys.modules[module]
    path = cache_dir() / "c" / "glue" / f"{module}{sysconfig.get_config_var('EXT_SUFFIX')}"
    with progress.reported("symdyn: compiling the C binding (once for this Python)"):
        lib = _library(path, flags, {f"{module}.c": _glue_source(module)}, list(headers))
    ext = _import_extension(module, lib)
    ext._set_threads(_jobs())
    return ext


# --------------------------------------------------------------------------- building


def _digest(*parts: str) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p.encode())
        h.update(b"\0")
    return h.hexdigest()


#: A model source longer than this is compiled in parts, in parallel: -O3 on a seven-joint
#: arm's 0.5 MB of C takes ~6 s in one piece, ~4 s in two on two cores.
SPLIT_BYTES = 100_000


def _jobs() -> int:
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


def _compile(cc: str, flags: tuple, sources: list[Path], includes: list[str], target: Path) -> None:
    """cc flags sources -o target, atomically; a RuntimeError with the compiler's message on
    failure.  Long sources are split (`split_source`) and every unit is compiled to an
    object at once, `_jobs()` compilers in parallel, then linked."""
    extra = ["-undefined", "dynamic_lookup"] if sys.platform == "darwin" else []
    inc = [f"-I{i}" for i in includes]
    with tempfile.TemporaryDirectory(prefix=f".{target.stem}.", dir=target.parent) as tmp:
        units = []
        for src in sources:
            pieces = split_source(src.read_text(), _jobs())
            if len(pieces) == 1:
                units.append(src)
                continue
            for k, text in enumerate(pieces):
                units.append(Path(tmp, f"{src.stem}.part{k}.c"))
                units[-1].write_text(text)
        objects = [Path(tmp, f"{k}.{u.stem}.o") for k, u in enumerate(units)]
        cmds = [[cc, *flags, *inc, "-c", str(u), "-o", str(o)] for u, o in zip(units, objects)]
        _run_all(cmds, units)
        linked = Path(tmp, target.name)
        _run_all([[cc, *flags, *extra, *map(str, objects), "-o", str(linked), "-lm"]], [target])
        os.replace(linked, target)


def _run_all(cmds: list[list[str]], names: list[Path]) -> None:
    """Run the commands, `_jobs()` at a time; a RuntimeError with the first failure's message."""
    pending, running, failures = list(zip(cmds, names)), [], []
    while pending or running:
        while pending and len(running) < _jobs():
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


def _build(flags: tuple, files: dict, includes: list[str], target: Path) -> Path:
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
        _compile(cc, flags, sources, includes, target)
    except RuntimeError:
        if "-march=native" not in flags:
            raise
        _compile(cc, tuple(f for f in flags if f != "-march=native"), sources, includes, target)
    write_atomic(_recorded(target), _sha256(target))
    return target


def _recorded(lib: Path) -> Path:
    """The file beside a built library holding the sha256 it was built with."""
    return lib.with_name(lib.name + ".sha256")


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _library(path: Path, flags: tuple, files: dict, includes: list[str]) -> Path:
    """The library at `path` when it is intact, else built (see `_build`).
    Intact: its sha256 is the one recorded when it was built.  A truncated or
    altered library would crash the process that loads it (SIGBUS, SIGSEGV)
    rather than raise, so a missing or different hash means rebuild.  Processes
    that want the same library (test workers, a cluster's workers on one
    machine) build it once: the others wait on a lock file beside it."""
    if _intact(path):
        return path
    with build_lock(path):
        return path if _intact(path) else _build(flags, files, includes, path)


# --------------------------------------------------------------------------- one unit per function

#: A function definition at column 0: (static and its qualifiers, or None), the name.
_FUNCTION = re.compile(r"(static (?:\w+ )*)?(?:void|int) (\w+)\(")

#: The two kinds of unit of a function, as named in messages.
KINDS = {"scalar": "scalar code", "simd": "batch kernel"}


def _chunk_start(lines: list[str], start: int, floor: int) -> int:
    """`start` moved back over the blank lines and whole comments (a function's doc)
    just before it, never to `floor` or before."""
    j = start
    while j - 1 > floor:
        line = lines[j - 1]
        if not line.strip():
            j -= 1
        elif line.rstrip().endswith("*/"):
            k = next((k for k in range(j - 1, floor, -1) if "/*" in lines[k]), None)
            if k is None or not lines[k].lstrip().startswith("/*"):
                break
            j = k
        else:
            break
    return j


def _layout(model: str, text: str) -> tuple[str, dict[str, str]] | None:
    """(preamble, {public function name: its chunk}) of a generated C file, or None
    when it is not laid out as symdyn writes it: the preamble (includes, static
    helpers), then only definitions of the model's functions (`<model>_…`) at column 0,
    each public one preceded by the static ones that belong with it (a SIMD kernel's
    lanes and range, a large function's parts) and by its doc comment."""
    lines = text.splitlines(keepends=True)
    ours = [(i, m) for i, line in enumerate(lines) if (m := _FUNCTION.match(line)) and m[2].startswith(model + "_")]
    if not ours or ours[-1][1][1]:
        return None
    for line in lines[ours[0][0] :]:
        m = _FUNCTION.match(line)
        if line.startswith("#") or line.startswith("static") and not (m and m[2].startswith(model + "_")):
            return None  # preprocessing or a helper after the model's first function
    chunks, pending, floor, bounds = {}, None, -1, []
    for i, m in ours:
        if m[1]:
            pending = i if pending is None else pending
            continue
        start = _chunk_start(lines, i if pending is None else pending, floor)
        bounds.append((m[2], start))
        pending, floor = None, i
    head = "".join(lines[: bounds[0][1]])
    ends = [b for _, b in bounds[1:]] + [len(lines)]
    for (name, start), end in zip(bounds, ends):
        chunks[name] = "".join(lines[start:end])
    return head, chunks


def function_units(model: str, c_text: str, h_text: str, names: list[str]) -> dict[tuple[str, str], str]:
    """The translation units of a generated model's C: {(function, "scalar"): text,
    (function, "simd"): text} for every function name.

    A scalar unit is the file's preamble (its includes and static helpers, the
    header's include replaced by the function's own prototypes) and the function's
    chunk: the public `void <model>_<f>(` with the static functions before it (a large
    function's parts) and its `_batch` loop.  A SIMD unit is the preamble and the
    kernel `<model>_<f>_simd` with its static `_lanes` and `_range`; the scalar function
    it calls for the states it cannot take is a pointer there, `<model>_<f>_scalar_`
    (`#define <model>_<f> (*<model>_<f>_scalar_)` turns the prototype into it), set
    to the scalar unit's function when the kernel is loaded.  The file's leading
    comment (provenance, its own checksum) is left out, so that a function's units
    change only when its code does.  A file not laid out so (`_layout`) is one unit,
    the whole file, for every function and kind.

    Raises:
        ValueError: a function of `names` is not in the file.
    """
    layout = _layout(model, c_text)
    include = re.compile(rf'^#include "{re.escape(model)}\.h"[ \t]*\n', re.M)
    protos = {
        (f, s): re.search(rf"^(?:void|int) {re.escape(model)}_{re.escape(f)}{s}\(.*\);[ \t]*$", h_text, re.M)
        for f in names
        for s in ("", "_batch", "_simd")
    }
    whole = (
        layout is None
        or not all(protos.values())
        or not include.search(layout[0])
        or any(f"{model}_{f}{s}" not in layout[1] for f in names for s in ("", "_batch", "_simd"))
    )
    if whole:
        for f in names:
            if not re.search(rf"\b{re.escape(model)}_{re.escape(f)}\(", c_text):
                raise ValueError(f"the C file of {model} has no function {model}_{f}")
        text = include.sub(lambda _: h_text + "\n", c_text)
        return {(f, kind): text for f in names for kind in KINDS}
    head, chunks = layout
    if head.startswith("/*"):
        head = head[head.index("*/") + 2 :].lstrip("\n")
    units = {}
    for f in names:
        own = "".join(protos[f, s][0] + "\n" for s in ("", "_batch", "_simd"))
        scalar = f"/* {model}_{f}: scalar code, from {model}.h */\n{own}"
        simd = (
            f"/* {model}_{f}: batch kernel; the scalar function it calls for the states it cannot\n"
            f"   take is a pointer, set when the kernel is loaded */\n"
            f"#define {model}_{f} (*{model}_{f}_scalar_)\n{own}"
        )
        units[f, "scalar"] = include.sub(lambda _: scalar, head) + chunks[f"{model}_{f}"] + chunks[f"{model}_{f}_batch"]
        units[f, "simd"] = include.sub(lambda _: simd, head) + chunks[f"{model}_{f}_simd"]
    return units


#: A SIMD kernel's unit of at least this many bytes is compiled at -O2 instead of -O3, and
#: at -O1 from SIMD_O1_BYTES on (when the flags say -O3; a scalar unit always keeps them).
#: Measured with gcc 12.2 on this 2-core machine (2026-11-25, min of two compiles each;
#: run: µs per state, batch of 2048 on one thread, best of three rounds), -O3 / -O2 / -O1:
#:
#:   unit (bytes)                         compile s            run µs/state
#:   Panda C kernel (84 k)                0.63 / 0.56 / 0.51   0.103 / 0.098 / 0.107
#:   Panda Y kernel (71 k)                1.72 / 1.44 / 0.99   0.652 / 0.741 / 0.814
#:   Panda ∂τ kernel (119 k)              1.45 / 1.10 / 0.93   0.195 / 0.192 / 0.211
#:   Panda ∂fdyn kernel (154 k)           1.98 / 1.67 / 1.31   0.373 / 0.415 / 0.438
#:   10-joint C kernel (151 k)            1.50 / 1.34 / 1.48   0.230 / 0.219 / 0.233
#:   10-joint Y kernel (205 k)            4.73 / 3.66 / 3.17   3.531 / 3.648 / 4.035
#:   10-joint ∂τ kernel (277 k)           4.84 / 4.34 / 3.36   0.510 / 0.510 / 0.524
#:   10-joint ∂fdyn kernel (409 k)        8.31 / 7.05 / 6.46   0.766 / 0.739 / 0.766
#:   Panda ∂fdyn scalar (144 k)           1.77 / 1.66 / 1.63   1.457 / 1.469 / 1.753 (one call)
#:   10-joint ∂fdyn scalar (522 k, parts) 2.57 / 3.06 / 3.48   3.370 / 3.367 / 4.759 (one call)
#:
#: A large kernel (one lane loop, which gcc's register allocation and scheduling take
#: superlinearly) compiles 10-25 % faster at -O2 and runs as fast (within the ±10 % noise
#: of a shared machine); -O1 saves 20-40 % and costs the smaller kernels up to 25 % of run
#: time, the largest (over 256 kB: the derivatives of 10 joints) 0-4 %.  Scalar code (a
#: large function in `static` parts of bounded size, `c.SPLIT_ABOVE`) compiles no faster
#: at a lower level and runs 10-40 % slower at -O1: it keeps -O3.  Under 64 kB the
#: difference is a tenth of a second.
SIMD_O2_BYTES = 64_000

#: A batch kernel of at least this much C compiles in the background at its first batch call,
#: which the scalar code answers meanwhile (state after state, the single calls' values): gcc's
#: time and memory on a kernel grow faster than its size (a random 30-joint arm's
#: fdyn_derivatives: still compiling after 14 min at 7.7 GB), and no call should wait longer than
#: the scalar loop takes.  Smaller kernels (every shipped arm's, a quadruped's τ, M, q̈) compile at
#: the first batch call, as before.  `CLibrary.build` compiles any ahead.
BACKGROUND_BYTES = 1_000_000
#: A batch kernel of at least this much C is not compiled at a call at all (its compile would take
#: many minutes and gigabytes): the scalar code serves its batches; `CLibrary.build` still builds it.
SCALAR_ONLY_BYTES = 8_000_000
SIMD_O1_BYTES = 256_000


def _unit_flags(flags: tuple, text: str, kind: str) -> tuple:
    """The flags a unit is compiled with: `flags`, with -O3 lowered for a large SIMD kernel."""
    if kind != "simd" or "-O3" not in flags or len(text) < SIMD_O2_BYTES:
        return flags
    level = "-O1" if len(text) >= SIMD_O1_BYTES else "-O2"
    return tuple(level if f == "-O3" else f for f in flags)


@dataclass(frozen=True)
class _Unit:
    """One translation unit to build: what it is (for messages), its text and flags,
    and the shared object it becomes."""

    model: str
    function: str
    kind: str
    text: str
    flags: tuple
    path: Path

    @property
    def label(self) -> str:
        return f"{self.model}'s {self.function} ({KINDS[self.kind]})"


def _intact(path: Path) -> bool:
    """Whether the library at `path` has the sha256 recorded when it was built (a
    truncated or altered library would crash the process that loads it)."""
    try:
        return _recorded(path).read_text() == _sha256(path)
    except OSError:
        return False


#: `CLibrary.build`'s order: the functions that take longest to compile first (G1's arm:
#: 3.0, 2.0, 1.9, 1.6 s of gcc), tau_derivatives before fdyn_derivatives because its program
#: is ready sooner (fdyn_derivatives needs fdyn's and Minv's too), so that the big compiles
#: run while the small programs are made and the last compile to finish is a short one
#: (xArm7 5.0 -> 4.7 s, G1's arm 8.8 -> 8.0 s against fdyn_derivatives first).
HEAVIEST_FIRST = ("tau_derivatives", "fdyn_derivatives", "Y", "C", "fdyn")


def _build_units(units: list[_Unit]) -> None:
    """Build the units whose library is missing or not intact, `_jobs()` compilers at a
    time, each under its build lock (another process building one: wait for it), each
    written atomically with its sha256 beside it; without -march=native when the
    compiler rejects it.  Over REPORT_AFTER_S the build says so on stderr, naming the
    functions.  Raises a RuntimeError naming the function and with the compiler's
    message when one does not compile."""
    units = list({u.path: u for u in units}.values())
    if all(_intact(u.path) for u in units):
        return
    cc = compiler()
    with contextlib.ExitStack() as locks:
        todo = []
        for u in sorted(units, key=lambda u: str(u.path)):  # one order: two processes never deadlock
            if _intact(u.path):
                continue
            locks.enter_context(build_lock(u.path))
            if not _intact(u.path):
                todo.append(u)
        if not todo:
            return
        names = ", ".join(u.label for u in todo)
        with progress.reported(f"symdyn: compiling {names}"):
            _compile_units(cc, todo)


def _compile_units(cc: str, units: list[_Unit]) -> None:
    """cc each unit into its library, in parallel; on Ctrl-C or an error the compilers
    are stopped and no partial file is left."""
    pending, running, failure = list(units), [], None
    try:
        while (pending or running) and failure is None:
            while pending and len(running) < _jobs():
                u = pending.pop(0)
                source = write_atomic(u.path.with_suffix(".c"), u.text)
                running.append(_start(cc, u, source, u.flags))
            u, proc, cmd, tmp = running.pop(0)
            _, err = proc.communicate()
            if proc.returncode != 0 and "-march=native" in u.flags and "native" in err:
                flags = tuple(f for f in u.flags if f != "-march=native")
                running.insert(0, _start(cc, u, u.path.with_suffix(".c"), flags))
                continue
            if proc.returncode != 0:
                failure = f"compiling {u.label} failed ({' '.join(cmd)}):\n{err[-2000:]}"
                tmp.unlink(missing_ok=True)
                continue
            os.replace(tmp, u.path)
            write_atomic(_recorded(u.path), _sha256(u.path))
    finally:
        for u, proc, cmd, tmp in running:
            proc.kill()
            proc.wait()
            tmp.unlink(missing_ok=True)
    if failure:
        raise RuntimeError(failure)


def _start(cc: str, u: _Unit, source: Path, flags: tuple):
    """(unit, compiler process, command, temporary output) of one unit's compile; the compiler is
    ended when this process exits (`_RUNNING`), however it exits."""
    tmp = u.path.with_name(f".{u.path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    cmd = [cc, *flags, str(source), "-o", str(tmp), "-lm"]
    proc = subprocess.Popen([*_with_parent(), *cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _RUNNING.add(proc)
    return u, proc, cmd, tmp


#: The compilers running now: killed at the interpreter's exit (a background kernel's compile
#: would outlive it otherwise).
_RUNNING: "weakref.WeakSet[subprocess.Popen]" = weakref.WeakSet()


@atexit.register
def _end_compilers() -> None:
    for proc in list(_RUNNING):
        if proc.poll() is None:
            proc.kill()


#: Linux: the compiler is started through a small launcher that asks the kernel for SIGKILL when
#: the thread that started it ends (PR_SET_PDEATHSIG, kept across exec) and then becomes the
#: compiler, so that a killed interpreter's compiler dies too; no `preexec_fn` (a fork of a
#: threaded process, which JAX and the thread pools make unsafe).  Elsewhere the atexit handler
#: alone ends them.
_LAUNCHER = (
    "import ctypes, os, sys\n"
    "ctypes.CDLL(None).prctl(1, 9)\n"
    "if os.getppid() != int(sys.argv[1]):\n"
    "    sys.exit(1)\n"
    "os.execvp(sys.argv[2], sys.argv[2:])\n"
)


def _with_parent() -> list[str]:
    """The launcher's command before the compiler's (none off Linux); this process's pid now (a
    forked child's own)."""
    return [sys.executable, "-c", _LAUNCHER, str(os.getpid())] if sys.platform.startswith("linux") else []


class _Units:
    """The units of one loaded model: built (or found in the cache) and loaded when a
    call first needs them; callable as the binding's builder: (function, kind) → the
    address of the compiled code (`<model>_<f>` or `<model>_<f>_simd`).  A SIMD unit's
    scalar fallback is bound to the scalar unit's function when it is loaded (both are
    compiled at once when neither is built)."""

    def __init__(self, model: str, units: Mapping[tuple[str, str], str], flags: tuple, whole: bool = False) -> None:
        self.model, self.texts, self.flags, self.whole = model, units, tuple(flags), whole
        self.host = platform.node() if "-march=native" in self.flags else ""
        self.lock = threading.RLock()  # one thread builds; the others wait, then find it loaded
        fork_safe(self, "lock")  # a forked child gets a lock of its own
        self.loaded: dict[tuple[str, str], tuple[ctypes.CDLL, int]] = {}
        self._units: dict[tuple[str, str], _Unit] = {}
        self._compiling: set[str] = set()  # batch kernels compiling in the background
        self._failed: dict[str, Exception] = {}
        self._folder: Path | None = None

    def folder(self) -> Path:
        if self._folder is None:
            self._folder = writable(cache_dir() / "c" / "units")
        return self._folder

    def unit(self, function: str, kind: str) -> _Unit:
        """The unit of `function` of kind "scalar" or "simd" (its cache name from the sha256 of its
        text, the compiler, the flags and for -march=native the host; a SIMD unit's also from its
        scalar unit's, which it calls)."""
        if (function, kind) not in self._units:
            if (function, kind) not in self.texts:
                raise KeyError(f"{self.model} has no function {function!r} (kind {kind!r})")
            text = self.texts[function, kind]
            whole = self.whole  # the whole file: one library for all
            flags = self.flags if whole else _unit_flags(self.flags, text, kind)
            scalar = self.unit(function, "scalar").path.name if kind == "simd" and not whole else ""
            key = _digest(text, os.environ.get("CC", "cc"), " ".join(flags), self.host, scalar)[:20]
            name = f"{self.model}.whole" if whole else f"{self.model}_{function}.{kind}"
            path = self.folder() / f"{name}.{key}.so"
            self._units[function, kind] = _Unit(self.model, function, kind, text, flags, path)
        return self._units[function, kind]

    def prepare(self, wanted: list[tuple[str, str]]) -> None:
        """Build (in parallel) and load the units `wanted` and the scalar units their kernels call."""
        with self.lock:
            need = [(f, "scalar") for f, _ in wanted] + [(f, k) for f, k in wanted if k != "scalar"]
            need = [u for u in dict.fromkeys(need) if u not in self.loaded]  # in wanted's order, scalar first
            if isinstance(self.texts, dict) or len(need) < 2:
                units = [self.unit(*u) for u in need]
                _build_units(units)
            else:  # texts made when first read (a program each): make the next while the last compiles
                units, builds = [], []
                bar = progress.Progress(f"symdyn: building {self.model}", len(need), after=progress.REPORT_AFTER_S)
                # one core stays with the programs while they are made (they are the critical path:
                # xArm7 6.2 s → 5.0 s on two cores), every core compiles once they are all made
                gate = threading.Semaphore(max(1, _jobs() - 1))

                def build(unit: _Unit) -> None:
                    with gate:
                        _build_units([unit])

                with concurrent.futures.ThreadPoolExecutor(max_workers=_jobs()) as pool:
                    for u in need:
                        units.append(self.unit(*u))
                        builds.append(pool.submit(build, units[-1]))
                    if _jobs() > 1:
                        gate.release()
                    for (f, kind), b in zip(need, builds):
                        b.result()
                        bar.step(f"{f} ({KINDS[kind]})")
                bar.done()
            for u in units:  # scalar ones first
                self._load(u)

    def _load(self, u: _Unit) -> None:
        dll = ctypes.CDLL(str(u.path))
        symbol = f"{self.model}_{u.function}" + ("_simd" if u.kind == "simd" else "")
        address = ctypes.cast(getattr(dll, symbol), ctypes.c_void_p).value
        if u.kind == "simd" and not self.whole:
            fallback = ctypes.c_void_p.in_dll(dll, f"{self.model}_{u.function}_scalar_")
            fallback.value = self.loaded[u.function, "scalar"][1]
        self.loaded[u.function, u.kind] = (dll, address)

    def __call__(self, function: str, kind: str) -> int:
        """The address of `function`'s compiled code of `kind`, built and loaded if need be; 0 for
        a large batch kernel not yet built (`background`): the call uses the scalar code meanwhile."""
        with self.lock:
            if (function, kind) not in self.loaded:
                if kind == "simd" and self.background(function):
                    return 0
                self.prepare([(function, kind)])
            return self.loaded[function, kind][1]

    def background(self, function: str) -> bool:
        """Whether `function`'s batch calls go to the scalar code: its kernel is being compiled in the
        background (started here if its unit has BACKGROUND_BYTES or more of C and is not in the
        cache; the scalar unit is built first, for the calls meanwhile), or is too large to compile
        at a call (SCALAR_ONLY_BYTES).  A kernel that failed to compile raises here, at the first
        batch call after."""
        if function in self._failed:
            raise self._failed[function]
        if function in self._compiling:
            return True
        size = 0 if self.whole else len(self.texts[function, "simd"])
        if size < BACKGROUND_BYTES:
            return False
        unit = self.unit(function, "simd")
        if _intact(unit.path):
            return False
        self.prepare([(function, "scalar")])
        if size >= SCALAR_ONLY_BYTES:  # the scalar code serves its batches for good
            return True

        def build() -> None:
            try:
                _build_units([unit])
                with self.lock:
                    self._load(unit)
            except Exception as exc:  # surfaced at the next batch call (`background`)
                self._failed[function] = exc
            finally:
                self._compiling.discard(function)

        self._compiling.add(function)
        threading.Thread(target=build, name=f"symdyn: {unit.label}", daemon=True).start()
        return True


def load_library(c_path: Path, h_path: Path, options: CompileOptions = CompileOptions()) -> "CLibrary":
    """Bind the model in c_path/h_path, compiling nothing of it yet: each function's
    translation units (`function_units`) are compiled into the cache (or found there)
    when a call first needs them, its scalar code at its first single-state call, its
    SIMD kernel at its first batch; `CLibrary.build` compiles them ahead.  Only the
    extension binding itself is compiled here, once for this Python and compiler.

    Raises:
        ValueError: the header lists no signatures, or the C file lacks a function it lists.
        RuntimeError: binding="extension" without Python.h; no C compiler, or the binding
            does not compile (a function that does not compile raises at its first call).
    """
    c_path, h_path = Path(c_path), Path(h_path)
    model = h_path.stem
    c_text, h_text = c_path.read_text(), h_path.read_text()
    sigs = read_signatures(h_text)
    if not sigs:
        raise ValueError(f"{h_path} lists no 'function:' signatures: not a symdyn header")
    texts = function_units(model, c_text, h_text, [s.name for s in sigs])
    return load_units(model, sigs, texts, options, whole=len(set(texts.values())) == 1)


def load_units(
    model: str,
    sigs: list[Signature],
    texts: Mapping[tuple[str, str], str],
    options: CompileOptions = CompileOptions(),
    whole: bool = False,
) -> "CLibrary":
    """Bind the functions `sigs` of `model` whose translation units are `texts`
    ({(function, "scalar" or "simd"): C text}, as `function_units` makes them; a mapping
    may make each text only when it is first read: nothing is read before a call needs
    it, beyond checking, for a plain dict, whether a missing compiler matters).  `whole`:
    every text is the same whole file, one library for all.

    Raises:
        RuntimeError: binding="extension" without Python.h; no C compiler (for a plain dict:
            unless every unit is built), or the binding does not compile.
    """
    headers = _python_headers() if options.binding != "ctypes" else None
    if options.binding == "extension" and headers is None:
        raise RuntimeError(
            f"Python.h not found in {sysconfig.get_paths()['include']}: install the "
            "Python development headers (Debian/Ubuntu: apt install python3-dev) "
            "or use binding='ctypes'"
        )
    units = _Units(model, texts, options.flags, whole)
    try:
        compiler()
    except RuntimeError:  # say so now, not at the first call, unless every unit is built
        if not isinstance(texts, dict) or not all(_intact(units.unit(*u).path) for u in texts):
            raise
    if headers is None:
        functions = {s.name: _CtypesFunction(model, s, units) for s in sigs}
        return CLibrary(model, sigs, cache_dir() / "c" / "units", functions, "ctypes", units)
    ext = _glue(options.flags, headers)
    functions = {
        s.name: ext._function(s.name, _doc(s), tuple(s.inputs), tuple(shape for _, shape in s.outputs), units)
        for s in sigs
    }
    return CLibrary(model, sigs, Path(ext.__file__), functions, "extension", units)


def _import_extension(module: str, path: Path):
    if module in sys.modules:
        return sys.modules[module]
    loader = importlib.machinery.ExtensionFileLoader(module, str(path))
    spec = importlib.util.spec_from_file_location(module, str(path), loader=loader)
    ext = importlib.util.module_from_spec(spec)
    loader.exec_module(ext)
    sys.modules[module] = ext
    return ext


# --------------------------------------------------------------------------- ctypes binding


def check_out(function: str, out, shapes: list) -> list:
    """The caller's out= as a list of arrays, one per output, each exactly a
    C-contiguous writeable float64 ndarray of its shape.

    Raises:
        ValueError: out is not such an array (or tuple of them, one per output).
    """
    arrays = [out] if len(shapes) == 1 else out
    if len(shapes) > 1 and (not isinstance(out, tuple) or len(out) != len(shapes)):
        raise ValueError(f"{function}(): out must be a tuple of {len(shapes)} arrays, one per output")
    for a, shape in zip(arrays, shapes):
        if not (
            isinstance(a, np.ndarray)
            and a.dtype == np.float64
            and a.flags.c_contiguous
            and a.flags.writeable
            and a.flags.aligned
            and a.shape == shape
        ):
            raise ValueError(
                f"{function}(): out{'[k]' if len(shapes) > 1 else ''} must be a C-contiguous "
                f"writeable float64 array of shape {shape}"
            )
    return list(arrays)


class _CtypesFunction:
    """One generated function over ctypes: validates, allocates (or writes into
    out=), calls single or batched (the SIMD kernel on `threads` threads;
    ctypes releases the GIL); its compiled code is built and bound at the first
    call that needs it (`_Units`)."""

    def __init__(self, model: str, sig: Signature, units: _Units) -> None:
        self.sig, self._units = sig, units
        nargs = len(sig.inputs) + len(sig.outputs)
        self._one_type = ctypes.CFUNCTYPE(None, *[ctypes.c_void_p] * nargs)
        self._many_type = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int, ctypes.c_int, *[ctypes.c_void_p] * nargs)
        self._one = self._many = None
        self.__name__ = sig.name
        self.__doc__ = f"{sig.line()[len('function: ') :]}; batched over leading axes"
        self._lead_max = contract.MAXDIMS - max(len(shape) for _, shape in sig.outputs)

    def _bind(self, kind: str):
        address = self._units(self.sig.name, kind)
        if kind == "simd":
            self._many = self._many_type(address) if address else None
            return self._many
        self._one = self._one_type(address)
        return self._one

    def _loop(self, count: int, arrays: list, outs: list) -> None:
        """The scalar code on each state (the contract checked the inputs are finite)."""
        one = self._one or self._bind("scalar")
        flat = [a.reshape(count, -1) for a in (*arrays, *outs)]
        for k in range(count):
            one(*(x[k].ctypes.data for x in flat))

    def __call__(self, *args, out=None, threads=None, **kwargs):
        arrays, lead = contract.arguments(self.sig.name, self.sig.inputs, args, kwargs, self._lead_max)
        shapes = [lead + shape for _, shape in self.sig.outputs]
        outs = [np.empty(s) for s in shapes] if out is None else check_out(self.sig.name, out, shapes)
        if threads is None:
            threads = _jobs()
        elif int(threads) < 1:
            raise ValueError(f"{self.sig.name}(): threads must be at least 1, got {threads}")
        pointers = [a.ctypes.data for a in (*arrays, *outs)]
        if lead:
            count = int(np.prod(lead))
            if count > 2**31 - 1:
                raise ValueError(f"{self.sig.name}(): {count} states, at most {2**31 - 1} per call")
            if count:
                many = self._many or self._bind("simd")
                if many is not None:
                    many(count, min(int(threads), 256), *pointers)
                else:  # the kernel compiles in the background: the scalar code, state after state
                    self._loop(count, arrays, outs)
        else:
            (self._one or self._bind("scalar"))(*pointers)
        return outs[0] if len(outs) == 1 else tuple(outs)


@dataclass(frozen=True)
class CLibrary:
    """A bound model: its signatures, the binding's library (the extension; the folder
    of the function's libraries for ctypes), the callables and the binding's kind."""

    model: str
    signatures: list
    path: Path
    functions: dict
    binding: str
    units: _Units | None = dataclasses.field(default=None, repr=False, compare=False)

    def build(self, functions: list[str] | None = None, batch: bool = True) -> None:
        """Compile ahead, in parallel, the scalar code of `functions` (default: all) and
        with `batch` their SIMD kernels, so that no later call waits for a compiler.

        Raises:
            KeyError: a name that is not one of the model's functions.
            RuntimeError: a function does not compile (the message names it).
        """
        names = [s.name for s in self.signatures] if functions is None else list(functions)
        for name in names:
            if name not in self.functions:
                raise KeyError(f"{self.model} has no function {name!r}")
        names.sort(key=lambda f: HEAVIEST_FIRST.index(f) if f in HEAVIEST_FIRST else len(HEAVIEST_FIRST))
        self.units.prepare([(f, k) for f in names for k in (("scalar", "simd") if batch else ("scalar",))])

    def library(self, function: str, kind: str = "scalar") -> Path:
        """The shared library of `function`'s scalar code (`<model>_<f>` and
        `<model>_<f>_batch`) or, kind="simd", of its SIMD kernel, built if need be.

        Raises:
            KeyError: not one of the model's functions, or kind not "scalar" or "simd".
            RuntimeError: it does not compile (the message names it).
        """
        if function not in self.functions or kind not in KINDS:
            raise KeyError(f"{self.model} has no function {function!r} of kind {kind!r}")
        self.units.prepare([(function, kind)])
        return self.units.unit(function, kind).path
