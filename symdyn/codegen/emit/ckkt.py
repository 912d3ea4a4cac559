"""The contact derivatives in C: a straight-line program for the KKT parts, then dense products.

Part of the C target, beside `c`: `contact_fdyn_derivatives` and `contact_impulse_derivatives`
are emitted from their KKT parts (`contact_functions.parts_program`: the dynamics, M⁻¹ or its
factors L⁻¹ and D⁻¹L⁻¹, Xᵀ = J M⁻¹ or the rows J, A⁻¹, and R = the residuals' Jacobians or the
local partials they are made from) as a static function; then M⁻¹ multiplied out from its factors
and Xᵀ = J M⁻¹ (`_combined_rows`), R made by forward mode in vectors of directions
(`tangents.Plan.c_source`), and the derivatives −K⁻¹R, K⁻¹ = [P Gᵀ; −G A⁻¹] (G = A⁻¹Xᵀ,
P = M⁻¹ − X G): the forces' rows df = [G −A⁻¹] R two at a time, then the accelerations'
da = M⁻¹(Jᵀdf − R1) through M⁻¹'s factors (`_top`), by kernels whose accumulators stay in vector
registers, the vectors of exact zeros and the tree's zeros of the factors skipped.  The
unrolled solve of each column (`contact_functions.derivatives_program`, what the other targets run)
is one scalar operation after another: on Solo 12 with four feet 90 k of them, against 15.6 k
scalar operations, 3.8 k vector multiply-adds of the tangents and 38 k multiply-adds of products
here (`symdyn bench --task-space solo12-contact-derivatives`, `talos-contact-derivatives`).  The
batch kernel runs the scalar function state after state on every thread.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ...derivation.program import Program
from ..contact_functions import ALL_PARTS
from . import c as c_emit, csimd
from . import seal

__all__ = ["derivatives_source", "function_file", "products"]


#: Doubles per vector of the products' kernels: an AVX-512 register (eight), which GCC and Clang
#: split into two halves on a machine with 256-bit vectors.  Talos on two soles, products 5.4 →
#: 3.7 µs a call against four (AMD Zen 5); Solo 12 1.4 → 1.0 µs, its 18 columns padded to 24.
LANES = 8


#: Rows of −K⁻¹R made at once (`_sparse_rows`): each vector of R loaded once for both, the loads
#: that bound one row shared.  Talos on two soles (R 9 vectors wide): −K⁻¹R 4.7 → 2.6 µs a call at
#: two rows, 3.6 at three and 4.0 at four (their accumulators spill: AMD Zen 5, 32 vector
#: registers); Solo 12 (5 wide) the same at two and four.
ROWS = 2


#: Assignments per part of the KKT parts' program (`c.PART_SIZE` elsewhere): fewer values pass
#: between parts through memory.  Talos on two soles, a call in the benchmark's harness: 11.1 µs
#: at 100, 10.8 at 150, 10.4 at 200, 10.6 at 250 and 300, 11.9 at 400 (best of 8, one stack
#: placement); 12.2–12.4 → 11.1–11.3 µs from 100 to 200 over 16 placements (two comparisons);
#: compiling its unit 9.0 s at 100, 9.5 s at 200.
PART_SIZE = 200


def _up(k: int) -> int:
    """k rounded up to whole vectors of LANES doubles."""
    return -(-k // LANES) * LANES


def _residual_pattern(parts: Program, tangents) -> sp.ImmutableMatrix:
    """R, or where the plan makes it in vectors (`tangents`: (program, plan, columns)) its pattern:
    1 where an entry may be nonzero (the plan's directions, the turn's columns), 0 elsewhere."""
    out = dict(parts.outputs)
    if tangents is None:
        return out["R"]
    _, plan, columns = tangents
    n, nc = out["XT" if "XT" in out else "J"].cols, out["Ainv"].rows
    nonzero = plan.pattern(columns) | {(i, 3 + k) for i in range(n) for k in range(3) if out["turn"][i, k] != 0}
    return sp.ImmutableMatrix(n + nc, 2 * n, lambda i, j: 1 if (i, j) in nonzero else 0)


def products(parts: Program, tangents=None) -> int:
    """The multiply-adds of the products after the parts: M⁻¹ from its factors where the parts hold
    them, G, P, df = [G −A⁻¹] R and da = M⁻¹(Jᵀdf − R1) (`_top`), R's vectors of exact zeros
    skipped as the kernels skip them."""
    out = dict(parts.outputs)
    n, nc = out["XT" if "XT" in out else "J"].cols, out["Ainv"].rows
    R = _vectors(_padded(_residual_pattern(parts, tangents)))
    kept = sum(len(r) for r in R)
    inverse = _macs(out["Linv"], _vectors(_padded(out["DLinv"]))) if "Linv" in out else 0  # M⁻¹ multiplied out
    rows = _macs(out["J"], [set(range(_up(n) // LANES))] * n) if "J" in out else 0  # Xᵀ = J M⁻¹
    top = sum(_macs(step.A, step.B) for step in _top(out, R))
    return nc * nc * n + n * nc * n + nc * LANES * kept + top + inverse + rows


def _padded(m) -> sp.ImmutableMatrix:
    """m with zero columns up to whole vectors (its rows then start on a vector's bound)."""
    return sp.ImmutableMatrix(m.rows, _up(m.cols), lambda i, j: m[i, j] if j < m.cols else 0)


def _kkt_program(parts: Program) -> Program:
    """The parts as the static function's program, M⁻¹'s, Xᵀ's and R's rows padded to whole vectors."""
    outputs = tuple((o, _padded(m) if o in ("Minv", "XT", "R", "DLinv") else m) for o, m in parts.outputs)
    shapes = tuple((o, (m.rows, m.cols)) for o, m in outputs if o in ALL_PARTS)
    return Program(f"{parts.name}_kkt", parts.inputs, parts.assignments, outputs, "", parts.origin, frozenset(), shapes)


def _rows(name: str, depth: int, width: int) -> str:
    """`name`(w, B, init, out): out = init (or 0) + Σₖ w[k]·B[k] over `depth` rows of B, each
    `width` vectors of LANES doubles: the accumulators stay in registers (GCC's and Clang's vector
    types; plain loops elsewhere)."""
    size = LANES * width
    zero = ", ".join(["0.0"] * LANES)
    return "\n".join(
        [
            f"static void {name}(const double *w, const double *B, const double *init, double *out)",
            "{",
            "    int j, k;",
            "    #if defined(__GNUC__)",
            f"    typedef double v_ __attribute__((vector_size({8 * LANES})));",
            f"    v_ acc[{width}];",
            "    if (init)",
            "        memcpy(acc, init, sizeof acc);",
            "    else",
            f"        for (j = 0; j < {width}; ++j)",
            f"            acc[j] = (v_){{{zero}}};",
            f"    for (k = 0; k < {depth}; ++k) {{",
            "        const double s = w[k];",
            f"        for (j = 0; j < {width}; ++j) {{",
            "            v_ x;",
            f"            memcpy(&x, B + k * {size} + {LANES} * j, sizeof x);",
            "            acc[j] += s * x;",
            "        }",
            "    }",
            "    memcpy(out, acc, sizeof acc);",
            "    #else",
            f"    double acc[{size}];",
            f"    for (j = 0; j < {size}; ++j)",
            "        acc[j] = init ? init[j] : 0.0;",
            f"    for (k = 0; k < {depth}; ++k)",
            f"        for (j = 0; j < {size}; ++j)",
            f"            acc[j] += w[k] * B[k * {size} + j];",
            "    memcpy(out, acc, sizeof acc);",
            "    #endif",
            "}",
            "",
        ]
    )


def _vector_head(signature: str, accumulators: list[str]) -> list[str]:
    """A row kernel's first lines: its signature, then (GCC's and Clang's vector types) the vector
    type, a load register x and the accumulators."""
    return [
        f"static void {signature}",
        "{",
        "    #if defined(__GNUC__)",
        f"    typedef double v_ __attribute__((vector_size({8 * LANES})));",
        "    v_ x, " + ", ".join(accumulators) + ";",
    ]


def _vectors(m) -> list:
    """Per row of m (columns whole vectors), the vectors holding an entry that may be nonzero."""
    return [frozenset(j // LANES for j in range(m.cols) if m[i, j] != 0) for i in range(m.rows)]


def _times(A, B: list, C: list | None = None) -> list:
    """The vectors (`_vectors`) of A·B, or of A·B − C, per row."""
    return [
        frozenset().union(*(B[k] for k in range(A.cols) if A[a, k] != 0), *([C[a]] if C else [])) for a in range(A.rows)
    ]


@dataclass(frozen=True)
class _Step:
    """One `_combined_rows` kernel, out = A·B (− C): A's pattern and its buffer's layout (A[a, k] at
    a·stride + k, or k·stride + a where `transposed`), B's and C's vectors per row, the buffers."""

    name: str
    A: sp.ImmutableMatrix
    stride: int
    transposed: bool
    B: list
    C: list | None
    args: tuple  # the buffers: A, B[, C], out
    note: str


def _top(out: dict, R: list) -> list:
    """The kernels of da = M⁻¹(Jᵀdf − R1) from df = [G −A⁻¹] R (−K⁻¹R's last nc rows, made first
    in F_): with M⁻¹'s factors, W = Jᵀdf − R1 in R1's place, then D⁻¹L⁻¹W and L⁻ᵀ of that (the
    tree's zeros of both factors and of J skipped: Talos on two soles' products 152 k → 119 k
    multiply-adds against −K⁻¹R's first n rows by P's and Gᵀ's, `products`); without them,
    X df − M⁻¹R1."""
    n, nc = out["XT" if "XT" in out else "J"].cols, out["Ainv"].rows
    wn = _up(n)
    F = [frozenset().union(*R)] * nc  # df's rows: every row of R weighted
    R1 = R[:n]
    if "Linv" in out:
        Jt = out["J"].T
        W = _times(Jt, F, R1)
        DL = out["DLinv"]
        Y = _times(DL, W)
        return [
            _Step("jtf", Jt, n, True, F, R1, ("J_", "F_", "R_", "R_"), "W = J^T df - R1, in R1's place"),
            _Step("dl", DL, wn, False, W, None, ("DLinv_", "R_", "Y_"), "D^-1 L^-1 W"),
            _Step("lt", out["Linv"], n, False, Y, None, ("Linv_", "Y_", "R_"), "da = L^-T (D^-1 L^-1 W)"),
        ]
    Minv = out["Minv"]
    Y = _times(Minv, R1)
    return [
        _Step("m", Minv, wn, False, R1, None, ("Minv_", "R_", "Y_"), "M^-1 R1"),
        _Step("xf", out["XT"].T, wn, True, F, Y, ("XT_", "F_", "Y_", "R_"), "da = X df - M^-1 R1"),
    ]


def _combined_rows(
    name: str, A, B: list, width: int, stride: int, transposed: bool = False, C: list | None = None
) -> str:
    """`name`(A, B[, C], out): out's row a = Σₖ A[a, k]·B[k] (− C[a]) over the k where A[a, k] is not
    an exact zero, B's vectors of exact zeros (`B`, `C`: `_vectors`) skipped; B's, C's and out's rows
    `width` vectors, A's buffer as `_Step` says.  M⁻¹ from its factors (`derivatives.minv_factors_spec`:
    A = (L⁻¹)ᵀ, whose row keeps a joint on the joints between it and the root; B = D⁻¹L⁻¹),
    Xᵀ = J M⁻¹ and the derivatives' top rows (`_top`)."""
    rows, depth, size = A.rows, A.cols, width * LANES
    zero = ", ".join(["0.0"] * LANES)
    at = (lambda a, k: k * stride + a) if transposed else (lambda a, k: a * stride + k)
    minus = ", const double *C" if C is not None else ""
    lines = _vector_head(
        f"{name}(const double *A, const double *B{minus}, double *out)", [f"a{j}" for j in range(width)]
    )
    for a in range(rows):
        for j in range(width):
            if C is not None and j in C[a]:
                lines += [f"    memcpy(&x, C + {a * size + LANES * j}, sizeof x);", f"    a{j} = -x;"]
            else:
                lines.append(f"    a{j} = (v_){{{zero}}};")
        for k in range(depth):
            if A[a, k] == 0:
                continue
            for j in sorted(B[k]):
                lines += [f"    memcpy(&x, B + {k * size + LANES * j}, sizeof x);", f"    a{j} += A[{at(a, k)}] * x;"]
        lines += [f"    memcpy(out + {a * size + LANES * j}, &a{j}, sizeof x);" for j in range(width)]
    index = "k * %d + a" % stride if transposed else "a * %d + k" % stride
    lines += [
        "    #else",
        "    int a, j, k;",
        f"    double row[{size}];",
        f"    for (a = 0; a < {rows}; ++a) {{",
        f"        for (j = 0; j < {size}; ++j)",
        f"            row[j] = {'-C[a * %d + j]' % size if C is not None else '0.0'};",
        f"        for (k = 0; k < {depth}; ++k)",
        f"            for (j = 0; j < {size}; ++j)",
        f"                row[j] += A[{index}] * B[k * {size} + j];",
        f"        memcpy(out + a * {size}, row, sizeof row);",
        "    }",
        "    #endif",
        "}",
        "",
    ]
    return "\n".join(lines)


def _macs(A, B: list) -> int:
    """The multiply-adds `_combined_rows` runs (`B`: `_vectors`)."""
    return LANES * sum(len(B[k]) for a in range(A.rows) for k in range(A.cols) if A[a, k] != 0)


def _sparse_rows(name: str, R) -> str:
    """`name`(w, B, out): ROWS rows at once, out[r] = Σₖ w[r·R.rows + k]·B[k] for r < ROWS over the
    rows of R (padded to whole vectors), each row's vectors of exact zeros skipped (a leg's joint
    moves neither another leg's rows nor its contact), unrolled: each vector of B loaded once for
    all the rows, one accumulator per vector of each (plain loops without vector types)."""
    width, depth = R.cols // LANES, R.rows
    zero = ", ".join(["0.0"] * LANES)
    accumulators = [f"a{r}_{j} = {{{zero}}}" for r in range(ROWS) for j in range(width)]
    lines = _vector_head(f"{name}(const double *w, const double *B, double *out)", accumulators)
    for k in range(depth):
        blocks = [j for j in range(width) if any(R[k, LANES * j + t] != 0 for t in range(LANES))]
        for j in blocks:
            lines.append(f"    memcpy(&x, B + {k * R.cols + LANES * j}, sizeof x);")
            lines += [f"    a{r}_{j} += w[{r * depth + k}] * x;" for r in range(ROWS)]
    lines += [
        f"    memcpy(out + {r * R.cols + LANES * j}, &a{r}_{j}, sizeof x);" for r in range(ROWS) for j in range(width)
    ]
    lines += [
        "    #else",
        "    int j, k, r;",
        f"    for (r = 0; r < {ROWS}; ++r) {{",
        f"        for (j = 0; j < {R.cols}; ++j)",
        f"            out[r * {R.cols} + j] = 0.0;",
        f"        for (k = 0; k < {depth}; ++k)",
        f"            for (j = 0; j < {R.cols}; ++j)",
        f"                out[r * {R.cols} + j] += w[r * {depth} + k] * B[k * {R.cols} + j];",
        "    }",
        "    #endif",
        "}",
        "",
    ]
    return "\n".join(lines)


def derivatives_source(model: str, parts: Program, sig: c_emit.Signature, tangents=None) -> str:
    """The static KKT-parts function, the public single-state function `sig` (its doc the parts'),
    its batch loop and its threaded kernel; with `tangents` ((program, plan, columns) of
    `choice.Programs.tangents`) R is made from the parts' partials by the plan's vectors."""
    out = dict(parts.outputs)
    n, nc = out["XT" if "XT" in out else "J"].cols, out["Ainv"].rows
    pattern = _residual_pattern(parts, tangents)
    N, m = n + nc, pattern.cols
    kkt = _kkt_program(parts)
    kkt_out = dict(kkt.outputs)
    f = f"{model}_{sig.name}"
    names = [o for o, _ in sig.outputs]
    first, second = names[0], names[1]
    dz = names[2:]  # d first/dq, d first/dv[, d first/dtau], d second/dq, d second/dv[, d second/dtau]
    half = len(dz) // 2
    single, batch = c_emit._prototypes(model, sig)
    args = [a for a, _ in sig.inputs]
    tau = half == 3  # fdyn: by tau, K^-1 [I; 0] = [P; -G]
    wn, wm = _up(n), _up(m)
    small, large = f"{f}_rows{wn // LANES}x{nc}", f"{f}_rows_R"
    R = _vectors(_padded(pattern))
    helpers = _rows(small, nc, wn // LANES) + "\n" + _sparse_rows(large, _padded(pattern))
    produced = [o for o, _ in kkt.outputs[2:]]  # the parts' outputs after the dynamics' two
    sizes = {o: m.rows * m.cols for o, m in kkt.outputs[2:]}
    fn = -(-nc // ROWS) * ROWS  # df's rows, whole turns of the row kernel
    body = [
        f"    double Minv_[{n * wn}], R_[{N * wm}], F_[{fn * wm}], Y_[{n * wm}];",
        *(f"    double {o}_[{max(1, sizes[o])}];" for o in produced if o not in ("Minv", "R")),
        *([f"    double XT_[{nc * wn}];"] if "J" in out else []),
        f"    double G_[{nc * wn}], p_[{wn}], w_[{ROWS * N}], *w;",
        "    int i, j, c, k, r;",
        f"    {f}_kkt({', '.join(args + [first, second] + [f'{o}_' for o in produced])});",
    ]
    if "Linv" in out:
        helpers += "\n" + _combined_rows(f"{f}_minv", out["Linv"], _vectors(kkt_out["DLinv"]), wn // LANES, n)
        body.append(f"    {f}_minv(Linv_, DLinv_, Minv_);  /* M^-1 = L^-T D^-1 L^-1, in vectors */")
    if "J" in out:
        helpers += "\n" + _combined_rows(f"{f}_xt", out["J"], [set(range(wn // LANES))] * n, wn // LANES, n)
        body.append(f"    {f}_xt(J_, Minv_, XT_);  /* X^T = J M^-1, in vectors */")
    if tangents is not None:
        _, plan, columns = tangents
        turned = [(i, k) for i in range(n) for k in range(3) if out["turn"][i, k] != 0]
        helpers += "\n" + plan.c_source(f"{f}_tangents", columns, wm)
        body += [
            "    memset(R_, 0, sizeof R_);",
            f"    {f}_tangents(partials_, R_);  /* R's columns by the directions, in vectors */",
            *(f"    R_[{i * wm + 3 + k}] = turn_[{3 * i + k}];" for i, k in turned),
        ]
    body += [
        f"    for (c = 0; c < {nc}; ++c)  /* G = A^-1 X^T */",
        f"        {small}(Ainv_ + c * {nc}, XT_, 0, G_ + c * {wn});",
        f"    for (i = 0; i < {nc}; i += {ROWS}) {{  /* df = [G -A^-1] R, rows i, i + 1, ... (K^-1 = [P G^T; -G A^-1]) */",
        f"        for (r = 0; r < {ROWS}; ++r) {{",
        f"            k = i + r, w = w_ + r * {N};",
        f"            if (k < {nc}) {{",
        f"                for (j = 0; j < {n}; ++j)",
        f"                    w[j] = G_[k * {wn} + j];",
        f"                for (j = 0; j < {nc}; ++j)",
        f"                    w[{n} + j] = -Ainv_[k * {nc} + j];",
        "            } else",
        f"                memset(w, 0, {N} * sizeof *w);",
        "        }",
        f"        {large}(w_, R_, F_ + i * {wm});",
        "    }",
    ]
    for step in _top(out, R):
        kernel = f"{f}_{step.name}"
        helpers += "\n" + _combined_rows(kernel, step.A, step.B, wm // LANES, step.stride, step.transposed, step.C)
        body.append(f"    {kernel}({', '.join(step.args)});  /* {step.note} */")
    body += [
        f"    for (k = 0; k < {n}; ++k) {{",
        *(
            [
                f"        for (c = 0; c < {nc}; ++c)  /* P's row k = M^-1's less (X G)'s */",
                f"            w_[c] = -XT_[c * {wn} + k];",
                f"        {small}(w_, G_, Minv_ + k * {wn}, p_);",
            ]
            if tau
            else []
        ),
        f"        for (j = 0; j < {n}; ++j) {{",
        f"            {dz[0]}[k * {n} + j] = R_[k * {wm} + j];",
        f"            {dz[1]}[k * {n} + j] = R_[k * {wm} + {n} + j];",
        *([f"            {dz[2]}[k * {n} + j] = p_[j];"] if tau else []),
        "        }",
        "    }",
        f"    for (c = 0; c < {nc}; ++c)",
        f"        for (j = 0; j < {n}; ++j) {{",
        f"            {dz[half]}[c * {n} + j] = F_[c * {wm} + j];",
        f"            {dz[half + 1]}[c * {n} + j] = F_[c * {wm} + {n} + j];",
        *([f"            {dz[5]}[c * {n} + j] = -G_[c * {wn} + j];"] if tau else []),
        "        }",
    ]
    doc = f"/* {parts.doc} */\n" if parts.doc else ""
    scalar = c_emit.single_source(model, kkt, c_emit.CACHE_SPLIT_ABOVE, static=True, part_size=PART_SIZE)
    scalar += "\n" + helpers
    scalar += f"\n{doc}{single}\n{{\n" + "\n".join(body) + "\n}\n"
    calls = [f"{a} + {k}*k" for a, k in sig.inputs] + [f"{o} + {c_emit._size(s)}*k" for o, s in sig.outputs]
    loop = f"{batch}\n{{\n    for (long k = 0; k < n; ++k)\n        {f}({', '.join(calls)});\n}}\n"
    return scalar + "\n" + loop + "\n" + _threaded(model, sig)


def _threaded(model: str, sig: c_emit.Signature) -> str:
    """The batch kernel: the scalar function state after state, the states split over threads;
    nonzero when an input is NaN or infinite (the kernels' contract)."""
    f = f"{model}_{sig.name}"
    nin = len(sig.inputs)
    checks = [f"in[{a}][i * {k} + {j}] * 0.0" for a, (_, k) in enumerate(sig.inputs) for j in range(k)]
    call = [f"in[{a}] + i * {k}" for a, (_, k) in enumerate(sig.inputs)]
    call += [f"out[{o}] + i * {c_emit._size(s)}" for o, (_, s) in enumerate(sig.outputs)]
    lines = [
        f"static int {f}_range(const double *const *in, double *const *out, long i0, long i1)",
        "{",
        "    long i;",
        "    for (i = i0; i < i1; ++i) {",
        f"        if ({csimd._balanced_sum(checks)} != 0.0)",
        "            return 1;",
        f"        {f}({', '.join(call)});",
        "    }",
        "    return 0;",
        "}",
        "",
        c_emit._simd_prototype(model, sig),
        "{",
        f"    const double *const in[{nin}] = {{{', '.join(a for a, _ in sig.inputs)}}};",
        f"    double *const out[{len(sig.outputs)}] = {{{', '.join(o for o, _ in sig.outputs)}}};",
        f"    return symdyn_parallel_({f}_range, in, out, n, threads);",
        "}",
        "",
    ]
    return "\n".join(lines)


def function_file(model: str, parts: Program, sig: c_emit.Signature, comment: list[str], tangents=None) -> str:
    """One contact derivatives function's C as a file of its own, sealed, as `c.function_file`."""
    split = len(parts.assignments) > c_emit.CACHE_SPLIT_ABOVE
    source = derivatives_source(model, parts, sig, tangents)
    return seal("\n".join([c_emit._comment(comment), *c_emit._preamble(model, split), source]))
