"""NumPy target: one plain Python module per model, importing only numpy and math.

Stage "emit" of model → derive → simplify → program → emit.  Every function
is batched over leading axes: q of shape (n,) or (..., n) gives outputs of
shape (..., n) or (..., n, n); inputs broadcast against each other.  Each
program is printed twice, doing the same operations in the same order: a
scalar body on Python floats (math.sin, float arithmetic) for one state,
some 10x faster than NumPy scalars, and a batched body on contiguous rows of
states in which every operation writes into a preallocated work row that is
reused once its value is dead (a fresh temporary per operation costs page
faults, not arithmetic).  The module carries its provenance (SYMDYN_VERSION,
FINGERPRINT) and op counts so a stale file is detected when loaded.
"""

from __future__ import annotations

from ..program import Program, lower
from . import ATOM, Bundle, Infix, header_lines

__all__ = ["module_source", "output_shape", "CHUNK"]

#: States per pass of the batched body (measured: per-call overhead of ~1 us per
#: operation favours long rows; longer ones fall out of the caches).
CHUNK = 16384

#: NumPy ufunc of each primitive of `symdyn.program.lower`.
UFUNCS = {"neg": "negative", "add": "add", "sub": "subtract", "mul": "multiply", "div": "divide",
          "sin": "sin", "cos": "cos", "tan": "tan", "sqrt": "sqrt", "sign": "sign", "abs": "absolute",
          "pow": "power"}

_HELPERS = '''

def _arg(x, size, name):
    """x as a float array of shape (..., size), or a ValueError naming it."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 0 or x.shape[-1] != size:
        raise ValueError(f"{name} must have shape (..., {size}), got {x.shape}")
    return x


def _rows(x, shape):
    """x (..., size) broadcast to shape + (size,), as contiguous rows (size, states)."""
    x = np.broadcast_to(x, shape + x.shape[-1:]).reshape(-1, x.shape[-1])
    return np.ascontiguousarray(x.T)


def _chunk(states, size):
    """Length of the equal chunks, each at most `size`, that cover `states`."""
    count = max(1, -(-states // size))
    return max(1, -(-states // count))


# sin and cos at the angles k/256, |k| <= 2048: exact doubles, so the
# remainder of an angle from its nearest table angle is exact (see _sincos).
_TABLE = np.arange(-2048, 2049) / 256.0
_SIN, _COS = np.sin(_TABLE), np.cos(_TABLE)
_ROUND = 6755399441055744.0  # 1.5 * 2**52: x + _ROUND rounds x to an integer held in the low bits
_ROUND_BITS = int(np.array(_ROUND).view(np.int64))


def _sincos(x, work):
    """sin x, cos x of angles x (k, m) into rows :k and k:2k of work (6k, m), rows
    2k: scratch.  x = t + d with t = round(256 x)/256 a table angle, |d| <= 1/512
    exact; sin x = sin t + (cos t sin d - sin t (1 - cos d)), cos x = cos t -
    (sin t sin d + cos t (1 - cos d)), sin d and 1 - cos d by Taylor series to d^5
    (error ~1e-16 absolute; 3-4x faster than np.sin and np.cos).  Angles beyond
    +-8 rad, inf or nan: np.sin and np.cos."""
    s, c, t, d, z, e = work[:6 * len(x)].reshape(6, len(x), -1)
    if not (-8.0 <= x.min() and x.max() <= 8.0):
        return np.sin(x, s), np.cos(x, c)
    np.multiply(x, 256.0, t)
    np.add(t, _ROUND, t)
    index = np.subtract(t.view(np.int64), _ROUND_BITS - 2048, z.view(np.int64))
    np.subtract(t, _ROUND, t)
    np.multiply(t, 1.0 / 256.0, d)
    np.subtract(x, d, d)
    np.take(_SIN, index, out=s, mode="clip")
    np.take(_COS, index, out=c, mode="clip")
    np.multiply(d, d, z)
    np.multiply(z, 1.0 / 120.0, e)
    np.subtract(e, 1.0 / 6.0, e)
    np.multiply(e, z, e)
    np.multiply(e, d, e)
    np.add(e, d, e)
    np.multiply(z, 1.0 / 24.0, t)
    np.subtract(0.5, t, t)
    np.multiply(t, z, t)
    np.multiply(c, e, z)
    np.multiply(s, t, d)
    np.subtract(z, d, z)
    np.multiply(s, e, e)
    np.multiply(c, t, t)
    np.add(e, t, e)
    np.add(s, z, s)
    np.subtract(c, e, c)
    return s, c
'''


class _Scalar(Infix):
    """Infix text on Python floats: math functions, sign inline (0 at ±0, NaN
    stays NaN, as np.sign: x - x is +0.0 for ±0 and NaN for NaN)."""

    def __init__(self) -> None:
        super().__init__({"sin": "math.sin", "cos": "math.cos", "tan": "math.tan", "sqrt": "math.sqrt",
                          "abs": "abs"}, power="math.pow")

    def call(self, name: str, x):
        if name != "sign":
            return super().call(name, x)
        v = x[0] if x[1] == ATOM else f"(_v := {x[0]})"
        first = x[0] if x[1] == ATOM else "_v"
        return (f"(1.0 if {v} > 0.0 else -1.0 if {first} < 0.0 else {first} - {first})", ATOM)


SCALAR = _Scalar()


class _Tape:
    """Algebra recording each primitive as one ufunc call: values are op
    indices (int), input columns (str) or constants (float).  sin and cos of
    an input column are recorded once each, in `trig`: the batched body
    computes them up front, all columns of an argument in one `_sincos`."""

    def __init__(self) -> None:
        self.ops: list[tuple[str, tuple]] = []
        self.env: dict[str, int | str | float] = {}
        self.trig: dict[tuple[str, str], int] = {}

    def _op(self, fn: str, *args) -> int:
        self.ops.append((UFUNCS[fn], args))
        return len(self.ops) - 1

    def number(self, value: float):
        return float(value)

    def symbol(self, name: str):
        return self.env.get(name, name)

    def neg(self, x):
        return self._op("neg", x)

    def add(self, x, y):
        return self._op("add", x, y)

    def sub(self, x, y):
        return self._op("sub", x, y)

    def mul(self, x, y):
        return self._op("mul", x, y)

    def div(self, x, y):
        return self._op("div", x, y)

    def call(self, name: str, x):
        if name in ("sin", "cos") and isinstance(x, str):
            if (name, x) not in self.trig:
                self.trig[name, x] = self._op(name, x)
            return self.trig[name, x]
        return self._op(name, x)

    def pow(self, x, exponent: float):
        return self._op("pow", x, float(exponent))


def output_shape(mat) -> tuple[int, ...]:
    """Shape of one output per state: (rows,) for a column vector, else (rows, cols)."""
    return (mat.rows,) if mat.cols == 1 else (mat.rows, mat.cols)


def _used_names(p: Program, args: list[str]) -> list[tuple[str, str]]:
    """(argument, unpacking target) of each input the program reads: 'q1, _, q3'."""
    used = p.used_inputs()
    out = []
    for a, syms in p.inputs:
        if any(s in used for s in syms):
            names = ", ".join(s.name if s in used else "_" for s in syms)
            out.append((a, names + ("," if len(syms) == 1 else "")))
    return out


def scalar_source(p: Program) -> str:
    """The one-state body `_<name>_one` on Python floats (arguments as lists)."""
    args = [a for a, _ in p.inputs]
    lines = [f"def _{p.name}_one({', '.join(args)}):",
             f'    """{p.name} of one state on Python floats (arguments: lists)."""']
    lines += [f"    {names} = {a}" for a, names in _used_names(p, args)]
    lines += [f"    {s.name} = {lower(e, SCALAR)[0]}" for s, e in p.assignments]
    values = []
    for _, mat in p.outputs:
        items = [lower(e, SCALAR)[0] for e in mat]
        if mat.cols == 1:
            values.append("np.array([" + ", ".join(items) + "])")
        else:
            rows = (items[r * mat.cols:(r + 1) * mat.cols] for r in range(mat.rows))
            values.append("np.array([" + ", ".join("[" + ", ".join(r) + "]" for r in rows) + "])")
    lines.append("    return " + ", ".join(values))
    return "\n".join(lines)


def _tape(p: Program) -> tuple[_Tape, dict, dict, list]:
    """Record the program: (tape, name of each named op, output row of each op
    that writes one directly, output writes).  Writes are (output, row, value),
    value None when the expression's last op writes the row itself."""
    tape = _Tape()
    names = {}
    for s, e in p.assignments:
        v = lower(e, tape)
        tape.env[s.name] = v
        if isinstance(v, int) and v not in names:
            names[v] = s.name
    writes, direct = [], {}
    for j, (_, mat) in enumerate(p.outputs):
        for k, e in enumerate(mat):
            start = len(tape.ops)
            v = lower(e, tape)
            if isinstance(v, int) and v >= start and v not in tape.trig.values():
                direct[v] = (j, k)
                writes.append((j, k, None))
            else:
                writes.append((j, k, v))
    return tape, names, direct, writes


def _trig_blocks(p: Program, trig: dict) -> list[tuple[str, list[int], int]]:
    """(argument, its columns, first work row) of each argument whose columns
    have sin or cos: rows first..first+k hold their sines, then k cosines."""
    blocks, first = [], 0
    for a, syms in p.inputs:
        cols = [i for i, s in enumerate(syms) if ("sin", s.name) in trig or ("cos", s.name) in trig]
        if cols:
            blocks.append((a, cols, first))
            first += 2 * len(cols)
    return blocks


def _allocate(tape: _Tape, direct: dict, writes: list, fixed: dict) -> tuple[dict, int]:
    """Work row of every op not writing an output (`fixed`: rows given up
    front): linear scan, a row is reused as soon as its value is dead, and an
    op may write over its dying operand.  Returns (rows, rows used)."""
    ops = tape.ops
    last = {}
    for i, (_, args) in enumerate(ops):
        for a in args:
            if isinstance(a, int):
                last[a] = i
    for _, _, v in writes:
        if isinstance(v, int):
            last[v] = len(ops)
    row = dict(fixed)
    free = [r for i, r in fixed.items() if i not in last]
    count = max(fixed.values(), default=-1) + 1
    for i, (_, args) in enumerate(ops):
        if i in fixed:
            continue
        dying = [row[a] for a in dict.fromkeys(args) if isinstance(a, int) and last[a] == i]
        free.extend(reversed(dying))
        if i in direct:
            continue
        if free:
            row[i] = free.pop()
        else:
            row[i], count = count, count + 1
        if i not in last:
            free.append(row[i])
    return row, count


def _columns(cols: list[int]) -> str:
    """Index of rows `cols`: a slice when consecutive."""
    if cols == list(range(cols[0], cols[-1] + 1)):
        return f"{cols[0]}:{cols[-1] + 1}"
    return repr(cols)


def batched_source(p: Program, chunk: int = CHUNK) -> str:
    """The public function: argument checks, the scalar body for one state,
    else the batched body, `chunk` states at a time."""
    args = [a for a, _ in p.inputs]
    taken = {s.name for _, syms in p.inputs for s in syms} | set(args) | {s.name for s, _ in p.assignments}
    clash = sorted(n for n in taken if n.startswith("_"))
    if clash:
        raise ValueError(f"function {p.name!r}: names starting with '_' are the emitter's, got {', '.join(clash)}")
    tape, names, direct, writes = _tape(p)
    blocks = _trig_blocks(p, tape.trig)
    syms = dict(p.inputs)
    fixed = {}
    for a, cols, first in blocks:
        for k, col in enumerate(cols):
            for fn, offset in (("sin", 0), ("cos", len(cols))):
                i = tape.trig.get((fn, syms[a][col].name))
                if i is not None:
                    fixed[i] = first + offset + k
    row, count = _allocate(tape, direct, writes, fixed)
    nrows = max([count] + [first + 6 * len(cols) for _, cols, first in blocks])
    outs = [(name, output_shape(mat), len(mat)) for name, mat in p.outputs]
    used = {v for _, op_args in tape.ops for v in op_args if isinstance(v, int)}
    used |= {v for _, _, v in writes if isinstance(v, int)}

    def text(v) -> str:
        if isinstance(v, float):
            return repr(v)
        if isinstance(v, str):
            return v
        return names.get(v, f"_w{row.get(v)}")

    lines = [f"def {p.name}({', '.join(args)}):"]
    if p.doc:
        lines.append(f'    """{p.doc}"""')
    lines.append(f"    {', '.join(args)} = " + ", ".join(f"_arg({a}, {len(s)}, {a!r})" for a, s in p.inputs))
    lines += [f"    if {' == '.join(f'{a}.ndim' for a in args)} == 1:",
              "        try:",
              f"            return _{p.name}_one({', '.join(f'{a}.tolist()' for a in args)})",
              "        except (ArithmeticError, ValueError):",
              "            pass  # a zero division or math domain error: inf/nan as NumPy gives below"]
    leading = ", ".join(f"{a}.shape[:-1]" for a in args)
    lines.append(f"    shape = np.broadcast_shapes({leading})" if len(args) > 1
                 else f"    shape = {args[0]}.shape[:-1]")
    lines.append(f"    {', '.join(args)} = " + ", ".join(f"_rows({a}, shape)" for a in args))
    lines.append(f"    _states = {args[0]}.shape[1]")
    lines.append(f"    _step = _chunk(_states, {chunk})")
    lines += [f"    {name} = np.empty(({size}, _states))" for name, _, size in outs]
    if nrows:
        lines.append(f"    _work = np.empty(({nrows}, _step))")
    lines.append("    for _lo in range(0, _states, _step):")
    lines.append("        _hi = min(_lo + _step, _states)")
    lines += [f"        {targets} = {a}[:, _lo:_hi]" for a, targets in _used_names(p, args)]
    if nrows:
        lines.append("        _block = _work[:, :_hi - _lo]")
        lines.append(f"        {', '.join(f'_w{k}' for k in range(nrows))}{',' if nrows == 1 else ''} = _block")
    for a, cols, first in blocks:
        def target(fn, col):
            i = tape.trig.get((fn, syms[a][col].name))
            return text(i) if i in used else "_"
        sines, cosines = (", ".join(target(fn, col) for col in cols) + ("," if len(cols) == 1 else "")
                          for fn in ("sin", "cos"))
        lines.append(f"        ({sines}), ({cosines}) = "
                     f"_sincos({a}[{_columns(cols)}, _lo:_hi], _block[{first}:{first + 6 * len(cols)}])")
    lines += [f"        _o{j} = {name}[:, _lo:_hi]" for j, (name, _, _) in enumerate(outs)]
    for i, (fn, op_args) in enumerate(tape.ops):
        if i in fixed:
            continue
        dest = f"_o{direct[i][0]}[{direct[i][1]}]" if i in direct else f"_w{row[i]}"
        call = f"np.{fn}({', '.join(text(a) for a in op_args)}, {dest})"
        lines.append(f"        {names[i]} = {call}" if i in names else f"        {call}")
    lines += [f"        _o{j}[{k}] = {text(v)}" for j, k, v in writes if v is not None]
    returns = ", ".join(f"np.ascontiguousarray({name}.T).reshape(shape + {shape!r})" for name, shape, _ in outs)
    lines.append(f"    return {returns}")
    return "\n".join(lines)


def module_source(bundle: Bundle) -> str:
    """The whole module text of one model: header, constants, helpers, functions."""
    head = "\n".join(header_lines(bundle, "numpy"))
    counts = {p.name: p.op_count() for p in bundle.programs}
    parts = [
        f'"""{head}\n"""\n',
        "import math\n\nimport numpy as np\n",
        f"MODEL = {bundle.name!r}",
        f"SYMDYN_VERSION = {bundle.version!r}",
        f"FINGERPRINT = {bundle.fingerprint!r}",
        f"N = {bundle.n}",
        f"FUNCTIONS = {tuple(p.name for p in bundle.programs)!r}",
        f"OP_COUNTS = {counts!r}",
        _HELPERS,
    ]
    for p in bundle.programs:
        parts += ["\n\n" + batched_source(p), "\n\n" + scalar_source(p)]
    return "\n".join(parts) + "\n"
