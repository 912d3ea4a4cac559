"""Call a generated model's compiled C from Python: the binding of the C target.

The C target in three modules: `cbuild` builds C into shared libraries in symdyn's cache
(compiler, flags, sha256-verified libraries), `cunits` keeps one translation unit per function
and kind, built when a call first needs it (`load_library` binds them; `CLibrary.build` builds
them all ahead, in parallel), and this module binds them.  Two bindings: a small CPython
extension (per-call overhead well under a microsecond once a function is bound; needs Python.h;
its C is `runtime/glue.c`), compiled once for all models (it holds no model code: each
function's address is bound into its table on first use), and ctypes (no headers needed, a few µs
per call).  Both follow the contract of `symdyn.codegen.contract` (shapes, broadcasting, keyword
arguments, bad input) and return new arrays.
"""

from __future__ import annotations

import ctypes
import dataclasses
import importlib.machinery
import importlib.util
import os
import sys
import sysconfig
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...derivation import progress
from ...derivation.cache import cache_dir
from .. import contract
from . import cbuild
from .c import Signature, read_signatures
from .cunits import HEAVIEST_FIRST, KINDS, Units, function_units

__all__ = ["CompileOptions", "CLibrary", "load_library", "load_units"]


@dataclass(frozen=True)
class CompileOptions:
    """How to build: compiler flags and binding ("auto": the extension when
    Python.h is available, else ctypes; or "extension" / "ctypes")."""

    flags: tuple = cbuild.DEFAULT_FLAGS
    binding: str = "auto"

    def __post_init__(self) -> None:
        if self.binding not in ("auto", "extension", "ctypes"):
            raise ValueError(f"binding must be 'auto', 'extension' or 'ctypes', got {self.binding!r}")


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
    key = cbuild.digest(
        _glue_source("MODULE"), os.environ.get("CC", "cc"), " ".join(flags), sys.version, np.__version__
    )
    module = f"_symdyn_glue_{key[:16]}"
    if module in sys.modules:
        return sys.modules[module]
    path = cache_dir() / "c" / "glue" / f"{module}{sysconfig.get_config_var('EXT_SUFFIX')}"
    with progress.reported("symdyn: compiling the C binding (once for this Python)"):
        lib = cbuild.library(path, flags, {f"{module}.c": _glue_source(module)}, list(headers))
    ext = _import_extension(module, lib)
    ext._set_threads(cbuild.jobs())
    return ext


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
    headers = cbuild.python_headers() if options.binding != "ctypes" else None
    if options.binding == "extension" and headers is None:
        raise RuntimeError(
            f"Python.h not found in {sysconfig.get_paths()['include']}: install the "
            "Python development headers (Debian/Ubuntu: apt install python3-dev) "
            "or use binding='ctypes'"
        )
    units = Units(model, texts, options.flags, whole)
    try:
        cbuild.compiler()
    except RuntimeError:  # say so now, not at the first call, unless every unit is built
        if not isinstance(texts, dict) or not all(cbuild.intact(units.unit(*u).path) for u in texts):
            raise
    free = contract.free_base([(s.name, s.inputs) for s in sigs])  # q's quaternion checked
    if headers is None:
        functions = {s.name: _CtypesFunction(model, s, units, "q" if free else None) for s in sigs}
        return CLibrary(model, sigs, cache_dir() / "c" / "units", functions, "ctypes", units)
    ext = _glue(options.flags, headers)
    functions = {
        s.name: ext._function(
            s.name,
            _doc(s),
            tuple(s.inputs),
            tuple(shape for _, shape in s.outputs),
            units,
            [a for a, _ in s.inputs].index("q") if free and "q" in dict(s.inputs) else -1,
        )
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


def check_out(function: str, out, shapes: list, inputs=()) -> list:
    """The caller's out= as a list of arrays, one per output, each exactly a
    C-contiguous writeable float64 ndarray of its shape sharing no memory with the
    `inputs` ((name, array), …: a function stores a matrix's entries as it computes
    them, before it has read every input) or with another output.

    Raises:
        ValueError: out is not such an array (or tuple of them, one per output), or shares
            memory with an input (named) or with another output (both named by position).
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
        for name, x in inputs:
            if np.may_share_memory(a, x):
                raise ValueError(
                    f"{function}(): out{'[k]' if len(shapes) > 1 else ''} shares memory with the input "
                    f"{name}: give it an array of its own"
                )
    for j, a in enumerate(arrays[1:], 1):
        for k, b in enumerate(arrays[:j]):
            if np.may_share_memory(a, b):
                raise ValueError(f"{function}(): out[{k}] and out[{j}] share memory: give each an array of its own")
    return list(arrays)


class _CtypesFunction:
    """One generated function over ctypes: validates, allocates (or writes into
    out=), calls single or batched (the SIMD kernel on `threads` threads;
    ctypes releases the GIL); its compiled code is built and bound at the first
    call that needs it (`Units`)."""

    def __init__(self, model: str, sig: Signature, units: Units, quaternion: str | None = None) -> None:
        self.sig, self._units, self._quaternion = sig, units, quaternion
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
        arrays, lead = contract.arguments(
            self.sig.name, self.sig.inputs, args, kwargs, self._lead_max, self._quaternion
        )
        shapes = [lead + shape for _, shape in self.sig.outputs]
        named = [(a, x) for (a, _), x in zip(self.sig.inputs, arrays)]
        outs = [np.empty(s) for s in shapes] if out is None else check_out(self.sig.name, out, shapes, named)
        if threads is None:
            threads = cbuild.jobs()
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
    units: Units | None = dataclasses.field(default=None, repr=False, compare=False)

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
