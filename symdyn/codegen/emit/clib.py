"""Compile a generated .c/.h into a shared library and call it from Python.

The library is built with the system C compiler (`$CC`, else `cc`) into
symdyn's cache folder (`symdyn.derivation.cache.cache_dir()`, outside the repository),
under a name derived from the hash of everything that affects it (source,
header, compiler, flags, Python and NumPy ABI): a changed source is
rebuilt, an unchanged one is reused once its sha256, recorded beside it when
it was built, is verified (a truncated library would crash Python when
loaded).  A cache that cannot be written means a temporary folder.  Two
bindings: a small CPython extension (per-call overhead well under a
microsecond; needs Python.h) and ctypes (no headers needed, a few µs per
call).  Both follow the contract of `symdyn.codegen.contract` (shapes,
broadcasting, keyword arguments, bad input) and return new arrays.
"""

from __future__ import annotations

import ctypes
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
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...derivation.cache import build_lock, cache_dir, writable
from .. import contract
from . import write_atomic
from .c import Signature, read_signatures

__all__ = ["CompileOptions", "CLibrary", "load_library", "compiler"]

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
    """Path of the C compiler ($CC or cc), or a RuntimeError saying what to install."""
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

_GLUE_HEAD = r"""#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>
#include <limits.h>
#include <math.h>
#include <string.h>
#include "%(model)s.h"

#define MAXARGS 8
typedef void (*one_fn)(const double *const *in, double *const *out);
typedef int (*many_fn)(int n, int threads, const double *const *in, double *const *out);

/* threads= when the call gives none: set by symdyn (the cores this process may use). */
static int default_threads = 1;
#define MAXTHREADS 256
typedef struct {
    const char *name;
    const char *const *in_names;
    int nin, nout;
    const npy_intp *in_size;
    const int *out_nd;
    const npy_intp (*out_dims)[2];
    one_fn one;
    many_fn many;
} spec_t;

/* Whether the call is the common one: positional C-contiguous double arrays
   (..., size) of one leading shape with room for the outputs' dimensions, finite
   when they hold one state (a batch's kernel tests its inputs as it gathers them). */
static int plain(const spec_t *s, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames, int out_nd)
{
    int i, nd = 0;
    if (nargs != s->nin || (kwnames && PyTuple_GET_SIZE(kwnames)))
        return 0;
    for (i = 0; i < s->nin; ++i) {
        PyArrayObject *a = (PyArrayObject *)args[i];
        npy_intp size, k;
        const double *x;
        if (!PyArray_CheckExact(args[i]) || PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISCARRAY_RO(a))
            return 0;
        if (i == 0) {
            nd = PyArray_NDIM(a);
            if (nd == 0 || nd - 1 + out_nd > NPY_MAXDIMS)
                return 0;
        } else if (PyArray_NDIM(a) != nd
                   || memcmp(PyArray_DIMS(a), PyArray_DIMS((PyArrayObject *)args[0]), (nd - 1) * sizeof(npy_intp)))
            return 0;
        if (PyArray_DIMS(a)[nd - 1] != s->in_size[i])
            return 0;
        if (nd > 1)
            continue;
        size = PyArray_SIZE(a);
        x = (const double *)PyArray_DATA(a);
        for (k = 0; k < size; ++k)
            if (!isfinite(x[k]))
                return 0;
    }
    return 1;
}

/* Any other call goes through symdyn.codegen.contract.arguments, the contract
   every target shares: (checked arrays of one leading shape, that shape), or an error. */
static PyObject *checked(const spec_t *s, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames, int out_nd)
{
    static PyObject *arguments = NULL;
    PyObject *inputs = NULL, *pos = NULL, *kw = NULL, *result = NULL;
    Py_ssize_t i, nkw = kwnames ? PyTuple_GET_SIZE(kwnames) : 0;
    if (!arguments) {
        PyObject *module = PyImport_ImportModule("symdyn.codegen.contract");
        if (!module)
            return NULL;
        arguments = PyObject_GetAttrString(module, "arguments");
        Py_DECREF(module);
        if (!arguments)
            return NULL;
    }
    inputs = PyTuple_New(s->nin);
    pos = PyTuple_New(nargs);
    kw = PyDict_New();
    if (!inputs || !pos || !kw)
        goto done;
    for (i = 0; i < s->nin; ++i) {
        PyObject *pair = Py_BuildValue("(sn)", s->in_names[i], (Py_ssize_t)s->in_size[i]);
        if (!pair)
            goto done;
        PyTuple_SET_ITEM(inputs, i, pair);
    }
    for (i = 0; i < nargs; ++i) {
        Py_INCREF(args[i]);
        PyTuple_SET_ITEM(pos, i, args[i]);
    }
    for (i = 0; i < nkw; ++i)
        if (PyDict_SetItem(kw, PyTuple_GET_ITEM(kwnames, i), args[nargs + i]) < 0)
            goto done;
    result = PyObject_CallFunction(arguments, "sOOOi", s->name, inputs, pos, kw, NPY_MAXDIMS - out_nd);
done:
    Py_XDECREF(inputs);
    Py_XDECREF(pos);
    Py_XDECREF(kw);
    return result;
}

/* The keywords out= and threads= taken out of a call: the other keywords' names
   in *kw (a new tuple, or NULL when none is left), the arguments' values in vals
   (positional, then those keywords'); 0, or -1 with an exception set. */
static int extras(const char *name, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames,
                  PyObject **vals, PyObject **kw, PyObject **outarg, int *threads)
{
    Py_ssize_t i, nkw = kwnames ? PyTuple_GET_SIZE(kwnames) : 0, kept = 0;
    *kw = NULL;
    *outarg = NULL;
    *threads = default_threads;
    if (nargs + nkw > 2 * MAXARGS) {
        PyErr_Format(PyExc_TypeError, "%%s(): too many arguments", name);
        return -1;
    }
    for (i = 0; i < nargs; ++i)
        vals[i] = args[i];
    for (i = 0; i < nkw; ++i) {
        PyObject *key = PyTuple_GET_ITEM(kwnames, i), *v = args[nargs + i];
        if (PyUnicode_CompareWithASCIIString(key, "out") == 0) {
            *outarg = v == Py_None ? NULL : v;
        } else if (PyUnicode_CompareWithASCIIString(key, "threads") == 0) {
            long t;
            if (v == Py_None)
                continue;
            t = PyLong_AsLong(v);
            if (t == -1 && PyErr_Occurred())
                return -1;
            if (t < 1) {
                PyErr_Format(PyExc_ValueError, "%%s(): threads must be at least 1, got %%ld", name, t);
                return -1;
            }
            *threads = t > MAXTHREADS ? MAXTHREADS : (int)t;
        } else {
            vals[nargs + kept++] = v;
        }
    }
    if (kept == 0)
        return 0;
    *kw = PyTuple_New(kept);
    if (!*kw)
        return -1;
    for (i = 0, kept = 0; i < nkw; ++i) {
        PyObject *key = PyTuple_GET_ITEM(kwnames, i);
        if (PyUnicode_CompareWithASCIIString(key, "out") && PyUnicode_CompareWithASCIIString(key, "threads")) {
            Py_INCREF(key);
            PyTuple_SET_ITEM(*kw, kept++, key);
        }
    }
    return 0;
}

/* The caller's array for output j (new reference), or NULL with a ValueError:
   exactly an ndarray, float64, C-contiguous, aligned and writeable, of the output's shape. */
static PyObject *given_out(const spec_t *s, PyObject *outarg, int j, int nd, const npy_intp *dims)
{
    PyObject *o = outarg;
    PyArrayObject *a;
    if (s->nout > 1) {
        if (!PyTuple_Check(outarg) || PyTuple_GET_SIZE(outarg) != s->nout) {
            PyErr_Format(PyExc_ValueError, "%%s(): out must be a tuple of %%d arrays, one per output", s->name, s->nout);
            return NULL;
        }
        o = PyTuple_GET_ITEM(outarg, j);
    }
    a = (PyArrayObject *)o;
    if (!PyArray_Check(o) || PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISCARRAY(a) || PyArray_NDIM(a) != nd
        || memcmp(PyArray_DIMS(a), dims, nd * sizeof(npy_intp))) {
        PyErr_Format(PyExc_ValueError, "%%s(): out%%s must be a C-contiguous writeable float64 array of the "
                     "output's shape (leading dimensions of the inputs, then the output's own)",
                     s->name, s->nout > 1 ? "[k]" : "");
        return NULL;
    }
    Py_INCREF(o);
    return o;
}

/* One output array per output, shaped leading + its own shape (or the caller's out=);
   single or batched call (threads= threads, default: the cores this process may use). */
static PyObject *call(const spec_t *s, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames)
{
    PyObject *out[MAXARGS] = {0};
    PyObject *normal = NULL, *result = NULL, *vals[2 * MAXARGS], *kw = NULL, *outarg = NULL;
    const double *pin[MAXARGS];
    double *pout[MAXARGS];
    npy_intp dims[NPY_MAXDIMS], count = 1;
    int lead_nd, out_nd = 0, i, j, threads;
    for (j = 0; j < s->nout; ++j)   /* an output has lead_nd + out_nd dimensions: they must fit dims */
        out_nd = s->out_nd[j] > out_nd ? s->out_nd[j] : out_nd;
    if (kwnames && PyTuple_GET_SIZE(kwnames)) {
        if (extras(s->name, args, nargs, kwnames, vals, &kw, &outarg, &threads) < 0)
            return NULL;
        args = vals;
        kwnames = kw;
    } else {
        threads = default_threads;
    }
    if (!plain(s, args, nargs, kwnames, out_nd)) {
        normal = checked(s, args, nargs, kwnames, out_nd);
        Py_CLEAR(kw);
        if (!normal)
            return NULL;
        args = &PyTuple_GET_ITEM(PyTuple_GET_ITEM(normal, 0), 0);
    }
    lead_nd = PyArray_NDIM((PyArrayObject *)args[0]) - 1;
    memcpy(dims, PyArray_DIMS((PyArrayObject *)args[0]), lead_nd * sizeof(npy_intp));
    for (i = 0; i < lead_nd; ++i)
        count *= dims[i];
    for (i = 0; i < s->nin; ++i)
        pin[i] = (const double *)PyArray_DATA((PyArrayObject *)args[i]);
    if (count > INT_MAX) {
        PyErr_Format(PyExc_ValueError, "%%s(): %%zd states, at most %%d per call", s->name, (Py_ssize_t)count, INT_MAX);
        goto done;
    }
    for (j = 0; j < s->nout; ++j) {
        memcpy(dims + lead_nd, s->out_dims[j], s->out_nd[j] * sizeof(npy_intp));
        out[j] = outarg ? given_out(s, outarg, j, lead_nd + s->out_nd[j], dims)
                        : PyArray_SimpleNew(lead_nd + s->out_nd[j], dims, NPY_DOUBLE);
        if (!out[j])
            goto done;
        pout[j] = (double *)PyArray_DATA((PyArrayObject *)out[j]);
    }
    if (lead_nd == 0) {
        s->one(pin, pout);
    } else if (count > 0) {
        int nonfinite;
        Py_BEGIN_ALLOW_THREADS
        nonfinite = s->many((int)count, threads, pin, pout);
        Py_END_ALLOW_THREADS
        if (nonfinite) {   /* the contract's check names the argument (a checked call is finite) */
            PyObject *why = normal ? NULL : checked(s, args, nargs, kwnames, out_nd);
            if (!PyErr_Occurred())
                PyErr_Format(PyExc_ValueError, "%%s(): an input contains NaN or infinity", s->name);
            Py_XDECREF(why);
            goto done;
        }
    }
    if (s->nout == 1) {
        result = out[0];
        out[0] = NULL;
    } else {
        result = PyTuple_New(s->nout);
        for (j = 0; result && j < s->nout; ++j) {
            PyTuple_SET_ITEM(result, j, out[j]);
            out[j] = NULL;
        }
    }
done:
    for (j = 0; j < MAXARGS; ++j)
        Py_XDECREF(out[j]);
    Py_XDECREF(normal);
    Py_XDECREF(kw);
    return result;
}

static PyObject *py_set_threads(PyObject *self, PyObject *arg)
{
    long t = PyLong_AsLong(arg);
    (void)self;
    if (t == -1 && PyErr_Occurred())
        return NULL;
    default_threads = t < 1 ? 1 : t > MAXTHREADS ? MAXTHREADS : (int)t;
    Py_RETURN_NONE;
}
"""


def _glue_source(model: str, module: str, sigs: list[Signature]) -> str:
    """CPython extension wrapping every function of the model's header."""
    parts = [_GLUE_HEAD % {"model": model}]
    methods = []
    for sig in sigs:
        f, nin, nout = sig.name, len(sig.inputs), len(sig.outputs)
        ins = ", ".join(f"in[{i}]" for i in range(nin))
        outs = ", ".join(f"out[{j}]" for j in range(nout))
        dims = ", ".join("{" + ", ".join(map(str, (list(s) + [0])[:2])) + "}" for _, s in sig.outputs)
        names = ", ".join(f'"{a}"' for a, _ in sig.inputs)
        parts.append(
            f"static void {f}_one(const double *const *in, double *const *out) "
            f"{{ {model}_{f}({ins}, {outs}); }}\n"
            f"static int {f}_many(int n, int threads, const double *const *in, double *const *out) "
            f"{{ return {model}_{f}_simd(n, threads, {ins}, {outs}); }}\n"
            f"static const char *const {f}_names[] = {{{names}}};\n"
            f"static const npy_intp {f}_in[] = {{{', '.join(str(k) for _, k in sig.inputs)}}};\n"
            f"static const int {f}_out_nd[] = {{{', '.join(str(len(s)) for _, s in sig.outputs)}}};\n"
            f"static const npy_intp {f}_out_dims[][2] = {{{dims}}};\n"
            f'static const spec_t {f}_spec = {{"{f}", {f}_names, {nin}, {nout}, {f}_in, {f}_out_nd, '
            f"{f}_out_dims, {f}_one, {f}_many}};\n"
            f"static PyObject *py_{f}(PyObject *self, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames) "
            f"{{ return call(&{f}_spec, args, nargs, kwnames); }}\n"
        )
        doc = (
            f"{f}($module, {', '.join(a for a, _ in sig.inputs)}, *, out=None, threads=None)\\n--\\n\\n"
            f"{sig.line()[len('function: ') :]}; batched over leading axes (SIMD across states, "
            f"on `threads` threads), into out= if given"
        )
        methods.append(f'    {{"{f}", (PyCFunction)(void (*)(void))py_{f}, METH_FASTCALL | METH_KEYWORDS, "{doc}"}},')
    methods.append('    {"_set_threads", py_set_threads, METH_O, "default number of threads of a batched call"},')
    parts.append("static PyMethodDef methods[] = {\n" + "\n".join(methods) + "\n    {NULL, NULL, 0, NULL}\n};\n")
    parts.append(
        f'static struct PyModuleDef moduledef = {{PyModuleDef_HEAD_INIT, "{module}", NULL, -1, methods}};\n'
        f"PyMODINIT_FUNC PyInit_{module}(void)\n{{\n    import_array();\n"
        f"    return PyModule_Create(&moduledef);\n}}\n"
    )
    return "\n".join(parts)


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


#: A function definition at column 0 of a generated C file: `void f(`, `int f(`, static or not.
_DEFINITION = re.compile(r"(static )?(void|int) \w+\(")


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

    def intact() -> bool:
        try:
            return _recorded(path).read_text() == _sha256(path)
        except OSError:
            return False

    if intact():
        return path
    with build_lock(path):
        return path if intact() else _build(flags, files, includes, path)


def load_library(c_path: Path, h_path: Path, options: CompileOptions = CompileOptions()) -> "CLibrary":
    """Compile (or reuse from the cache) the model in c_path/h_path and bind it."""
    c_path, h_path = Path(c_path), Path(h_path)
    model = h_path.stem
    c_text, h_text = c_path.read_text(), h_path.read_text()
    sigs = read_signatures(h_text)
    if not sigs:
        raise ValueError(f"{h_path} lists no 'function:' signatures: not a symdyn header")
    headers = _python_headers() if options.binding != "ctypes" else None
    if options.binding == "extension" and headers is None:
        raise RuntimeError(
            f"Python.h not found in {sysconfig.get_paths()['include']}: install the "
            "Python development headers (Debian/Ubuntu: apt install python3-dev) "
            "or use binding='ctypes'"
        )
    kind = "extension" if headers else "ctypes"
    host = platform.node() if "-march=native" in options.flags else ""
    glue = _glue_source(model, "_symdyn_MODULE", sigs) if kind == "extension" else ""  # a new binding rebuilds
    key = _digest(
        c_text,
        h_text,
        glue,
        os.environ.get("CC", "cc"),
        " ".join(options.flags),
        kind,
        host,
        sys.version,
        np.__version__,
    )[:16]
    folder = cache_dir() / "c" / f"{model}-{key}"
    files = {c_path.name: c_text, h_path.name: h_text}
    if kind == "ctypes":
        lib = _library(folder / f"lib{model}.so", options.flags, files, [])
        return CLibrary(model, sigs, lib, _ctypes_functions(model, sigs, lib), kind)
    module = f"_symdyn_{model}_{key}"
    files[f"{module}.c"] = _glue_source(model, module, sigs)
    lib = _library(folder / f"{module}{sysconfig.get_config_var('EXT_SUFFIX')}", options.flags, files, list(headers))
    ext = _import_extension(module, lib)
    ext._set_threads(_jobs())
    return CLibrary(model, sigs, lib, {s.name: getattr(ext, s.name) for s in sigs}, kind)


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
    C-contiguous writeable float64 ndarray of its shape; else a ValueError."""
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
    ctypes releases the GIL)."""

    def __init__(self, lib: ctypes.CDLL, model: str, sig: Signature) -> None:
        self.sig = sig
        nargs = len(sig.inputs) + len(sig.outputs)
        self._one = getattr(lib, f"{model}_{sig.name}")
        self._one.argtypes, self._one.restype = [ctypes.c_void_p] * nargs, None
        self._many = getattr(lib, f"{model}_{sig.name}_simd")
        self._many.argtypes, self._many.restype = [ctypes.c_int, ctypes.c_int] + [ctypes.c_void_p] * nargs, ctypes.c_int
        self.__name__ = sig.name
        self.__doc__ = f"{sig.line()[len('function: ') :]}; batched over leading axes"
        self._lead_max = contract.MAXDIMS - max(len(shape) for _, shape in sig.outputs)

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
            self._many(count, min(int(threads), 256), *pointers)
        else:
            self._one(*pointers)
        return outs[0] if len(outs) == 1 else tuple(outs)


def _ctypes_functions(model: str, sigs: list[Signature], lib_path: Path) -> dict:
    lib = ctypes.CDLL(str(lib_path))
    return {s.name: _CtypesFunction(lib, model, s) for s in sigs}


@dataclass(frozen=True)
class CLibrary:
    """A compiled model: its signatures, the library file and the callables."""

    model: str
    signatures: list
    path: Path
    functions: dict
    binding: str
