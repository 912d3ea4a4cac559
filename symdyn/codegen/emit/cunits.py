"""One translation unit per generated function and kind, built when a call first needs it.

Part of the C target, between building (`cbuild`) and binding (`clib`): `function_units` splits a
model's C file into each function's scalar unit and SIMD unit (the file's preamble in front);
`Units` builds them into the cache (or finds them there) and loads them when a call first asks
for a function's address; a large batch kernel compiles in the background while the scalar code
answers; every compiler ends with the process that started it.
"""

from __future__ import annotations

import atexit
import concurrent.futures
import contextlib
import ctypes
import gc
import os
import platform
import re
import shutil
import subprocess
import sys
import threading
import weakref
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from ...derivation import progress
from ...derivation.cache import build_lock, cache_dir, fork_safe, writable
from . import cbuild, csimd, write_atomic

__all__ = ["KINDS", "BACKGROUND_BYTES", "SCALAR_ONLY_BYTES", "HEAVIEST_FIRST", "Units", "function_units"]

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

    A scalar unit is the file's preamble (its includes and static helpers, without the
    header's include), the function's own prototypes and the function's
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
    head = include.sub("", head)
    units = {}
    for f in names:
        own = "".join(protos[f, s][0] + "\n" for s in ("", "_batch", "_simd"))
        scalar = f"{_scalar_mark(model, f)}{own}\n"
        simd = (
            f"/* {model}_{f}: batch kernel; the scalar function it calls for the states it cannot\n"
            f"   take is a pointer, set when the kernel is loaded */\n"
            f"#define {model}_{f} (*{model}_{f}_scalar_)\n{own}\n"
        )
        units[f, "scalar"] = head + scalar + chunks[f"{model}_{f}"] + chunks[f"{model}_{f}_batch"]
        units[f, "simd"] = head + simd + chunks[f"{model}_{f}_simd"]
    return units


def _scalar_mark(model: str, function: str) -> str:
    """The line that opens a scalar unit's own part (its prototypes, then its functions), after
    the preamble every unit of its file shares."""
    return f"/* {model}_{function}: scalar code, from {model}.h */\n"


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


#: gcc builds a loop's data dependences only up to 1000 memory references
#: (--param loop-max-datarefs-for-datadeps) and leaves a larger loop unvectorized, `omp simd` or
#: not.  A lane loop stores each output once, so every kernel of more than about a thousand
#: outputs ran its lanes one at a time: Talos' M (1296) 1 509 ns a state on one thread against
#: its scalar loop's 582, and C, M⁻¹, ∂τ and Solo 12's fdyn_derivatives alike
#: (scripts/batch_vs_loop.py).  SIMD units raise the limit to 3000: Talos' M then runs 366 ns,
#: its ∂τ (2 628 outputs) 3 406 against the loop's 8 148.  The analysis grows with the square of
#: the references: at 3000 a kernel's compile takes up to ~0.5 GB more (a 3 000-output kernel
#: 4.1 → 7.0 s, 84 → 522 MB; Talos' ∂τ 104 → 63 s, the same 1.5 GB), while Talos' regressor
#: (15 480 outputs) would take 146 s and 12.7 GB instead of 16 s and 0.4 GB: a wider kernel runs
#: the scalar function instead (`csimd.LANE_REFERENCES`).  A kernel under 1000 gives the same
#: code.  gcc 12.2, timed by hand.
WIDE_LOOPS = f"--param=loop-max-datarefs-for-datadeps={csimd.LANE_REFERENCES}"

#: Flags a compiler may reject, each with the words its message then contains: dropped and the
#: unit compiled again (clang ignores gcc's --param with a warning, which -Werror makes an error;
#: an old compiler may not know -march=native).
OPTIONAL_FLAGS = {"-march=native": "-march=", WIDE_LOOPS: "loop-max-datarefs-for-datadeps"}


def _unit_flags(flags: tuple, text: str, kind: str) -> tuple:
    """The flags a unit is compiled with: `flags`; for a SIMD kernel (or a whole file, which has
    them) gcc's limit on a vectorized loop's memory references raised (`WIDE_LOOPS`) unless the
    flags set it, and -O3 lowered for a large kernel."""
    if kind == "scalar":
        return flags
    if not any("loop-max-datarefs-for-datadeps" in f for f in flags):
        flags = (*flags, WIDE_LOOPS)
    if kind != "simd" or "-O3" not in flags or len(text) < SIMD_O2_BYTES:
        return flags
    level = "-O1" if len(text) >= SIMD_O1_BYTES else "-O2"
    return tuple(level if f == "-O3" else f for f in flags)


def _without_rejected(flags: tuple, message: str) -> tuple | None:
    """`flags` without the first optional one (`OPTIONAL_FLAGS`) the compiler's message names,
    or None when it names none of them."""
    for flag, word in OPTIONAL_FLAGS.items():
        if flag in flags and word in message:
            return tuple(f for f in flags if f != flag)
    return None


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


#: `CLibrary.build`'s order: the functions that take longest to compile first (G1's arm:
#: 3.0, 2.0, 1.9, 1.6 s of gcc), tau_derivatives before fdyn_derivatives because its program
#: is ready sooner (fdyn_derivatives needs fdyn's and Minv's too), so that the big compiles
#: run while the small programs are made and the last compile to finish is a short one
#: (xArm7 5.0 -> 4.7 s, G1's arm 8.8 -> 8.0 s against fdyn_derivatives first).
HEAVIEST_FIRST = ("tau_derivatives", "fdyn_derivatives", "Y", "C", "fdyn")


#: Scalar units of less C of their own (past the preamble they share) than this that are built at
#: once share a compiler run (`_jobs`), each run taking units until it has GROUP_BYTES of it: gcc's start, its link and symdyn's launcher cost about 40 ms a run on
#: this machine whatever the unit, as much as a small function's own code (the Panda's thirteen
#: task-space units, 1.22 s of gcc one by one, 0.75 s as one file).  Larger units, SIMD kernels
#: and units of another preamble or other flags are compiled alone.
GROUP_BELOW = 32_000
GROUP_BYTES = 24_000


def _jobs(units: list[_Unit]) -> list[list[_Unit]]:
    """The compiler runs that build `units`, in their order: each small scalar unit with those
    of the same flags and preamble (`GROUP_BELOW`, `GROUP_BYTES`), every other unit alone."""
    jobs: list[list[_Unit]] = []
    open_: dict[tuple, list[_Unit]] = {}
    for u in units:
        if not _groupable(u):
            jobs.append([u])
            continue
        group = open_.get((u.flags, _preamble(u)))
        if group is None or sum(_own(v) for v in group) >= GROUP_BYTES:
            group = open_[u.flags, _preamble(u)] = []
            jobs.append(group)
        group.append(u)
    return jobs


def _groupable(u: _Unit) -> bool:
    """Whether a unit may share a compiler run: a small scalar unit laid out by `function_units`."""
    return u.kind == "scalar" and _preamble(u) is not None and _own(u) < GROUP_BELOW


def _preamble(u: _Unit) -> str | None:
    """The preamble of a scalar unit (what comes before its own part), None if it has none."""
    at = u.text.find(_scalar_mark(u.model, u.function))
    return None if at < 0 else u.text[:at]


def _own(u: _Unit) -> int:
    """The bytes of C of a unit's own part (all of it when it has no preamble of its own)."""
    head = _preamble(u)
    return len(u.text) - (0 if head is None else len(head))


def _source(job: list[_Unit]) -> str:
    """The C of one compiler run: a unit's text, or the group's preamble once and each unit's own
    part after it, calling one copy of the trigonometric loop (SYMDYN_TRIG_LOOP_CALLED)."""
    if len(job) == 1:
        return job[0].text
    head = _preamble(job[0])
    return "#define SYMDYN_TRIG_LOOP_CALLED\n" + head + "".join(u.text[len(head) :] for u in job)


def _build_units(units: list[_Unit]) -> None:
    """Build the units whose library is missing or not intact, `cbuild.jobs()` compilers at a
    time, each under its build lock (another process building one: wait for it), each
    written atomically with its sha256 beside it; without an optional flag the compiler
    rejects (`OPTIONAL_FLAGS`).  Over REPORT_AFTER_S the build says so on stderr, naming the
    functions.  Raises a RuntimeError naming the function and with the compiler's
    message when one does not compile."""
    units = list({u.path: u for u in units}.values())
    if all(cbuild.intact(u.path) for u in units):
        return
    cc = cbuild.compiler()
    with contextlib.ExitStack() as locks:
        todo = []
        for u in sorted(units, key=lambda u: str(u.path)):  # one order: two processes never deadlock
            if cbuild.intact(u.path):
                continue
            locks.enter_context(build_lock(u.path))
            if not cbuild.intact(u.path):
                todo.append(u)
        if not todo:
            return
        names = ", ".join(u.label for u in todo)
        with progress.reported(f"symdyn: compiling {names}"):
            _compile_units(cc, todo)


def _compile_units(cc: str, units: list[_Unit]) -> None:
    """cc each unit into its library, in parallel, the small ones in groups (`_jobs`: a group's
    library is linked, or copied, to each unit's name; a group that does not compile is compiled
    unit by unit); on Ctrl-C or an error the compilers are stopped and no partial file is left."""
    pending, running, failure = _jobs(units), [], None
    try:
        while (pending or running) and failure is None:
            while pending and len(running) < cbuild.jobs():
                job = pending.pop(0)
                running.append(_start(cc, job, write_atomic(_source_path(job), _source(job)), job[0].flags))
            job, proc, cmd, tmp = running.pop(0)
            _, err = proc.communicate()
            fewer = _without_rejected(tuple(cmd[1:-4]), err) if proc.returncode != 0 else None
            if fewer is not None:
                running.insert(0, _start(cc, job, _source_path(job), fewer))
                continue
            if len(job) > 1:  # a group's source is its units' texts: not kept
                _source_path(job).unlink(missing_ok=True)
            if proc.returncode != 0:
                tmp.unlink(missing_ok=True)
                if len(job) > 1:  # each on its own: the error names the culprit, the others are built
                    pending[:0] = [[u] for u in job]
                    continue
                failure = f"compiling {job[0].label} failed ({' '.join(cmd)}):\n{err[-2000:]}"
                continue
            try:
                for u in job[1:]:
                    _place(tmp, u.path)
                os.replace(tmp, job[0].path)
            except BaseException:
                tmp.unlink(missing_ok=True)
                raise
            cbuild.record(job[0].path)
    finally:
        for job, proc, cmd, tmp in running:
            proc.kill()
            proc.wait()
            tmp.unlink(missing_ok=True)
            if len(job) > 1:
                _source_path(job).unlink(missing_ok=True)
    if failure:
        raise RuntimeError(failure)


def _source_path(job: list[_Unit]) -> Path:
    """Where a compiler run's C is written: beside the unit's library, or for a group beside its
    first unit's, named by its units' keys."""
    if len(job) == 1:
        return job[0].path.with_suffix(".c")
    key = cbuild.digest(*(u.path.name for u in job))[:20]
    return job[0].path.with_name(f"{job[0].model}.group.{key}.c")


def _place(built: Path, path: Path) -> None:
    """A group's library under one of its units' names (a hard link, or a copy where the file
    system has none), written atomically, its sha256 recorded."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    tmp.unlink(missing_ok=True)  # a killed process's, maybe linked to a library in use: never written into
    try:
        try:
            os.link(built, tmp)
        except OSError:
            shutil.copyfile(built, tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    cbuild.record(path)


def _start(cc: str, job: list[_Unit], source: Path, flags: tuple):
    """(units, compiler process, command, temporary output) of one compiler run; the compiler is
    ended when this process exits (`_RUNNING`), however it exits."""
    path = job[0].path
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    cmd = [cc, *flags, str(source), "-o", str(tmp), "-lm"]
    proc = subprocess.Popen([*_with_parent(), *cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _RUNNING.add(proc)
    return job, proc, cmd, tmp


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
    # -S -I: no site-packages, no user environment (the launcher needs only the standard library):
    # its start 20 → 10 ms, once per unit compiled
    return [sys.executable, "-S", "-I", "-c", _LAUNCHER, str(os.getpid())] if sys.platform.startswith("linux") else []


_GC_LOCK = threading.Lock()
_GC_PAUSE = {"count": 0, "thresholds": (700, 10, 10)}


@contextlib.contextmanager
def full_collections_paused():
    """No full collection of Python's cyclic garbage collector while models are derived, emitted
    and compiled (the young generations still collected; the process's thresholds back when the
    last such build ends): a full collection walks every sympy expression alive.  A whole build's
    Python time: the Panda 2.2 → 1.9 s, Solo 12 5.4 → 4.7, Talos 24.2 → 20.7; peak memory 157 →
    161, 181 → 198 and 297 → 385 MB (GC off altogether: 19.9 s and 492 MB for Talos)."""
    with _GC_LOCK:
        if _GC_PAUSE["count"] == 0:
            _GC_PAUSE["thresholds"] = gc.get_threshold()
            young, middle, _ = _GC_PAUSE["thresholds"]
            gc.set_threshold(young, middle, 10**6)
        _GC_PAUSE["count"] += 1
    try:
        yield
    finally:
        with _GC_LOCK:
            _GC_PAUSE["count"] -= 1
            if _GC_PAUSE["count"] == 0:
                gc.set_threshold(*_GC_PAUSE["thresholds"])


class Units:
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
            flags = _unit_flags(self.flags, text, "whole" if whole else kind)
            scalar = self.unit(function, "scalar").path.name if kind == "simd" and not whole else ""
            key = cbuild.digest(text, os.environ.get("CC", "cc"), " ".join(flags), self.host, scalar)[:20]
            name = f"{self.model}.whole" if whole else f"{self.model}_{function}.{kind}"
            path = self.folder() / f"{name}.{key}.so"
            self._units[function, kind] = _Unit(self.model, function, kind, text, flags, path)
        return self._units[function, kind]

    def prepare(self, wanted: list[tuple[str, str]]) -> None:
        """Build (in parallel) and load the units `wanted` and the scalar units their kernels call."""
        with self.lock, full_collections_paused():
            need = [(f, "scalar") for f, _ in wanted] + [(f, k) for f, k in wanted if k != "scalar"]
            need = [u for u in dict.fromkeys(need) if u not in self.loaded]  # in wanted's order, scalar first
            if isinstance(self.texts, dict) or len(need) < 2:
                units = [self.unit(*u) for u in need]
                _build_units(units)
            else:  # texts made when first read (a program each): make the next while the last compiles
                units: list[_Unit] = []
                futures: dict[tuple[str, str], concurrent.futures.Future] = {}
                bar = progress.Progress(f"symdyn: building {self.model}", len(need), after=progress.REPORT_AFTER_S)
                # one core stays with the programs while they are made (they are the critical path:
                # xArm7 6.2 s → 5.0 s on two cores), every core compiles once they are all made
                gate = threading.Semaphore(max(1, cbuild.jobs() - 1))

                def build(job: list[_Unit]) -> None:
                    with gate:
                        _build_units(job)

                with concurrent.futures.ThreadPoolExecutor(max_workers=cbuild.jobs()) as pool:
                    group: list[_Unit] = []  # small scalar units waiting to share a compiler run

                    def submit(job: list[_Unit]) -> None:
                        future = pool.submit(build, job)
                        for u in job:
                            futures[u.function, u.kind] = future

                    for u in need:
                        units.append(self.unit(*u))
                        if cbuild.intact(units[-1].path) or not _groupable(units[-1]):
                            submit([units[-1]])
                            continue
                        group.append(units[-1])
                        if sum(_own(g) for g in group) >= GROUP_BYTES:
                            submit(group)
                            group = []
                    if group:
                        submit(group)
                    if cbuild.jobs() > 1:
                        gate.release()
                    for f, kind in need:
                        futures[f, kind].result()
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
        if cbuild.intact(unit.path):
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
