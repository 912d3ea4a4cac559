"""NumPy target: one plain Python module per model, importing only numpy.

Every function is batched over leading axes: q of shape (n,) or (..., n)
gives outputs of shape (..., n) or (..., n, n); inputs broadcast against
each other.  The module carries its provenance (SYMDYN_VERSION, FINGERPRINT)
and op counts so a stale file is detected when loaded.
"""

from __future__ import annotations

from ..program import Program, lower
from . import Bundle, Infix, header_lines

__all__ = ["module_source", "output_shape"]

ALGEBRA = Infix({"sin": "np.sin", "cos": "np.cos", "tan": "np.tan", "sqrt": "np.sqrt",
                 "sign": "np.sign", "abs": "np.abs"}, power="np.power")

_HELPERS = '''

def _arg(x, size, name):
    """x as a float array of shape (..., size), or a ValueError naming it."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 0 or x.shape[-1] != size:
        raise ValueError(f"{name} must have shape (..., {size}), got {x.shape}")
    return x


def _split(x):
    """The columns of x (..., size): floats for one state, arrays for a batch."""
    return np.moveaxis(x, -1, 0)
'''


def output_shape(mat) -> tuple[int, ...]:
    """Shape of one output per state: (rows,) for a column vector, else (rows, cols)."""
    return (mat.rows,) if mat.cols == 1 else (mat.rows, mat.cols)


def _text(expr) -> str:
    return lower(expr, ALGEBRA)[0]


def function_source(p: Program) -> str:
    """One batched Python function printing the program `p`."""
    args = [a for a, _ in p.inputs]
    used = p.used_inputs()
    sig = ", ".join(args)
    lines = [f"def {p.name}({sig}):", f'    """{p.doc}"""' if p.doc else None]
    lines = [line for line in lines if line]
    lines.append(f"    {', '.join(args)} = " + ", ".join(f"_arg({a}, {len(s)}, {a!r})" for a, s in p.inputs))
    leading = ", ".join(f"{a}.shape[:-1]" for a in args)
    lines.append(f"    shape = np.broadcast_shapes({leading})" if len(args) > 1
                 else f"    shape = {args[0]}.shape[:-1]")
    for a, syms in p.inputs:
        if any(s in used for s in syms):
            names = ", ".join(s.name if s in used else "_" for s in syms)
            lines.append(f"    {names}{',' if len(syms) == 1 else ''} = _split({a})")
    lines += [f"    {s.name} = {_text(e)}" for s, e in p.assignments]
    for name, mat in p.outputs:
        shape = output_shape(mat)
        lines.append(f"    {name} = np.empty(shape + {shape!r})")
        for k, expr in enumerate(mat):
            index = (k,) if mat.cols == 1 else divmod(k, mat.cols)
            lines.append(f"    {name}[..., {', '.join(map(str, index))}] = {_text(expr)}")
    returns = ", ".join(name for name, _ in p.outputs)
    lines.append(f"    return {returns}")
    return "\n".join(lines)


def module_source(bundle: Bundle) -> str:
    """The whole module text of one model: header, constants, helpers, functions."""
    head = "\n".join(header_lines(bundle, "numpy"))
    counts = {p.name: p.op_count() for p in bundle.programs}
    parts = [
        f'"""{head}\n"""\n',
        "import numpy as np\n",
        f"MODEL = {bundle.name!r}",
        f"SYMDYN_VERSION = {bundle.version!r}",
        f"FINGERPRINT = {bundle.fingerprint!r}",
        f"N = {bundle.n}",
        f"FUNCTIONS = {tuple(p.name for p in bundle.programs)!r}",
        f"OP_COUNTS = {counts!r}",
        _HELPERS,
    ]
    parts += ["\n\n" + function_source(p) for p in bundle.programs]
    return "\n".join(parts) + "\n"
