"""Array-API target: one module per model for every library that follows the Python array API
standard (JAX, PyTorch, NumPy, CuPy), and its JAX and PyTorch loaders.

Stage "emit" of model → derive → simplify → program → emit.  Each program is
printed once as straight-line array code: the namespace `xp` comes from the
arguments (`array_api_compat.array_namespace` when installed, else the
arrays' own `__array_namespace__`), every operation is an `xp` function or an
operator, each entry broadcasts over the leading axes, and the outputs are
stacked at the end, never written in place — so `jax.jit`, `jax.vmap`,
`jax.grad`, `torch.compile`, `torch.func` and autograd can trace every
function, and float32 in gives float32 out on the arguments' device.  Coulomb
friction's sign is two comparisons; forward dynamics' LDLᵀ is the program's own
straight-line code: no Python `if` on a value anywhere.  Shapes are checked
(they are static under tracing); values are not (a traced function cannot
raise on them): NaN in gives NaN in every output entry that depends on it
(docs/functions.md).  `jax_functions` and `torch_functions` wrap the module's
functions for `symdyn.load(model, "jax" | "torch")`.
"""

from __future__ import annotations

import functools
import inspect

from ...derivation.program import Program, lower
from . import ATOM, Bundle, Infix, header_lines, seal

__all__ = ["module_source", "function_source", "jax_functions", "torch_functions", "SUFFIX"]

#: The generated file of model NAME is NAME + SUFFIX.
SUFFIX = "_xp.py"

#: Local names of the generated functions (a program's name must not hide them).
_LOCALS = {"xp", "like", "sign", "output", "arguments", "namespace", "broadcast"}

_HELPERS = '''

def namespace(function, names, values):
    """The array namespace of the arguments that are arrays, NumPy's counting only when no
    other library's is there (NumPy arrays, lists and numbers are then converted), or a
    ValueError naming arguments of different libraries."""
    try:
        import array_api_compat as compat
    except ImportError:
        compat = None
    arrays = [(a, v) for a, v in zip(names, values)
              if (compat.is_array_api_obj(v) if compat else hasattr(v, "__array_namespace__"))]
    arrays = [(a, v) for a, v in arrays if type(v).__module__ != "numpy"] or arrays
    if not arrays:
        import numpy
        arrays = [(names[0], numpy.asarray(0.0))]
    try:
        if compat is not None:
            return compat.array_namespace(*(v for _, v in arrays))
        spaces = {v.__array_namespace__() for _, v in arrays}
    except TypeError:
        spaces = None
    if spaces is None or len(spaces) != 1:
        given = ", ".join(f"{a} {type(v).__module__}.{type(v).__name__}" for a, v in arrays)
        raise ValueError(f"{function}(): the arguments are arrays of different libraries: {given}")
    return spaces.pop()


def arguments(function, inputs, values):
    """(xp, the arguments as arrays of one real floating dtype, each (..., size), and
    `like`: an array of the arguments' leading shape broadcast, dtype and device), or a
    ValueError naming the argument.  Shapes only: values are never read (tracing)."""
    names = [a for a, _ in inputs]
    xp = namespace(function, names, values)
    arrays = []
    for (a, size), x in zip(inputs, values):
        try:
            if not (hasattr(x, "shape") and hasattr(x, "dtype")) or type(x).__module__ == "numpy":
                x = xp.asarray(x)
            kind = ("complex" if xp.isdtype(x.dtype, "complex floating") else
                    "real" if xp.isdtype(x.dtype, ("real floating", "integral")) else None)
        except (TypeError, ValueError, RuntimeError):
            kind = None
        if kind == "complex":
            raise ValueError(f"{function}(): {a} is complex; the dynamics take real numbers")
        if kind is None:
            raise ValueError(f"{function}(): {a} must be real numbers, got {type(x).__name__} "
                             f"{getattr(x, 'dtype', '')}")
        if len(x.shape) == 0 or x.shape[-1] != size:
            raise ValueError(f"{function}(): {a} must have shape (..., {size}), got {tuple(x.shape)}")
        arrays.append(x)
    floats = [x.dtype for x in arrays if xp.isdtype(x.dtype, "real floating")]
    if floats:
        dtype = xp.result_type(*floats)
    else:
        try:
            dtype = xp.__array_namespace_info__().default_dtypes()["real floating"]
        except AttributeError:
            dtype = xp.float64
    arrays = [x if x.dtype == dtype else xp.astype(x, dtype) for x in arrays]
    shape = broadcast(function, names, [tuple(x.shape[:-1]) for x in arrays])
    return xp, arrays, xp.broadcast_to(arrays[0][..., 0], shape)


def broadcast(function, names, shapes):
    """The leading shapes broadcast together by NumPy's rules, or a ValueError naming them."""
    out = []
    for sizes in zip(*(((1,) * (max(map(len, shapes)) - len(s)) + s) for s in shapes)):
        wide = {k for k in sizes if k != 1}
        if len(wide) > 1:
            given = ", ".join(f"{a} {s}" for a, s in zip(names, shapes))
            raise ValueError(f"{function}(): the leading shapes of the arguments do not broadcast "
                             f"together: {given}")
        out.append(wide.pop() if wide else 1)
    return tuple(out)


def sign(xp, x):
    """sign x: 1, -1, 0 at +-0 and NaN at NaN (as NumPy's), by comparisons, never `xp.sign`
    (array-api-compat's for PyTorch writes NaNs in place: no vmap) nor an `if`; derivative 0."""
    return xp.astype(x > 0, x.dtype) - xp.astype(x < 0, x.dtype) + (x - x)


def output(xp, like, shape, entries):
    """One output of shape like.shape + shape from its entries in row-major order (arrays
    of leading shapes that broadcast to like's, or numbers), stacked: no in-place write.
    Stacked on a new first axis, then moved last (XLA on CPU: 1.9x faster than stacking
    on the last axis for the Puma's tau at 1e5 states, measured)."""
    entries = [xp.full_like(like, e) if isinstance(e, float) else
               e if e.shape == like.shape else xp.broadcast_to(e, like.shape) for e in entries]
    rows = xp.stack(entries, axis=0)
    return xp.reshape(xp.permute_dims(rows, tuple(range(1, rows.ndim)) + (0,)), tuple(like.shape) + shape)
'''


class _Printer(Infix):
    """Infix text on arrays of the namespace `xp`: its functions, `xp.pow` for powers, the
    module's traceable `sign`."""

    def __init__(self) -> None:
        super().__init__({f: f"xp.{f}" for f in ("sin", "cos", "tan", "sqrt", "abs")}, power="xp.pow")

    def call(self, name: str, x):
        return (f"sign(xp, {x[0]})", ATOM) if name == "sign" else super().call(name, x)


PRINTER = _Printer()


def _check_names(p: Program) -> None:
    taken = (
        {s.name for _, syms in p.inputs for s in syms} | {a for a, _ in p.inputs} | {s.name for s, _ in p.assignments}
    )
    clash = sorted(n for n in taken if n.startswith("_") or n in _LOCALS)
    if clash:
        raise ValueError(
            f"function {p.name!r}: names starting with '_' and {', '.join(sorted(_LOCALS))} are the "
            f"array-API emitter's, got {', '.join(clash)}"
        )


def function_source(p: Program) -> str:
    """The function of one program: arguments checked, columns read, one statement per
    assignment, the outputs stacked."""
    _check_names(p)
    args = [a for a, _ in p.inputs]
    used = p.used_inputs()
    inputs = repr(tuple((a, len(syms)) for a, syms in p.inputs))
    lines = [f"def {p.name}({', '.join(args)}):"] + ([f'    """{p.doc}"""'] if p.doc else [])
    group = f"({args[0]},)" if len(args) == 1 else f"({', '.join(args)})"
    lines.append(f"    xp, {group}, like = arguments({p.name!r}, {inputs}, {group})")
    lines += [f"    {s.name} = {a}[..., {k}]" for a, syms in p.inputs for k, s in enumerate(syms) if s in used]
    lines += [f"    {s.name} = {lower(e, PRINTER)[0]}" for s, e in p.assignments]
    outs = []
    for (_, mat), shape in zip(p.outputs, p.output_shapes()):
        entries = [lower(e, PRINTER)[0] for e in mat]
        outs.append(f"output(xp, like, {shape!r}, [\n" + "".join(f"        {e},\n" for e in entries) + "    ])")
    lines.append(
        f"    return {outs[0]}"
        if len(outs) == 1
        else "    return (\n" + "".join(f"    {o.replace(chr(10), chr(10) + '    ')},\n" for o in outs) + "    )"
    )
    return "\n".join(lines)


def module_source(bundle: Bundle) -> str:
    """The whole module text of one model: header, constants, helpers, functions."""
    head = "\n".join(header_lines(bundle, "array-api"))
    counts = {p.name: p.op_count() for p in bundle.programs}
    parts = [
        f'"""{head}\n\nEvery function takes its array namespace from its arguments (JAX, PyTorch, NumPy, CuPy\n'
        "arrays; PyTorch and NumPy < 2 through array-api-compat), broadcasts over their leading axes,\n"
        "keeps their dtype and device and never writes in place; values are not checked (NaN in, NaN\n"
        'out): see docs/functions.md.\n"""\n',
        f"MODEL = {bundle.name!r}",
        f"SYMDYN_VERSION = {bundle.version!r}",
        f"FINGERPRINT = {bundle.fingerprint!r}",
        f"N = {bundle.n}",
        *(
            [f"NQ = {bundle.nq}  # q: base coordinates, then the joints", f"NV = {bundle.nv}  # qd, qdd, tau"]
            if bundle.floating
            else []
        ),
        f"FUNCTIONS = {tuple(p.name for p in bundle.programs)!r}",
        f"OP_COUNTS = {counts!r}",
        _HELPERS,
    ]
    parts += ["\n\n" + function_source(p) for p in bundle.programs]
    return seal("\n".join(parts) + "\n")


# --------------------------------------------------------------------------- loaders


def _converting(fn, convert, inner, traced=lambda values: False):
    """`inner` called with fn's arguments bound by name (Python's own TypeErrors) and
    converted by `convert` (a ValueError naming the argument it cannot take); `fn` itself
    when `traced(values)` (inside a transformation, which compiles what it traces)."""
    signature = inspect.signature(fn)

    @functools.wraps(fn)
    def call(*args, **kwargs):
        bound = signature.bind(*args, **kwargs).arguments
        values = []
        for name, value in bound.items():
            try:
                values.append(convert(value))
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{fn.__name__}(): {name} must be real numbers: {exc}") from None
        return fn(*values) if traced(values) else inner(*values)

    return call


#: XLA options of the jitted functions on CPU: its instruction fusion duplicates the shared
#: intermediates of a large straight-line program into every consumer (measured, jax 0.10:
#: the Panda's fdyn_derivatives compiles in 7.4 min with it, 6 s without; at 1e4 states the
#: Panda's tau runs in 110 us per state with it, 1.0 us without, its fdyn 77 vs 1.5 us; the
#: Puma's tau alone is faster fused, 1.4x at 1e5 states).
CPU_COMPILER_OPTIONS = {"xla_disable_hlo_passes": "fusion"}


def jax_functions(module, jit: bool = True) -> dict:
    """name → function of the generated module on JAX arrays: arguments that are not
    JAX arrays (NumPy arrays, lists) go through `jax.numpy.asarray`; `jit`: each function
    `jax.jit`-compiled (once per shape and dtype of its arguments), on CPU without XLA's
    fusion (`CPU_COMPILER_OPTIONS`).  Called inside a transformation (`jax.jit`, `vmap`,
    `grad` of the caller's) a function is traced as it is: the outermost jit compiles it,
    with its own options."""
    import jax
    import jax.numpy as jnp

    def convert(x):
        return x if isinstance(x, jax.Array) else jnp.asarray(x)

    def traced(values):
        return any(isinstance(v, jax.core.Tracer) for v in values)

    options = CPU_COMPILER_OPTIONS if jax.default_backend() == "cpu" else None
    return {
        f: _converting(fn, convert, jax.jit(fn, compiler_options=options) if jit else fn, traced)
        for f, fn in ((f, getattr(module, f)) for f in module.FUNCTIONS)
    }


def torch_functions(module) -> dict:
    """name → function of the generated module on PyTorch tensors (through array-api-compat):
    arguments that are not tensors go through `torch.as_tensor`; the tensors' device and
    dtype are kept.  Wrap them in `torch.compile` for compiled kernels."""
    import array_api_compat  # noqa: F401  (a clear ImportError here rather than at the first call)
    import torch

    def convert(x):
        return x if isinstance(x, torch.Tensor) else torch.as_tensor(x)

    return {f: _converting(fn, convert, fn) for f, fn in ((f, getattr(module, f)) for f in module.FUNCTIONS)}
