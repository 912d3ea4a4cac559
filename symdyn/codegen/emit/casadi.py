"""CasADi target: one `casadi.Function` per program, with named inputs and outputs.

The program's assignments are evaluated once in CasADi SX (so the function is
the same DAG the C and NumPy targets compute); CasADi's AD then gives any
Jacobian (∂τ/∂q, ∂q̈/∂τ, …).  A model's functions are stored together in one
file with CasADi's serialiser, preceded by the provenance strings (symdyn
version, model fingerprint); the functions are packed as one sealed string
(their serialisation headed by its sha256, see `symdyn.codegen.emit.seal`) so
an edited file is detected before it is deserialised, with the shape of
each output (a 1×1 M is a matrix, a 1-vector τ is not).  They can be passed
through CasADi's own C code generator.  `Numeric` gives a Function the
contract of every target (`symdyn.codegen.contract`) when it is called with
numbers, batched over leading axes by CasADi's map.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

from ...derivation.program import Program, lower
from .. import contract
from . import DIGEST_FIELD, Bundle, seal, write_atomic

__all__ = ["function", "functions", "serialize", "read", "deserialize", "generate_c", "FORMAT", "Numeric"]

FORMAT = "symdyn-casadi-3"

_CALLS = {"sin": ca.sin, "cos": ca.cos, "tan": ca.tan, "sqrt": ca.sqrt, "sign": ca.sign, "abs": ca.fabs}


class _SX:
    """The algebra of CasADi SX values (Python floats for constants)."""

    def __init__(self, env: dict) -> None:
        self.env = env

    def number(self, value):
        return float(value)

    def symbol(self, name):
        return self.env[name]

    def neg(self, x):
        return -x

    def add(self, x, y):
        return x + y

    def sub(self, x, y):
        return x - y

    def mul(self, x, y):
        return x * y

    def div(self, x, y):
        return x / y

    def call(self, name, x):
        return _CALLS[name](x)

    def pow(self, x, exponent):
        return x**exponent


def function(p: Program) -> ca.Function:
    """The program as a casadi.Function: inputs are column vectors, outputs
    vectors or matrices, all named as in the program."""
    args = [ca.SX.sym(a, len(syms)) for a, syms in p.inputs]
    env = {s.name: arg[k] for arg, (_, syms) in zip(args, p.inputs) for k, s in enumerate(syms)}
    alg = _SX(env)
    for s, e in p.assignments:
        env[s.name] = lower(e, alg)
    outs = []
    for _, mat in p.outputs:
        out = ca.SX(mat.rows, mat.cols)
        for i in range(mat.rows):
            for j in range(mat.cols):
                out[i, j] = lower(mat[i, j], alg)
        outs.append(out)
    return ca.Function(p.name, args, outs, [a for a, _ in p.inputs], [o for o, _ in p.outputs])


def functions(bundle: Bundle) -> list[ca.Function]:
    return [function(p) for p in bundle.programs]


def serialize(bundle: Bundle, path: Path) -> Path:
    """Write the model's functions to `path` (atomically): format tag, version,
    fingerprint, model name, then the sealed content: "content-sha256: <hex>",
    the output shapes of every function (JSON, one line) and the serialised
    list of Functions, one per program."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    inner = ca.StringSerializer()
    inner.pack(functions(bundle))
    shapes = json.dumps({p.name: p.output_shapes() for p in bundle.programs}, separators=(",", ":"))
    content = seal(f"{DIGEST_FIELD}\n{shapes}\n{inner.encode()}")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    os.close(fd)
    try:
        s = ca.FileSerializer(tmp)
        for text in (FORMAT, bundle.version, bundle.fingerprint, bundle.name, content):
            s.pack(text)
        del s
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)
    return path


def read(path: Path) -> tuple[dict, str]:
    """({"format", "symdyn-version", "model-fingerprint", "model"}, sealed content) of a file."""
    d = ca.FileDeserializer(str(path))
    try:
        head = dict(zip(("format", "symdyn-version", "model-fingerprint", "model"), (d.unpack() for _ in range(4))))
        if head.get("format") != FORMAT:
            raise ValueError(f"{path} is not a symdyn CasADi file (format {head.get('format')!r}, expected {FORMAT!r})")
        return head, d.unpack()
    except RuntimeError as exc:
        raise ValueError(f"{path} is not a symdyn CasADi file: {exc}") from exc


def deserialize(path: Path) -> tuple[dict, list["Numeric"]]:
    """(the head of `read`, the functions with their output shapes) of a file
    (check `is_intact` of its content first)."""
    head, content = read(path)
    _, shapes, encoded = content.split("\n", 2)
    shapes = json.loads(shapes)
    functions = ca.StringDeserializer(encoded).unpack()
    inputs = [(f.name(), [(f.name_in(i), f.size1_in(i)) for i in range(f.n_in())]) for f in functions]
    quaternion = "q" if contract.free_base(inputs) else None
    return head, [Numeric(f, shapes[f.name()], quaternion) for f in functions]


class Numeric:
    """A casadi.Function that follows the contract of every target when called
    with numbers (NumPy arrays, lists, floats): single or batched states,
    broadcasting, keyword arguments, NumPy outputs of the documented shapes,
    bad input refused.  Called with CasADi values (SX, MX, DM), and in every
    attribute (name_in, map, factory, …), it is the Function itself."""

    def __init__(self, function: ca.Function, shapes, quaternion: str | None = None) -> None:
        self.function = function
        self.quaternion = quaternion  # the input that is a free base's q (`contract.free_base`)
        self.shapes = tuple(tuple(s) for s in shapes)
        self.inputs = tuple((function.name_in(i), function.size1_in(i)) for i in range(function.n_in()))
        self.__name__ = function.name()
        self.__doc__ = function.__str__()
        self._lead = contract.MAXDIMS - max(map(len, self.shapes))
        self._maps: dict[int, ca.Function] = {}

    def __getattr__(self, name):
        if name == "function":  # not set yet (a copy being built)
            raise AttributeError(name)
        return getattr(self.function, name)

    def __repr__(self) -> str:
        return repr(self.function)

    def __call__(self, *args, **kwargs):
        if any(isinstance(x, (ca.SX, ca.MX, ca.DM)) for x in (*args, *kwargs.values())):
            return self.function(*args, **kwargs)
        arrays, lead = contract.arguments(self.__name__, self.inputs, args, kwargs, self._lead, self.quaternion)
        count = int(np.prod(lead))
        if lead and not count:
            outs = tuple(np.empty(lead + s) for s in self.shapes)
            return outs[0] if len(outs) == 1 else outs
        if lead:
            values = self._map(count).call([ca.DM(x.reshape(count, -1).T) for x in arrays])
        else:
            values = self.function.call([ca.DM(x) for x in arrays])
        outs = tuple(_rows(np.array(v), count, s).reshape(lead + s) for v, s in zip(values, self.shapes))
        return outs[0] if len(outs) == 1 else outs

    def _map(self, count: int) -> ca.Function:
        """CasADi's map of the function over `count` states, kept for the next call of that size
        (building one costs about as much as evaluating it; the last MAPS sizes are kept)."""
        mapped = self._maps.pop(count, None) or self.function.map(count)
        self._maps[count] = mapped
        while len(self._maps) > MAPS:
            del self._maps[next(iter(self._maps))]
        return mapped


#: Batch sizes whose CasADi map a Numeric function keeps.
MAPS = 8


def _rows(value: np.ndarray, count: int, shape: tuple) -> np.ndarray:
    """One state's output (rows, cols), or CasADi's map of `count` states
    (rows, count·cols), as (count, *shape) row-major."""
    per = value.reshape(value.shape[0], count, -1).transpose(1, 0, 2)
    return np.ascontiguousarray(per).reshape((count, *shape))


def generate_c(funcs: list[ca.Function], name: str, out_dir: Path) -> Path:
    """CasADi's own C code for the functions, as `<out_dir>/<name>_casadi.c` (+ .h)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cg = ca.CodeGenerator(f"{name}_casadi.c", {"with_header": True})
    for f in funcs:
        cg.add(f)
    with tempfile.TemporaryDirectory(dir=out_dir) as tmp:
        cg.generate(tmp + os.sep)
        for suffix in (".c", ".h"):
            src = Path(tmp, f"{name}_casadi{suffix}")
            write_atomic(out_dir / src.name, src.read_bytes())
    return out_dir / f"{name}_casadi.c"


# --------------------------------------------------------------------------- compiled functions

#: Flags of the compiled CasADi functions.  -O1: the second-derivative functions
#: are long straight lines that -O2/-O3 take several times longer to compile for
#: no measurable gain (docs/studies_ocp.md, "Compiled CasADi functions").
COMPILE_FLAGS = ("-O1", "-fPIC", "-shared")


def derivative_functions(f: ca.Function) -> list[ca.Function]:
    """f with the derivative functions IPOPT's exact-Hessian solve asks of it, under
    the names `casadi.external` looks up: `jac_f` (∂outputs/∂inputs, for the
    constraint Jacobian), `adj1_f` (reverse mode, for gradients) and `jac_adj1_f`
    (the Jacobian of the reverse mode: the Hessian of λᵀf, for the Hessian of
    the Lagrangian).  CasADi derives each from f's SX by its own AD."""
    adj = f.reverse(1)
    return [f, f.jacobian(), adj, adj.jacobian()]


def compiled(f: ca.Function, *, flags: tuple = COMPILE_FLAGS, derivatives=None) -> ca.Function:
    """f as a `casadi.external` on compiled code, with its Jacobian and the Hessian of
    λᵀf compiled beside it (`derivatives`, default `derivative_functions(f)` minus f:
    functions under the names `casadi.external` looks up): same name, inputs and outputs.

    CasADi's code generator writes the C; the library is built with the system C
    compiler once into symdyn's cache, under a name keyed by the sha256 of the C
    source, the compiler and the flags (any change of f is a new library), and is
    reused when its sha256 matches the one recorded when it was built (a damaged
    library is rebuilt, like the C target's, `emit.cbuild`).
    """
    from ...derivation.cache import cache_dir
    from .cbuild import digest, library

    name = f.name()
    cg = ca.CodeGenerator(f"{name}.c", {"with_header": False})
    for g in [f, *derivatives] if derivatives is not None else derivative_functions(f):
        cg.add(g)
    with tempfile.TemporaryDirectory() as tmp:
        cg.generate(tmp + os.sep)
        source = Path(tmp, f"{name}.c").read_text()
    key = digest(source, os.environ.get("CC", "cc"), " ".join(flags), FORMAT)[:16]
    lib = library(cache_dir() / "casadi" / f"{name}-{key}" / f"lib{name}.so", tuple(flags), {f"{name}.c": source}, [])
    return ca.external(name, str(lib))
