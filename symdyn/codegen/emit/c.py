"""C target: a .c/.h pair per model with plain C entry points.

For every function a single-state and a batched entry point, e.g.
`void puma560_tau(const double q[6], const double qd[6], const double qdd[6],
double tau[6])` and `void puma560_tau_batch(int n, const double *q, …)`;
matrices are row-major (`double M[36]`).  The header lists each function's
signature in a machine-readable comment (`function: M(q: 6) -> M: 6x6`), which
`symdyn.codegen.emit.clib` reads to bind the compiled library to Python.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import sympy as sp

from ...derivation.program import Program, lower
from . import Bundle, Infix, header_lines, seal

__all__ = ["c_source", "h_source", "Signature", "read_signatures"]

ALGEBRA = Infix({"sin": "sin_", "cos": "cos_", "tan": "tan", "sqrt": "sqrt", "sign": "sign_",
                 "abs": "fabs"}, power="pow")

_HELPERS = r"""/* sign(x): -1, 0 or +1, as sympy's sign (Coulomb friction is 0 at rest). */
static inline double sign_(double x) { return (double)((x > 0.0) - (x < 0.0)); }

/* sin and cos of x together, inline (libm's calls would dominate the run time):
   reduction by pi/2 in two parts (Cody-Waite), the fdlibm kernels on
   [-pi/4, pi/4] and a branch-free choice of quadrant.  Error <= 1 ulp, except
   within ~1e-6 of a multiple of pi/2 where it is below 1e-26 absolute; libm
   beyond |x| >= 1e5. */
static inline void sincos_(double x, double *s, double *c)
{
    if (!(fabs(x) < 1e5)) {
        *s = sin(x);
        *c = cos(x);
        return;
    }
    const double shift = 6755399441055744.0;  /* 1.5 * 2^52: adding it rounds to an integer */
    const double k = (x * 0.63661977236758134308 + shift) - shift;
    const double r = (x - k * 1.57079632673412561417e+00) - k * 6.07710050650619224932e-11;
    const long n = (long)k;
    const double z = r * r;
    const double sr = r + r * z * (-1.66666666666666324348e-01 + z * (8.33333333332248946124e-03
        + z * (-1.98412698298579493134e-04 + z * (2.75573137070700676789e-06
        + z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))));
    const double hz = 0.5 * z, w = 1.0 - hz;
    const double cr = w + (((1.0 - w) - hz) + z * z * (4.16666666666666019037e-02
        + z * (-1.38888888888741095749e-03 + z * (2.48015872894767294178e-05
        + z * (-2.75573143513906633035e-07 + z * (2.08757232129817482790e-09
        + z * -1.13596475577881948265e-11))))));
    const double odd = (double)(n & 1), even = 1.0 - odd;
    *s = (double)(1 - (n & 2)) * (sr * even + cr * odd);
    *c = (double)(1 - ((n + 1) & 2)) * (cr * even + sr * odd);
}

static inline double sin_(double x) { double s, c; sincos_(x, &s, &c); return s; }
static inline double cos_(double x) { double s, c; sincos_(x, &s, &c); return c; }
"""


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
    outs = tuple((o, shape) for (o, _), shape in zip(p.outputs, p.output_shapes()))
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
    return seal("\n".join(parts) + "\n")


def _text(expr) -> str:
    return lower(expr, ALGEBRA)[0]


def _assignments(assignments) -> list[str]:
    """C statements of the assignments; s = sin(x) and c = cos(x) of the same x
    become one sincos_ call where the first of them stood."""
    trig = {}
    for s, e in assignments:
        if isinstance(e, (sp.sin, sp.cos)):
            trig.setdefault(e.args[0], {})[e.func] = s
    lines, done = [], set()
    for s, e in assignments:
        pair = trig.get(e.args[0], {}) if isinstance(e, (sp.sin, sp.cos)) else {}
        if len(pair) == 2:
            if s not in done:
                sin_s, cos_s = pair[sp.sin], pair[sp.cos]
                lines.append(f"    double {sin_s.name}, {cos_s.name};")
                lines.append(f"    sincos_({_text(e.args[0])}, &{sin_s.name}, &{cos_s.name});")
                done |= {sin_s, cos_s}
            continue
        lines.append(f"    const double {s.name} = {_text(e)};")
    return lines


def function_source(model: str, p: Program) -> str:
    """The single-state and batched C functions of one program."""
    sig = signature(p)
    single, batch = _prototypes(model, sig)
    used = p.used_inputs()
    body = []
    for a, syms in p.inputs:
        read = [f"    const double {s.name} = {a}[{k}];" for k, s in enumerate(syms) if s in used]
        body += read or [f"    (void){a};  /* unused: this {p.name} does not depend on {a} */"]
    body += _assignments(p.assignments)
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
             f'#include "{bundle.name}.h"\n', _HELPERS]
    parts += [function_source(bundle.name, p) for p in bundle.programs]
    return seal("\n".join(parts))
