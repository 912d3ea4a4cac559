"""NumPy target: one plain Python module per model, importing only numpy and math.

Stage "emit" of model → derive → simplify → program → emit.  Every function
is batched over leading axes: q of shape (n,) or (..., n) gives outputs of
shape (..., n) or (..., n, n); inputs broadcast against each other.  Each
program is printed twice, doing the same operations in the same order: a
scalar body on Python floats (math.sin, float arithmetic), ~5x faster than
NumPy scalars, for one state or a few; and a batched body on contiguous
rows of states, one ufunc call per operation writing into a preallocated
work row that is reused once its value is dead (a fresh temporary per
operation costs page faults), with sin and cos of the joint angles by a
table kernel 3-4x faster than np.sin/np.cos.  The module carries its
provenance (SYMDYN_VERSION, FINGERPRINT) and op counts so a stale file is
detected when loaded.
"""

from __future__ import annotations

from dataclasses import dataclass

from ...derivation.program import Program, lower
from .. import contract
from . import ATOM, Bundle, Infix, header_lines, seal

__all__ = ["module_source", "batched_source", "scalar_source", "CHUNK", "FEW"]

#: States per pass of the batched body (measured: per-call overhead of ~1 us per
#: operation favours long rows; longer ones fall out of the caches).
CHUNK = 16384

#: Batches of at most FEW states run the scalar body state by state: the
#: batched body's ~1 us per operation and call exceeds ~25-40 states' float arithmetic.
FEW = 24

#: NumPy ufunc of each primitive of `symdyn.derivation.program.lower`.
UFUNCS = {
    "neg": "negative",
    "add": "add",
    "sub": "subtract",
    "mul": "multiply",
    "div": "divide",
    "sin": "sin",
    "cos": "cos",
    "tan": "tan",
    "sqrt": "sqrt",
    "sign": "sign",
    "abs": "absolute",
    "pow": "power",
}

_HELPERS = '''

def _rows(x, shape):
    """x (..., size) broadcast to shape + (size,), as contiguous rows (size, states)."""
    if x.shape[:-1] != shape:
        x = np.broadcast_to(x, shape + x.shape[-1:])
    return np.ascontiguousarray(x.reshape(-1, x.shape[-1]).T)


def _outputs(values, shape, shapes):
    """Outputs from the flat values (..., total size) of each state: one array
    of shape `shape + shapes[0]`, or a tuple of them for several outputs."""
    values = np.array(values)
    if len(shapes) == 1:
        return values.reshape(shape + shapes[0])
    ends = np.cumsum([math.prod(s) for s in shapes])[:-1]
    return tuple(v.reshape(shape + s) for v, s in zip(np.split(values, ends, axis=-1), shapes))


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
        super().__init__(
            {"sin": "math.sin", "cos": "math.cos", "tan": "math.tan", "sqrt": "math.sqrt", "abs": "abs"},
            power="math.pow",
        )

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


def _used_names(p: Program) -> list[tuple[str, str]]:
    """(argument, unpacking target) of each input the program reads: 'q1, _, q3'."""
    used = p.used_inputs()
    out = []
    for a, syms in p.inputs:
        if any(s in used for s in syms):
            names = ", ".join(s.name if s in used else "_" for s in syms)
            out.append((a, names + ("," if len(syms) == 1 else "")))
    return out


def scalar_source(p: Program) -> str:
    """The one-state body `_<name>_one` on Python floats: arguments and result
    are lists (the outputs' entries one after the other, matrices row-major)."""
    args = [a for a, _ in p.inputs]
    lines = [
        f"def _{p.name}_one({', '.join(args)}):",
        f'    """{p.name} of one state on Python floats: lists in, the flat list of outputs out."""',
    ]
    lines += [f"    {names} = {a}" for a, names in _used_names(p)]
    lines += [f"    {s.name} = {lower(e, SCALAR)[0]}" for s, e in p.assignments]
    items = [lower(e, SCALAR)[0] for _, mat in p.outputs for e in mat]
    lines += ["    return ["] + [f"        {item}," for item in items] + ["    ]"]
    return "\n".join(lines)


@dataclass(frozen=True)
class _Plan:
    """The batched body of one program: ops in order (ufunc, operands); the
    name of each named op; the output (index, entry) each op writing one
    directly writes; other output entries (index, entry, value); the sin/cos
    blocks (argument, columns, first row: k sines then k cosines); the work
    row of every op not writing an output and the number of rows; the op of
    each (sin or cos, input column), computed in a block."""

    ops: list
    names: dict
    direct: dict
    copies: list
    blocks: list
    row: dict
    rows: int
    trig: dict

    def text(self, v) -> str:
        """An operand as printed: constant, input column, op name or its work row."""
        if isinstance(v, float):
            return repr(v)
        if isinstance(v, str):
            return v
        return self.names.get(v, f"_w{self.row.get(v)}")


def _plan(p: Program) -> _Plan:
    """Record the program on a tape, lay out the sin/cos blocks and allocate work rows."""
    tape = _Tape()
    names = {}
    for s, e in p.assignments:
        v = lower(e, tape)
        tape.env[s.name] = v
        if isinstance(v, int) and v not in names:
            names[v] = s.name
    copies, direct = [], {}
    for j, (_, mat) in enumerate(p.outputs):
        for k, e in enumerate(mat):
            start = len(tape.ops)
            v = lower(e, tape)
            if isinstance(v, int) and v >= start and v not in tape.trig.values():
                direct[v] = (j, k)
            else:
                copies.append((j, k, v))
    blocks, fixed = [], {}
    for a, syms in p.inputs:
        cols = [i for i, s in enumerate(syms) if ("sin", s.name) in tape.trig or ("cos", s.name) in tape.trig]
        first = sum(2 * len(c) for _, c, _ in blocks)
        for k, col in enumerate(cols):
            for fn, offset in (("sin", 0), ("cos", len(cols))):
                if (fn, syms[col].name) in tape.trig:
                    fixed[tape.trig[fn, syms[col].name]] = first + offset + k
        if cols:
            blocks.append((a, cols, first))
    row, count = _allocate(tape.ops, direct, copies, fixed)
    rows = max([count] + [first + 6 * len(cols) for _, cols, first in blocks])
    return _Plan(tape.ops, names, direct, copies, blocks, row, rows, tape.trig)


def _allocate(ops: list, direct: dict, copies: list, fixed: dict) -> tuple[dict, int]:
    """Work row of every op not writing an output (`fixed`: rows given up
    front): linear scan, a row is reused as soon as its value is dead, and an
    op may write over its dying operand.  Returns (rows, rows used)."""
    last = {}
    for i, (_, args) in enumerate(ops):
        for a in args:
            if isinstance(a, int):
                last[a] = i
    for _, _, v in copies:
        if isinstance(v, int):
            last[v] = len(ops)
    row = dict(fixed)
    free = [r for i, r in fixed.items() if i not in last]
    count = max(fixed.values(), default=-1) + 1
    for i, (_, args) in enumerate(ops):
        if i in fixed:
            continue
        free.extend(reversed([row[a] for a in dict.fromkeys(args) if isinstance(a, int) and last[a] == i]))
        if i in direct:
            continue
        if free:
            row[i] = free.pop()
        else:
            row[i], count = count, count + 1
        if i not in last:
            free.append(row[i])
    return row, count


#: Module-level names the functions read (a local of the same name would hide them).
_MODULE_NAMES = {"argument", "leading", "MAXDIMS", "FEW", "shape"}


def _check_names(p: Program) -> None:
    taken = (
        {s.name for _, syms in p.inputs for s in syms} | {a for a, _ in p.inputs} | {s.name for s, _ in p.assignments}
    )
    clash = sorted(n for n in taken if n.startswith("_") or n in _MODULE_NAMES)
    if clash:
        raise ValueError(
            f"function {p.name!r}: names starting with '_' and {', '.join(sorted(_MODULE_NAMES))} "
            f"are the emitter's, got {', '.join(clash)}"
        )


def _dispatch_lines(p: Program, free: bool) -> list[str]:
    """Argument checks (`free`: q is a free base's, its quaternion must not be zero); one state
    or a few: the scalar body (a zero division or math domain error there falls through to
    NumPy's inf/nan)."""
    args = [a for a, _ in p.inputs]
    shapes = repr(p.output_shapes())
    lead = f"MAXDIMS - {max(map(len, p.output_shapes()))}"
    fallback = [
        "        except (ArithmeticError, ValueError):",
        "            pass  # a zero division or math domain error: inf/nan as NumPy gives below",
    ]
    checks = ", ".join(
        f"argument({a}, {len(s)}, {a!r}, {lead}, {p.name!r}{', True' if free and a == 'q' else ''})"
        for a, s in p.inputs
    )
    return [
        f"    {', '.join(args)} = {checks}",
        f"    if {' == '.join(f'{a}.ndim' for a in args)} == 1:",
        "        try:",
        f"            return _outputs(_{p.name}_one({', '.join(f'{a}.tolist()' for a in args)}), (), {shapes})",
        *fallback,
        f"    shape = leading({p.name!r}, {tuple(args)!r}, {_tuple(args)})",
        f"    {', '.join(args)} = " + ", ".join(f"_rows({a}, shape)" for a in args),
        f"    _states = {args[0]}.shape[1]",
        "    if _states <= FEW:",
        "        try:",
        f"            return _outputs([_{p.name}_one(*state) for state in zip("
        f"{', '.join(f'{a}.T.tolist()' for a in args)})], shape, {shapes})",
        *fallback,
    ]


def _tuple(names: list[str]) -> str:
    """Python text of a tuple of the variables `names`."""
    return f"({names[0]},)" if len(names) == 1 else f"({', '.join(names)})"


def _loop_lines(p: Program, plan: _Plan, chunk: int) -> list[str]:
    """The batched body: chunks of states; per chunk sin/cos blocks, then one
    ufunc call per operation into its work row or output row."""
    outs = [(name, shape, len(mat)) for (name, mat), shape in zip(p.outputs, p.output_shapes())]
    used = {v for _, args in plan.ops for v in args if isinstance(v, int)}
    used |= {v for _, _, v in plan.copies if isinstance(v, int)}
    syms = dict(p.inputs)
    lines = [f"    _step = _chunk(_states, {chunk})"]
    lines += [f"    {name} = np.empty(({size}, _states))" for name, _, size in outs]
    if plan.rows:
        lines.append(f"    _work = np.empty(({plan.rows}, _step))")
    lines += ["    for _lo in range(0, _states, _step):", "        _hi = min(_lo + _step, _states)"]
    lines += [f"        {targets} = {a}[:, _lo:_hi]" for a, targets in _used_names(p)]
    if plan.rows:
        lines += [
            "        _block = _work[:, :_hi - _lo]",
            f"        {', '.join(f'_w{k}' for k in range(plan.rows))}{',' if plan.rows == 1 else ''} = _block",
        ]
    for a, cols, first in plan.blocks:

        def target(fn, col):
            i = plan.trig.get((fn, syms[a][col].name))
            return plan.text(i) if i in used else "_"

        sines, cosines = (
            ", ".join(target(fn, col) for col in cols) + ("," if len(cols) == 1 else "") for fn in ("sin", "cos")
        )
        lines.append(
            f"        ({sines}), ({cosines}) = "
            f"_sincos({a}[{_columns(cols)}, _lo:_hi], _block[{first}:{first + 6 * len(cols)}])"
        )
    lines += [f"        _o{j} = {name}[:, _lo:_hi]" for j, (name, _, _) in enumerate(outs)]
    trig = set(plan.trig.values())
    for i, (fn, args) in enumerate(plan.ops):
        if i in trig:
            continue
        dest = f"_o{plan.direct[i][0]}[{plan.direct[i][1]}]" if i in plan.direct else f"_w{plan.row[i]}"
        call = f"np.{fn}({', '.join(plan.text(a) for a in args)}, {dest})"
        lines.append(f"        {plan.names[i]} = {call}" if i in plan.names else f"        {call}")
    lines += [f"        _o{j}[{k}] = {plan.text(v)}" for j, k, v in plan.copies]
    returns = ", ".join(f"np.ascontiguousarray({name}.T).reshape(shape + {shape!r})" for name, shape, _ in outs)
    return lines + [f"    return {returns}"]


def _columns(cols: list[int]) -> str:
    """Index of rows `cols`: a slice when consecutive."""
    if cols == list(range(cols[0], cols[-1] + 1)):
        return f"{cols[0]}:{cols[-1] + 1}"
    return repr(cols)


def batched_source(p: Program, chunk: int = CHUNK, free: bool = False) -> str:
    """The public function: argument checks (`free`: of a free base's q too), the scalar body
    for one state or a few, else the batched body, `chunk` states at a time."""
    _check_names(p)
    head = [f"def {p.name}({', '.join(a for a, _ in p.inputs)}):"] + ([f'    """{p.doc}"""'] if p.doc else [])
    return "\n".join(head + _dispatch_lines(p, free) + _loop_lines(p, _plan(p), chunk))


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
        *(
            [f"NQ = {bundle.nq}  # q: base coordinates, then the joints", f"NV = {bundle.nv}  # qd, qdd, tau"]
            if bundle.floating
            else []
        ),
        f"FEW = {FEW}  # batches of at most FEW states: the scalar body, state by state",
        f"FUNCTIONS = {tuple(p.name for p in bundle.programs)!r}",
        f"OP_COUNTS = {counts!r}",
        "\n" + contract.source(),
        _HELPERS,
    ]
    for p in bundle.programs:
        parts += ["\n\n" + batched_source(p, free=bundle.nq == bundle.nv + 1), "\n\n" + scalar_source(p)]
    return seal("\n".join(parts) + "\n")
