"""C target, the SIMD kernels: `<model>_<f>_simd` of one program.

A block of SYMDYN_W states is gathered into structure-of-arrays, the program runs once per lane
in a loop the compiler vectorizes (`VECTOR_ALGEBRA`: sin/cos/sign without branches), and the
block is scattered back; the range and threaded entry points split the blocks over threads.  A
kernel of matrix outputs computes them column by column and asks for its blocks' output lines
ahead in large batches (`_lane_statements`, `symdyn_ahead_` in the preamble of `c`).  A kernel
too wide for a vectorized lane loop (`LANE_REFERENCES`) runs the scalar function instead.
"""

from __future__ import annotations

import math

import sympy as sp

from ...derivation.program import Program, lower
from . import Infix
from .schedule import by_columns, schedule

__all__ = ["simd_source"]

#: The SIMD kernels' spelling: sin/cos/sign without branches, so that a loop over lanes vectorizes.
VECTOR_ALGEBRA = Infix(
    {"sin": "sinv_", "cos": "cosv_", "tan": "tan", "sqrt": "sqrt", "sign": "signv_", "abs": "fabs"}, power="pow"
)


def _vector_text(expr) -> str:
    return lower(expr, VECTOR_ALGEBRA)[0]


def _vector_statements(item) -> list[str]:
    """The lane loop's statements of one `sincos_pairs` item: as `c`'s, with the vector
    sin/cos/sign, and `bad += outside_(x)` for every sin/cos argument x."""
    x, a, b = item
    if x is None:
        return _trig_checks(b) + [f"        const double {a.name} = {_vector_text(b)};"]
    x = _vector_text(x)
    return [
        f"        double {a.name}, {b.name};",
        f"        bad += outside_({x});",
        f"        sincosv_({x}, &{a.name}, &{b.name});",
    ]


def _trig_checks(e) -> list[str]:
    """`bad += outside_(x)` for each sin/cos argument x of an expression: a lane whose angle the
    vector sin/cos cannot take is computed again by the scalar function (libm)."""
    return [
        f"        bad += outside_({_vector_text(t)});"
        for t in sorted({u.args[0] for u in e.atoms(sp.sin, sp.cos)}, key=sp.default_sort_key)
    ]


def _vector_store(o: str, k: int, e) -> list[str]:
    """The lane loop's store of one output entry (its own sines checked, as an assignment's are)."""
    return _trig_checks(e) + [f"        {o}_[{k}][k] = {_vector_text(e)};"]


def _lane_statements(p: Program) -> list[str]:
    """The lane loop's statements in `schedule`'s order: a kernel of matrix outputs stores each
    entry into its block as soon as its operands are computed, the matrices column by column."""
    plan = schedule(p)
    lines = [line for o, k, e in plan.head for line in _vector_store(o, k, e)]
    for step in plan.steps:
        lines += _vector_statements(step.item)
        lines += [line for o, k, e in step.stores for line in _vector_store(o, k, e)]
    return lines + [line for o, k, e in plan.tail for line in _vector_store(o, k, e)]


def _balanced_sum(terms: list[str]) -> str:
    """The terms' sum as a balanced tree (depth log2 of their count, not a chain)."""
    while len(terms) > 1:
        terms = [f"({a} + {b})" for a, b in zip(terms[::2], terms[1::2])] + terms[len(terms) - len(terms) % 2 :]
    return terms[0]


#: The memory references (a state's inputs and outputs) a lane loop may have: gcc vectorizes a
#: loop only up to its --param loop-max-datarefs-for-datadeps, which symdyn's builds raise to this
#: (`cunits.WIDE_LOOPS`; the analysis grows with the square of the references).  A wider kernel's
#: lanes would run one at a time, slower than the scalar function in a loop (Solo 12's regressor,
#: 3 204 outputs: 2 120 ns a state against 1 240), so it runs the scalar function state after
#: state over the threads (`_loop_source`).
LANE_REFERENCES = 3000


def _loop_source(f: str, ins, sig, prototype: str) -> str:
    """The batch entry of a kernel wider than `LANE_REFERENCES`: each thread's states by the scalar
    function, an input that is NaN or infinite stopping it (nonzero) before its state is computed."""
    body = [
        f"/* {f}: wider than a vectorized lane loop: the scalar function state after state */",
        f"static int {f}_range(const double *const *in, double *const *out, long i0, long i1)",
        "{",
        "    long i, j;",
        "    for (i = i0; i < i1; ++i) {",
    ]
    for k, (_, syms) in enumerate(ins):
        body += [
            f"        for (j = 0; j < {len(syms)}; ++j)",
            f"            if (!isfinite(in[{k}][i * {len(syms)} + j]))",
            "                return 1;",
        ]
    args = [f"in[{k}] + i * {len(syms)}" for k, (_, syms) in enumerate(ins)]
    args += [f"out[{k}] + i * {math.prod(sh)}" for k, (_, sh) in enumerate(sig.outputs)]
    body += [f"        {f}({', '.join(args)});", "    }", "    return 0;", "}", ""]
    body += [
        prototype,
        "{",
        f"    const double *const in[{len(ins)}] = {{{', '.join(a for a, _ in ins)}}};",
        f"    double *const out[{len(sig.outputs)}] = {{{', '.join(o for o, _ in sig.outputs)}}};",
        f"    return symdyn_parallel_({f}_range, in, out, n, threads);",
        "}",
        "",
    ]
    return "\n".join(body)


def simd_source(model: str, p: Program, sig, prototype: str) -> str:
    """The SIMD kernel of one program: a block of SYMDYN_W states gathered into
    structure-of-arrays, the program once per lane in a loop the compiler
    vectorizes, scattered back (a short last block repeats its last state);
    then the range and threaded entry points.  Each lane also sums x·0 over its
    inputs (0 unless one is NaN or infinite) in a balanced tree, so that the
    contract's check costs a few vector operations, not a pass of its own."""
    used = p.used_inputs()
    f = f"{model}_{p.name}"
    ins = [(a, syms) for a, syms in p.inputs]
    if sum(len(syms) for _, syms in ins) + sum(math.prod(sh) for _, sh in sig.outputs) > LANE_REFERENCES:
        return _loop_source(f, ins, sig, prototype)
    ahead = by_columns(p)  # a kernel of matrix outputs: its blocks' output lines asked for ahead
    body = [
        f"static int {f}_lanes(long i0, int m, "
        + ", ".join([f"const double *{a}" for a, _ in ins] + [f"double *{o}" for o, _ in sig.outputs])
        + (", int ahead)" if ahead else ")"),
        "{",
    ]
    body += [f"    double {a}_[{len(syms)}][SYMDYN_W];" for a, syms in ins]
    body += [f"    double {o}_[{math.prod(sh)}][SYMDYN_W];" for o, sh in sig.outputs]
    body += ["    double bad_[SYMDYN_W], nonfinite_[SYMDYN_W];", "    int k, j;"]
    body += ["    for (k = 0; k < SYMDYN_W; ++k) {", "        const long i = i0 + (k < m ? k : m - 1);"]
    for a, syms in ins:
        body += [f"        for (j = 0; j < {len(syms)}; ++j)", f"            {a}_[j][k] = {a}[i * {len(syms)} + j];"]
    body += ["    }"]
    if ahead:
        body += ["    if (ahead && m == SYMDYN_W) {"]
        body += [
            f"        symdyn_ahead_({o} + i0 * {math.prod(sh)}, {math.prod(sh) * 8} * SYMDYN_W);"
            for o, sh in sig.outputs
        ]
        body += ["    }"]
    body += ["    SYMDYN_SIMD", "    for (k = 0; k < SYMDYN_W; ++k) {", "        double bad = 0.0;"]
    body.append(
        f"        nonfinite_[k] = {_balanced_sum([f'{a}_[{j}][k] * 0.0' for a, syms in ins for j in range(len(syms))])};"
    )
    for a, syms in ins:
        body += [f"        const double {s.name} = {a}_[{k}][k];" for k, s in enumerate(syms) if s in used]
    body += _lane_statements(p)
    body += ["        bad_[k] = bad;", "    }"]
    body += ["    for (k = 0; k < SYMDYN_W; ++k)", "        if (nonfinite_[k] != 0.0)", "            return 1;"]
    args = [f"{a} + i * {len(syms)}" for a, syms in ins] + [f"{o} + i * {math.prod(sh)}" for o, sh in sig.outputs]
    body += [f"    symdyn_scatter_({o}_[0], {math.prod(sh)}, {o} + i0 * {math.prod(sh)}, m);" for o, sh in sig.outputs]
    body += [
        "    for (k = 0; k < m; ++k) {  /* a lane sincosv_ could not take: the scalar function's */",
        "        const long i = i0 + k;",
        "        if (bad_[k] != 0.0)",
        f"            {f}({', '.join(args)});",
        "    }",
        "    return 0;",
        "}",
        "",
    ]
    nin = len(ins)
    lanes_args = [f"in[{i}]" for i in range(nin)] + [f"out[{j}]" for j in range(len(sig.outputs))]
    bytes_per_state = 8 * sum(math.prod(sh) for _, sh in sig.outputs)
    body += [
        f"static int {f}_range(const double *const *in, double *const *out, long i0, long i1)",
        "{",
        "    long i;",
        "    int nonfinite = 0;",
    ]
    if ahead:
        body += [f"    const int ahead = (i1 - i0) * {bytes_per_state}L >= SYMDYN_AHEAD_BYTES;"]
        lanes_args.append("ahead")
    body += [
        "    for (i = i0; i < i1 && !nonfinite; i += SYMDYN_W)",
        f"        nonfinite = {f}_lanes(i, (int)(i1 - i < SYMDYN_W ? i1 - i : SYMDYN_W), {', '.join(lanes_args)});",
        "    return nonfinite;",
        "}",
        "",
    ]
    body += [
        prototype,
        "{",
        f"    const double *const in[{nin}] = {{{', '.join(a for a, _ in ins)}}};",
        f"    double *const out[{len(sig.outputs)}] = {{{', '.join(o for o, _ in sig.outputs)}}};",
        f"    return symdyn_parallel_({f}_range, in, out, n, threads);",
        "}",
        "",
    ]
    return "\n".join(body)
