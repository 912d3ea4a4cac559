"""CasADi target: one `casadi.Function` per program, with named inputs and outputs.

The program's assignments are evaluated once in CasADi SX (so the function is
the same DAG the C and NumPy targets compute); CasADi's AD then gives any
Jacobian (∂τ/∂q, ∂q̈/∂τ, …).  A model's functions are stored together in one
file with CasADi's serialiser, preceded by the provenance strings (symdyn
version, model fingerprint); the functions are packed as one sealed string
(their serialisation headed by its sha256, see `symdyn.codegen.emit.seal`) so
an edited file is detected before it is deserialised.  They can be passed
through CasADi's own C code generator.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import casadi as ca

from ...derivation.program import Program, lower
from . import DIGEST_FIELD, Bundle, seal, write_atomic

__all__ = ["function", "functions", "serialize", "read", "deserialize", "generate_c", "FORMAT"]

FORMAT = "symdyn-casadi-2"

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
        return x ** exponent


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
    fingerprint, model name, then the sealed content: "content-sha256: <hex>"
    and the serialised list of Functions, one per program."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    inner = ca.StringSerializer()
    inner.pack(functions(bundle))
    content = seal(f"{DIGEST_FIELD}\n{inner.encode()}")
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
        head = dict(zip(("format", "symdyn-version", "model-fingerprint", "model"),
                        (d.unpack() for _ in range(4))))
        if head.get("format") != FORMAT:
            raise ValueError(f"{path} is not a symdyn CasADi file (format {head.get('format')!r}, "
                             f"expected {FORMAT!r})")
        return head, d.unpack()
    except RuntimeError as exc:
        raise ValueError(f"{path} is not a symdyn CasADi file: {exc}") from exc


def deserialize(path: Path) -> tuple[dict, list[ca.Function]]:
    """(the head of `read`, functions) of a file (check `is_intact` of its content first)."""
    head, content = read(path)
    return head, list(ca.StringDeserializer(content.split("\n", 1)[1]).unpack())


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
