"""C target: a .c/.h pair per model with plain C entry points.

For every function a single-state and a batched entry point, e.g.
`void puma560_tau(const double q[6], const double qd[6], const double qdd[6],
double tau[6])` and `void puma560_tau_batch(int n, const double *q, …)`;
matrices are row-major (`double M[36]`).  The header lists each function's
signature in a machine-readable comment (`function: M(q: 6) -> M: 6x6`), which
`symdyn.emit.clib` reads to bind the compiled library to Python.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..program import Program, lower
from . import Bundle, Infix, header_lines

__all__ = ["c_source", "h_source", "Signature", "read_signatures"]

ALGEBRA = Infix({"sin": "sin", "cos": "cos", "tan": "tan", "sqrt": "sqrt", "sign": "sign_",
                 "abs": "fabs"}, power="pow")

_SIGN = ("/* sign(x): -1, 0 or +1, as sympy's sign (Coulomb friction is 0 at rest). */\n"
         "static inline double sign_(double x) { return (double)((x > 0.0) - (x < 0.0)); }\n")


@dataclass(frozen=True)
class Signature:
    """Inputs [(name, size)] and outputs [(name, (rows,) or (rows, cols))] of one function."""

    name: str
    inputs: tuple
    outputs: tuple

    def line(self) -> str:
        ins = ", ".join(f"{a}: {k}" for a, k in self.inputs)
        outs = ", ".join(f"{o}: {'x'.join(map(str, s))}" for o, s in self.outputs)
        return f"function: {self.name}({ins}) -> {outs}"


def signature(p: Program) -> Signature:
    outs = tuple((o, (m.rows,) if m.cols == 1 else (m.rows, m.cols)) for o, m in p.outputs)
    return Signature(p.name, tuple((a, len(s)) for a, s in p.inputs), outs)


_LINE = re.compile(r"^[\s*]*function: (\w+)\(([^)]*)\) -> (.*)$", re.M)


def read_signatures(header: str) -> list[Signature]:
    """The signatures listed in a generated .h (inverse of Signature.line)."""
    out = []
    for name, ins, outs in _LINE.findall(header):
        inputs = tuple((a.strip(), int(k)) for a, k in (x.split(":") for x in ins.split(",") if x.strip()))
        outputs = tuple((o.strip(), tuple(int(d) for d in s.strip().split("x")))
                        for o, s in (x.split(":") for x in outs.split(",")))
        out.append(Signature(name, inputs, outputs))
    return out


def _size(shape) -> int:
    size = 1
    for d in shape:
        size *= d
    return size


def _prototypes(model: str, sig: Signature) -> tuple[str, str]:
    """(single, batched) C prototypes of one function."""
    ins = [f"const double {a}[{k}]" for a, k in sig.inputs]
    outs = [f"double {o}[{_size(s)}]" for o, s in sig.outputs]
    single = f"void {model}_{sig.name}({', '.join(ins + outs)})"
    batch_args = ["int n"] + [f"const double *{a}" for a, _ in sig.inputs] + [f"double *{o}" for o, _ in sig.outputs]
    return single, f"void {model}_{sig.name}_batch({', '.join(batch_args)})"


def _comment(lines: list[str]) -> str:
    return "/*\n" + "".join(f" * {line}".rstrip() + "\n" for line in lines) + " */\n"


def h_source(bundle: Bundle) -> str:
    """The header: provenance, signatures, and the prototypes."""
    guard = f"SYMDYN_{bundle.name.upper()}_H"
    sigs = [signature(p) for p in bundle.programs]
    lines = header_lines(bundle, "c") + ["", "Matrices are row-major; *_batch loops over n states stored contiguously.",
                                         "signatures:"] + [f"  {s.line()}" for s in sigs]
    parts = [_comment(lines), f"#ifndef {guard}\n#define {guard}\n",
             '#ifdef __cplusplus\nextern "C" {\n#endif\n',
             f"#define {bundle.name.upper()}_NDOF {bundle.n}",
             f'#define {bundle.name.upper()}_FINGERPRINT "{bundle.fingerprint}"',
             f'#define {bundle.name.upper()}_SYMDYN_VERSION "{bundle.version}"\n']
    for p, sig in zip(bundle.programs, sigs):
        single, batch = _prototypes(bundle.name, sig)
        if p.doc:
            parts.append(f"/* {p.doc} */")
        parts.append(f"{single};\n{batch};\n")
    parts.append("#ifdef __cplusplus\n}\n#endif\n#endif")
    return "\n".join(parts) + "\n"


def _text(expr) -> str:
    return lower(expr, ALGEBRA)[0]


def function_source(model: str, p: Program) -> str:
    """The single-state and batched C functions of one program."""
    sig = signature(p)
    single, batch = _prototypes(model, sig)
    used = p.used_inputs()
    body = []
    for a, syms in p.inputs:
        body += [f"    const double {s.name} = {a}[{k}];" for k, s in enumerate(syms) if s in used]
    body += [f"    const double {s.name} = {_text(e)};" for s, e in p.assignments]
    for o, mat in p.outputs:
        body += [f"    {o}[{k}] = {_text(e)};" for k, e in enumerate(mat)]
    doc = f"/* {p.doc} */\n" if p.doc else ""
    calls = [f"{a} + {k}*k" for a, k in sig.inputs] + [f"{o} + {_size(s)}*k" for o, s in sig.outputs]
    loop = (f"{batch}\n{{\n    for (long k = 0; k < n; ++k)\n"
            f"        {model}_{p.name}({', '.join(calls)});\n}}\n")
    return f"{doc}{single}\n{{\n" + "\n".join(body) + "\n}\n\n" + loop


def c_source(bundle: Bundle) -> str:
    """The whole .c file of one model."""
    parts = [_comment(header_lines(bundle, "c")), "#include <math.h>",
             f'#include "{bundle.name}.h"\n', _SIGN]
    parts += [function_source(bundle.name, p) for p in bundle.programs]
    return "\n".join(parts)
