"""C target: a .c/.h pair per model with plain C entry points.

For every function a single-state and two batched entry points, e.g.
`void puma560_tau(const double q[6], const double qd[6], const double qdd[6],
double tau[6])`, `void puma560_tau_batch(int n, const double *q, …)` (the
scalar function state after state) and `void puma560_tau_simd(int n, int
threads, const double *q, …)`: SYMDYN_W states at a time across SIMD lanes
(structure-of-arrays blocks gathered from and scattered to the row-major
(n, size) arrays; W = 8 with AVX-512, 4 with AVX, 2 with SSE2/NEON, else 1),
the blocks split over `threads` POSIX threads; it returns nonzero when an
input is NaN or infinite, tested as the blocks are gathered.  Every lane computes exactly
the scalar function's arithmetic (sin/cos by the same reduction and
polynomials, sign by a branch-free select); a state with a sin/cos argument
outside |x| < 1e5 (or NaN) is recomputed by the scalar function, so the
kernel's results are the scalar function's whatever n and the thread count.
Matrices are row-major (`double M[36]`).  The header lists each function's
signature in a machine-readable comment (`function: M(q: 6) -> M: 6x6`), which
`symdyn.codegen.emit.clib` reads to bind the compiled library to Python.  An output
must not overlap an input: a matrix's entries are stored as they are computed
(`schedule`), before every input is read.
"""

from __future__ import annotations

import re
from dataclasses import dataclass


from ...derivation.program import Program, lower
from . import Bundle, Infix, header_lines, seal
from .csimd import simd_source
from .schedule import by_columns, defined, schedule

__all__ = ["c_source", "h_source", "function_file", "prototypes", "Signature", "read_signatures", "signature"]

ALGEBRA = Infix(
    {"sin": "sin_", "cos": "cos_", "tan": "tan", "sqrt": "sqrt", "sign": "sign_", "abs": "fabs"}, power="pow"
)

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

_SIMD_HELPERS = r"""
/* ---- batched kernels: SYMDYN_W states per SIMD instruction, blocks over threads ---- */
#ifndef SYMDYN_W
#if defined(__AVX512F__)
#define SYMDYN_W 8
#elif defined(__AVX__)
#define SYMDYN_W 4
#elif defined(__SSE2__) || defined(__ARM_NEON) || defined(__aarch64__) || defined(_M_X64)
#define SYMDYN_W 2
#else
#define SYMDYN_W 1
#endif
#endif
/* Build with -fopenmp-simd -DSYMDYN_OPENMP_SIMD (or -fopenmp) to vectorize each
   lane loop for certain; without it, -O3 usually vectorizes it anyway.  gcc leaves
   a loop of over 1000 memory references scalar (a kernel of over ~1000 outputs)
   unless given --param=loop-max-datarefs-for-datadeps=3000 too (symdyn's own
   builds do; its cost grows with the square of the references). */
#if defined(_OPENMP) || defined(SYMDYN_OPENMP_SIMD)
#define SYMDYN_SIMD _Pragma("omp simd")
#else
#define SYMDYN_SIMD
#endif
#if !defined(SYMDYN_NO_THREADS) && (defined(__unix__) || defined(__APPLE__))
#define SYMDYN_THREADS 1
#include <pthread.h>
#endif
#define SYMDYN_MAX_THREADS 256
/* Fewest blocks of SYMDYN_W states worth a thread of their own (starting one costs ~10 us). */
#define SYMDYN_MIN_BLOCKS 512
/* A thread whose run writes at least this many bytes of outputs (more than the last-level cache
   keeps) asks for each block's output lines before the block's arithmetic, with write intent:
   their reads from memory overlap the lane loop instead of stalling its stores (Talos'
   centroidal kernel at 10^5 states on two threads 126-128 -> 119-120 ns a state; 3 % slower in
   the caches, where it is not done). */
#define SYMDYN_AHEAD_BYTES 16000000L
static inline void symdyn_ahead_(const double *dst, long bytes)
{
#if defined(__GNUC__)
    const char *p = (const char *)dst;
    long j;
    for (j = 0; j < bytes; j += 64)
        __builtin_prefetch(p + j, 1, 0);
#else
    (void)dst;
    (void)bytes;
#endif
}

/* A block's output (size rows of SYMDYN_W lanes, src) to m states' rows of size doubles (dst):
   with 8 lanes, eight rows at a time transposed in registers (GCC 12+, Clang), not one double
   per load and store (Talos' centroidal kernel, 327 outputs a state: 220 -> 167 ns a state). */
#include <string.h>
#if SYMDYN_W == 8 && (defined(__clang__) || (defined(__GNUC__) && __GNUC__ >= 12))
#define SYMDYN_TRANSPOSE8_ 1
typedef double symdyn_v8_ __attribute__((vector_size(64)));
#define SYMDYN_SHUFFLE_(a, b, ...) __builtin_shufflevector(a, b, __VA_ARGS__)
static inline void symdyn_transpose8_(const double *src, double *dst, long stride)
{   /* unrolled by hand: at -O2 (a large kernel's unit) gcc keeps arrays of vectors in memory */
    symdyn_v8_ a0, a1, a2, a3, a4, a5, a6, a7, b0, b1, b2, b3, b4, b5, b6, b7, c0, c1, c2, c3, c4, c5, c6, c7, d;
    memcpy(&a0, src, 64), memcpy(&a1, src + 8, 64), memcpy(&a2, src + 16, 64), memcpy(&a3, src + 24, 64);
    memcpy(&a4, src + 32, 64), memcpy(&a5, src + 40, 64), memcpy(&a6, src + 48, 64), memcpy(&a7, src + 56, 64);
    b0 = SYMDYN_SHUFFLE_(a0, a1, 0, 8, 2, 10, 4, 12, 6, 14), b1 = SYMDYN_SHUFFLE_(a0, a1, 1, 9, 3, 11, 5, 13, 7, 15);
    b2 = SYMDYN_SHUFFLE_(a2, a3, 0, 8, 2, 10, 4, 12, 6, 14), b3 = SYMDYN_SHUFFLE_(a2, a3, 1, 9, 3, 11, 5, 13, 7, 15);
    b4 = SYMDYN_SHUFFLE_(a4, a5, 0, 8, 2, 10, 4, 12, 6, 14), b5 = SYMDYN_SHUFFLE_(a4, a5, 1, 9, 3, 11, 5, 13, 7, 15);
    b6 = SYMDYN_SHUFFLE_(a6, a7, 0, 8, 2, 10, 4, 12, 6, 14), b7 = SYMDYN_SHUFFLE_(a6, a7, 1, 9, 3, 11, 5, 13, 7, 15);
    c0 = SYMDYN_SHUFFLE_(b0, b2, 0, 1, 8, 9, 4, 5, 12, 13), c2 = SYMDYN_SHUFFLE_(b0, b2, 2, 3, 10, 11, 6, 7, 14, 15);
    c1 = SYMDYN_SHUFFLE_(b1, b3, 0, 1, 8, 9, 4, 5, 12, 13), c3 = SYMDYN_SHUFFLE_(b1, b3, 2, 3, 10, 11, 6, 7, 14, 15);
    c4 = SYMDYN_SHUFFLE_(b4, b6, 0, 1, 8, 9, 4, 5, 12, 13), c6 = SYMDYN_SHUFFLE_(b4, b6, 2, 3, 10, 11, 6, 7, 14, 15);
    c5 = SYMDYN_SHUFFLE_(b5, b7, 0, 1, 8, 9, 4, 5, 12, 13), c7 = SYMDYN_SHUFFLE_(b5, b7, 2, 3, 10, 11, 6, 7, 14, 15);
    d = SYMDYN_SHUFFLE_(c0, c4, 0, 1, 2, 3, 8, 9, 10, 11), memcpy(dst, &d, 64);
    d = SYMDYN_SHUFFLE_(c1, c5, 0, 1, 2, 3, 8, 9, 10, 11), memcpy(dst + stride, &d, 64);
    d = SYMDYN_SHUFFLE_(c2, c6, 0, 1, 2, 3, 8, 9, 10, 11), memcpy(dst + 2 * stride, &d, 64);
    d = SYMDYN_SHUFFLE_(c3, c7, 0, 1, 2, 3, 8, 9, 10, 11), memcpy(dst + 3 * stride, &d, 64);
    d = SYMDYN_SHUFFLE_(c0, c4, 4, 5, 6, 7, 12, 13, 14, 15), memcpy(dst + 4 * stride, &d, 64);
    d = SYMDYN_SHUFFLE_(c1, c5, 4, 5, 6, 7, 12, 13, 14, 15), memcpy(dst + 5 * stride, &d, 64);
    d = SYMDYN_SHUFFLE_(c2, c6, 4, 5, 6, 7, 12, 13, 14, 15), memcpy(dst + 6 * stride, &d, 64);
    d = SYMDYN_SHUFFLE_(c3, c7, 4, 5, 6, 7, 12, 13, 14, 15), memcpy(dst + 7 * stride, &d, 64);
}
#endif
static inline void symdyn_scatter_(const double *src, int size, double *dst, int m)
{
    int j = 0, k;
#ifdef SYMDYN_TRANSPOSE8_
    if (m == 8)
        for (; j + 8 <= size; j += 8)
            symdyn_transpose8_(src + j * 8, dst + j, size);
#endif
    for (; j < size; ++j)
        for (k = 0; k < m; ++k)
            dst[(long)k * size + j] = src[j * SYMDYN_W + k];
}

/* sign(x) as sign_, as a select. */
static inline double signv_(double x) { return (x > 0.0 ? 1.0 : 0.0) - (x < 0.0 ? 1.0 : 0.0); }

/* 1 when x is outside sincos_'s inline range (|x| < 1e5) or NaN: that lane's
   state is then recomputed by the scalar function (libm). */
static inline double outside_(double x) { return fabs(x) < 1e5 ? 0.0 : 1.0; }

/* sincos_'s arithmetic (same reduction, same polynomials, same quadrant choice:
   the same bits for |x| < 1e5) without its libm branch and without integers,
   so that it vectorizes; the quadrant n mod 4 in floating point.  Accurate
   (the 33-bit pi/2 head makes k * head exact) up to |x| ~ 1.6e6. */
static inline void sincosv_(double x, double *s, double *c)
{
    const double shift = 6755399441055744.0;
    const double k = (x * 0.63661977236758134308 + shift) - shift;
    const double r = (x - k * 1.57079632673412561417e+00) - k * 6.07710050650619224932e-11;
    const double k4 = ((k * 0.25 - 0.375) + shift) - shift;  /* floor(k / 4) */
    const double m = k - 4.0 * k4;                             /* n mod 4: 0, 1, 2, 3 */
    const double hi = m >= 2.0 ? 1.0 : 0.0;                    /* (n & 2) / 2 */
    const double odd = m - 2.0 * hi, even = 1.0 - odd;         /* n & 1 */
    const double hc = (m == 1.0 || m == 2.0) ? 1.0 : 0.0;      /* ((n + 1) & 2) / 2 */
    const double z = r * r;
    const double sr = r + r * z * (-1.66666666666666324348e-01 + z * (8.33333333332248946124e-03
        + z * (-1.98412698298579493134e-04 + z * (2.75573137070700676789e-06
        + z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))));
    const double hz = 0.5 * z, w = 1.0 - hz;
    const double cr = w + (((1.0 - w) - hz) + z * z * (4.16666666666666019037e-02
        + z * (-1.38888888888741095749e-03 + z * (2.48015872894767294178e-05
        + z * (-2.75573143513906633035e-07 + z * (2.08757232129817482790e-09
        + z * -1.13596475577881948265e-11))))));
    *s = (1.0 - 2.0 * hi) * (sr * even + cr * odd);
    *c = (1.0 - 2.0 * hc) * (cr * even + sr * odd);
}

static inline double sinv_(double x) { double s, c; sincosv_(x, &s, &c); return s; }
static inline double cosv_(double x) { double s, c; sincosv_(x, &s, &c); return c; }

/* s[j], c[j] = sin, cos of x[j] for j < m: sincosv_ in a loop the compiler vectorizes, then
   libm where |x[j]| >= 1e5 (or NaN), so the same values as a sincos_ call each.  Inlined (m
   known: Talos' centroidal 5 % faster), but called where several small functions share a
   translation unit (SYMDYN_TRIG_LOOP_CALLED: one copy, the Panda's task space compiles 12 %
   faster, runs as fast). */
#if defined(SYMDYN_TRIG_LOOP_CALLED) && defined(__GNUC__)
#define SYMDYN_TRIG_LOOP_ static __attribute__((noinline, unused))
#else
#define SYMDYN_TRIG_LOOP_ static inline
#endif
SYMDYN_TRIG_LOOP_ void sincos_loop_(const double *x, int m, double *s, double *c)
{
    int j;
    for (j = 0; j < m; ++j)
        sincosv_(x[j], &s[j], &c[j]);
    for (j = 0; j < m; ++j)
        if (!(fabs(x[j]) < 1e5)) {
            s[j] = sin(x[j]);
            c[j] = cos(x[j]);
        }
}

/* A kernel over the states [i0, i1) of its arrays (in: inputs, out: outputs); nonzero
   when an input there is NaN or infinite. */
typedef int (*symdyn_range_)(const double *const *in, double *const *out, long i0, long i1);
typedef struct {
    symdyn_range_ f;
    const double *const *in;
    double *const *out;
    long i0, i1;
    int nonfinite;
} symdyn_job_;

static void *symdyn_run_(void *p)
{
    symdyn_job_ *j = (symdyn_job_ *)p;
    j->nonfinite = j->f(j->in, j->out, j->i0, j->i1);
    return NULL;
}

/* f over n states in `threads` contiguous runs of whole blocks (fewer for a small n;
   threads < 1 means 1).  Every state is computed by the same lane code whatever
   the split, so the results do not depend on the thread count.  Nonzero when an
   input is NaN or infinite (then the outputs are unspecified). */
static int symdyn_parallel_(symdyn_range_ f, const double *const *in, double *const *out, long n, int threads)
{
    const long blocks = (n + SYMDYN_W - 1) / SYMDYN_W;
    long b0 = 0, most = blocks / SYMDYN_MIN_BLOCKS;
    symdyn_job_ job[SYMDYN_MAX_THREADS];
    int t, nonfinite = 0;
    if (threads > SYMDYN_MAX_THREADS)
        threads = SYMDYN_MAX_THREADS;
    if (threads > most)
        threads = (int)most;
    if (threads <= 1)
        return n > 0 ? f(in, out, 0, n) : 0;
    for (t = 0; t < threads; ++t) {
        const long b1 = blocks * (t + 1) / threads;
        job[t].f = f;
        job[t].in = in;
        job[t].out = out;
        job[t].i0 = b0 * SYMDYN_W;
        job[t].i1 = b1 * SYMDYN_W < n ? b1 * SYMDYN_W : n;
        b0 = b1;
    }
#ifdef SYMDYN_THREADS
    {
        pthread_t tid[SYMDYN_MAX_THREADS];
        int started[SYMDYN_MAX_THREADS];
        for (t = 1; t < threads; ++t)
            started[t] = pthread_create(&tid[t], NULL, symdyn_run_, &job[t]) == 0;
        symdyn_run_(&job[0]);
        for (t = 1; t < threads; ++t) {
            if (started[t])
                pthread_join(tid[t], NULL);
            else
                symdyn_run_(&job[t]);
        }
    }
#else
    for (t = 0; t < threads; ++t)
        symdyn_run_(&job[t]);
#endif
    for (t = 0; t < threads; ++t)
        nonfinite |= job[t].nonfinite;
    return nonfinite;
}
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
        outputs = tuple(
            (o.strip(), tuple(int(d) for d in s.strip().split("x"))) for o, s in (x.split(":") for x in outs.split(","))
        )
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
    arrays = [f"const double *{a}" for a, _ in sig.inputs] + [f"double *{o}" for o, _ in sig.outputs]
    return single, f"void {model}_{sig.name}_batch({', '.join(['int n'] + arrays)})"


def _simd_prototype(model: str, sig: Signature) -> str:
    """The SIMD kernel's prototype: n states on `threads` threads; it returns nonzero
    when an input is NaN or infinite (the outputs are then unspecified)."""
    arrays = [f"const double *{a}" for a, _ in sig.inputs] + [f"double *{o}" for o, _ in sig.outputs]
    return f"int {model}_{sig.name}_simd({', '.join(['int n', 'int threads'] + arrays)})"


def _comment(lines: list[str]) -> str:
    return "/*\n" + "".join(f" * {line}".rstrip() + "\n" for line in lines) + " */\n"


def h_source(bundle: Bundle) -> str:
    """The header: provenance, signatures, and the prototypes."""
    guard = f"SYMDYN_{bundle.name.upper()}_H"
    sigs = [signature(p) for p in bundle.programs]
    lines = (
        header_lines(bundle, "c")
        + [
            "",
            "Matrices are row-major; *_batch loops over n states stored contiguously;",
            "an output must not overlap an input (a matrix's entries are stored as they",
            "are computed, before every input is read);",
            "*_simd runs SYMDYN_W states per SIMD instruction on `threads` threads,",
            "with the results of the scalar function, and returns nonzero when an",
            "input is NaN or infinite (the outputs are then unspecified).",
            "signatures:",
        ]
        + [f"  {s.line()}" for s in sigs]
    )
    parts = [
        _comment(lines),
        f"#ifndef {guard}\n#define {guard}\n",
        '#ifdef __cplusplus\nextern "C" {\n#endif\n',
        f"#define {bundle.name.upper()}_NDOF {bundle.n}",
        *(
            [f"#define {bundle.name.upper()}_NQ {bundle.nq}", f"#define {bundle.name.upper()}_NV {bundle.nv}"]
            if bundle.floating
            else []
        ),
        f'#define {bundle.name.upper()}_FINGERPRINT "{bundle.fingerprint}"',
        f'#define {bundle.name.upper()}_SYMDYN_VERSION "{bundle.version}"\n',
    ]
    for p, sig in zip(bundle.programs, sigs):
        single, batch = _prototypes(bundle.name, sig)
        if p.doc:
            parts.append(f"/* {p.doc} */")
        parts.append(f"{single};\n{batch};\n{_simd_prototype(bundle.name, sig)};\n")
    parts.append("#ifdef __cplusplus\n}\n#endif\n#endif")
    return seal("\n".join(parts) + "\n")


def _text(expr) -> str:
    return lower(expr, ALGEBRA)[0]


#: Sine/cosine pairs of the joint coordinates, at least this many in a function, are computed
#: in one loop over q that gcc vectorizes (`_trig_loop`); fewer stay sincos_ calls where they stand.
TRIG_LOOP_MIN = 4


def _trig_loop(items: list, inputs) -> tuple[list[str], dict]:
    """The sin/cos pairs of plain coordinates of the first input (q), computed together: the
    preamble's sincos_loop_ over q[a..b] (sincosv_ in a loop the compiler vectorizes, the same bits
    as sincos_ below |x| < 1e5; libm where a coordinate lies beyond), then each pair read from it where it stood.  With `_zeros`'
    memset: Talos' 30-joint M 1002 → 769 ns, τ 801 → 664 ns (docs/whole_robots.md).  Returns (the
    loop's lines, {item index: its lines})."""
    if not inputs:
        return [], {}
    arg, syms = inputs[0]
    index = {sym: k for k, sym in enumerate(syms)}
    pairs = {i: index[x] for i, (x, _, _) in enumerate(items) if x is not None and x in index}
    if len(pairs) < TRIG_LOOP_MIN:
        return [], {}
    lo, hi = min(pairs.values()), max(pairs.values())
    m = hi - lo + 1
    loop = [
        f"    double sin_{arg}_[{m}], cos_{arg}_[{m}];",
        f"    sincos_loop_({arg} + {lo}, {m}, sin_{arg}_, cos_{arg}_);",
    ]
    reads = {
        i: [f"    const double {items[i][1].name} = sin_{arg}_[{k - lo}], {items[i][2].name} = cos_{arg}_[{k - lo}];"]
        for i, k in pairs.items()
    }
    return loop, reads


#: A single-state function of more assignments than this is emitted as parts of PART_SIZE
#: assignments each, `static` functions that gcc does not inline, passing the values later
#: parts use through one array: gcc's register allocation grows faster than linearly with a
#: function's size (a 10-joint arm's fdyn_derivatives, 3844 lines in one function: 6.6 s at
#: -O3, 6.1 s at -O1, 51 % of it in LRA), its parts compile in about linear time.  Seconds
#: of gcc -O3 as one function / parts of 400 / 200 / 100 lines: G1's arm + waist, C (1953
#: lines) 1.74 / 1.71 / 0.86 / 0.78, fdyn_derivatives (3848) 7.3 / 2.5 / 2.25 / 2.08;
#: xArm7's tau_derivatives (1260 lines, long ones) 1.75 whole, 0.77 in parts of 100.  Run
#: times differ by less than the noise (±5 %).  Files a person reads (`generate`'s, and
#: generated/, pinned byte for byte) keep a function whole up to SPLIT_ABOVE lines (every
#: function of the shipped arms: the largest has 1692); the lazy C target's per-function
#: files, which only a compiler reads, are split above CACHE_SPLIT_ABOVE.
SPLIT_ABOVE = 1700
CACHE_SPLIT_ABOVE = 600
PART_SIZE = 100

_NOINLINE = (
    "#if defined(__GNUC__)\n#define SYMDYN_NOINLINE __attribute__((noinline))\n#else\n#define SYMDYN_NOINLINE\n#endif\n"
)


def _statements(item) -> list[str]:
    """The C statements of one `sincos_pairs` item."""
    x, a, b = item
    if x is None:
        return [f"    const double {a.name} = {_text(b)};"]
    return [f"    double {a.name}, {b.name};", f"    sincos_({_text(x)}, &{a.name}, &{b.name});"]


def _used(item) -> set:
    x, a, b = item
    return (b if x is None else x).free_symbols


def _step_lines(steps, reads: dict, zeroed: set) -> list[str]:
    """The statements of `schedule` steps (item i read from the trigonometric loop where `reads`
    has it), each followed by its stores."""
    lines = []
    for i, step in enumerate(steps):
        lines += reads[i] if i in reads else _statements(step.item)
        lines += _store_lines(step.stores, zeroed)
    return lines


def _parts(model: str, p: Program, qualifier: str = "", size: int | None = None) -> tuple:
    """A large program's single-state body as parts of `size` `schedule` steps: (the part
    functions' source, the body's statements that call them, its lines after the calls, the
    reads those lines need); `qualifier` precedes each part (CUDA's `SYMDYN_HD`); `size` defaults
    to PART_SIZE.  A part stores the output entries its steps complete; the entries stored at
    the end (a program of vectors) are the body's, read from the parts' array."""
    size = size or PART_SIZE
    plan = schedule(p)
    zero, zeroed = _zeros(p, bool(qualifier))
    blocks = [plan.steps[i : i + size] for i in range(0, len(plan.steps), size)]
    inputs = {s for _, syms in p.inputs for s in syms}
    home = {sym: k for k, block in enumerate(blocks) for step in block for sym in defined(step.item)}

    def needs(block, k) -> set:  # what a block's items and stores read (its first: the head's too)
        stores = [e for step in block for *_, e in step.stores] + [e for *_, e in (plan.head if k == 0 else ())]
        return set().union(*(_used(step.item) for step in block), *(e.free_symbols for e in stores))

    later: set = set()  # values a later part (or the body's stores) reads
    for k, block in enumerate(blocks):
        later |= {sym for sym in needs(block, k) if sym in home and home[sym] < k}
    for *_, e in plan.tail:
        later |= {sym for sym in e.free_symbols if sym in home}
    slot = {sym: i for i, sym in enumerate(sorted(later, key=lambda x: (home[x], x.name)))}
    outs = [o for o, _ in p.outputs] if any(step.stores for step in plan.steps) or plan.head else []
    params = ", ".join([f"const double *{a}" for a, _ in p.inputs] + [f"double *{o}" for o in outs] + ["double *w_"])
    source, calls = [], []
    for k, block in enumerate(blocks):
        used = needs(block, k)
        loop, reads = _trig_loop([step.item for step in block], p.inputs)
        statements = (_store_lines(plan.head, zeroed) if k == 0 else []) + _step_lines(block, reads, zeroed)
        reads = [
            f"    const double {sym.name} = {a}[{j}];"
            for a, syms in p.inputs
            for j, sym in enumerate(syms)
            if sym in used
        ]
        reads += [
            f"    const double {sym.name} = w_[{slot[sym]}];"
            for sym in sorted(used - inputs, key=str)
            if sym in home and home[sym] < k
        ]
        body = _near_use(reads, loop + statements)
        body += [f"    w_[{slot[sym]}] = {sym.name};" for step in block for sym in defined(step.item) if sym in slot]
        named = set(re.findall(r"\b[A-Za-z_]\w*", "\n".join(body)))  # a parameter the part leaves alone: said so
        body = [f"    (void){x};" for x in [a for a, _ in p.inputs] + outs + ["w_"] if x not in named] + body
        name = f"{model}_{p.name}_part{k + 1}"
        source.append(f"{qualifier}static SYMDYN_NOINLINE void {name}({params})\n{{\n" + "\n".join(body) + "\n}\n")
        calls.append(f"    {name}({', '.join([a for a, _ in p.inputs] + outs + ['w_'])});")
    used = set().union(*(e.free_symbols for *_, e in plan.tail))
    reads = [
        f"    const double {sym.name} = {a}[{j}];" for a, syms in p.inputs for j, sym in enumerate(syms) if sym in used
    ]
    reads += [f"    const double {sym.name} = w_[{slot[sym]}];" for sym in sorted(used & set(slot), key=str)]
    early = by_columns(p)  # the zeros before the parts store, or with the body's stores
    body = [f"    double w_[{max(1, len(slot))}];", *(zero if early else []), *calls]
    return "\n".join(source) + "\n", body, (([] if early else zero) + _store_lines(plan.tail, zeroed)), reads


def _near_use(reads: list[str], lines: list[str]) -> list[str]:
    """The lines, each read (`const double x = w_[k];`) just before the first line naming x, the
    unused dropped.  Read all at the top, gcc loads them all first and spills them: Talos' contact
    derivatives, whose KKT parts end with 2 150 reads and 2 730 stores, 5.3 → 4.7 µs a call for
    those parts (`symdyn bench --task-space talos-contact-derivatives`: 12.6 → 12.0 µs)."""
    pending = {r.split()[2]: r for r in reads}
    out = []
    for line in lines:
        out += [pending.pop(name) for name in re.findall(r"\b[A-Za-z_]\w*", line) if name in pending]
        out.append(line)
    return out


#: An output with at least this many exact zeros, a quarter of it or more, is zeroed by one memset
#: and only its other entries stored; fewer are stored one by one (gcc joins the runs into vector
#: stores): memset is a call (every vector register saved around it) and glibc's rep stosb.  Scalar
#: calls, ns: Talos' 36 × 36 M (643 zeros) 442 by memset, 484 by stores; Solo 12's M (128 zeros)
#: 117 and 88; its four feet's `frame_kinematics` (252 zeros in J) 186 and 131.
MEMSET_MIN = 512


def _read(reads: list[str], lines: list[str]) -> list[str]:
    """The input reads (`const double x = q[k];`) whose name the lines use: a coordinate only the
    trigonometric loop needs is read there, from the array."""
    text = "\n".join(lines)
    return [r for r in reads if re.search(rf"\b{r.split()[2]}\b", text)]


def _zeros(p: Program, device: bool = False) -> tuple[list[str], set]:
    """(the lines that zero each output of many exact zeros, `MEMSET_MIN`, by one memset, or on a
    device, where no memset is declared, by a loop; the outputs so zeroed, whose zeros are then
    not stored one by one)."""
    lines, zeroed = [], set()
    for out, mat in p.outputs:
        zeros = sum(1 for e in mat if e == 0)
        if zeros < MEMSET_MIN or 4 * zeros < len(mat):
            continue
        zeroed.add(out)
        if device:
            lines += [
                f"    for (int z_ = 0; z_ < {len(mat)}; ++z_)  /* its {zeros} exact zeros */",
                f"        {out}[z_] = 0.0;",
            ]
        else:
            lines.append(f"    memset({out}, 0, sizeof(double) * {len(mat)});  /* its {zeros} exact zeros */")
    return lines, zeroed


def _store_lines(entries, zeroed: set) -> list[str]:
    """The statements that store output entries (output, index, expression), the zeros of an
    output already zeroed left out."""
    return [f"    {o}[{k}] = {_text(e)};" for o, k, e in entries if not (o in zeroed and e == 0)]


def single_source(
    model: str,
    p: Program,
    split_above: int | None = None,
    qualifier: str = "",
    static: bool = False,
    part_size: int | None = None,
) -> str:
    """The single-state C function of one program in `schedule`'s order (one of more than
    `split_above` assignments, default SPLIT_ABOVE, calls its parts of `part_size`, default
    PART_SIZE), each function preceded by `qualifier` (the CUDA target's `SYMDYN_HD `, whose
    device code has no memset); `static`: a helper of the public function after it (`ckkt`'s KKT
    parts)."""
    split_above = SPLIT_ABOVE if split_above is None else split_above
    sig = signature(p)
    single, _ = _prototypes(model, sig)
    used = p.used_inputs()
    if len(p.assignments) > split_above:
        parts, body, after, reads = _parts(model, p, qualifier, part_size)
        body += _near_use(reads, after)
    else:
        parts, body = "", []
        plan = schedule(p)
        zero, zeroed = _zeros(p, bool(qualifier))
        loop, reads = _trig_loop([step.item for step in plan.steps], p.inputs)
        early = by_columns(p)  # the zeros first, or with the stores at the end
        program = (zero if early else []) + _store_lines(plan.head, zeroed) + _step_lines(plan.steps, reads, zeroed)
        program = loop + program + ([] if early else zero) + _store_lines(plan.tail, zeroed)
        text = "\n".join(program)
        near = []
        for a, syms in p.inputs:
            read = [f"    const double {s.name} = {a}[{k}];" for k, s in enumerate(syms) if s in used]
            read = _read(read, program)
            if not read and not re.search(rf"\b{a}\b", text):  # not even by the trigonometric loop
                body.append(f"    (void){a};  /* unused: this {p.name} does not depend on {a} */")
            near += read
        # a matrix's entries are stored as they are computed: each coordinate read where first used,
        # not all held from the top (outputs never overlap inputs: the header says so, and the
        # bindings refuse such an out=, `clib.check_out` and glue.c's `separate`)
        body += _near_use(near, program) if early else near + program
    doc = f"/* {p.doc} */\n" if p.doc else ""
    return parts + f"{doc}{qualifier}{'static ' if static else ''}{single}\n{{\n" + "\n".join(body) + "\n}\n"


def function_source(model: str, p: Program, split_above: int | None = None) -> str:
    """The single-state and batched C functions of one program (`single_source`, the loop over
    states, the SIMD kernel)."""
    sig = signature(p)
    _, batch = _prototypes(model, sig)
    calls = [f"{a} + {k}*k" for a, k in sig.inputs] + [f"{o} + {_size(s)}*k" for o, s in sig.outputs]
    loop = f"{batch}\n{{\n    for (long k = 0; k < n; ++k)\n        {model}_{p.name}({', '.join(calls)});\n}}\n"
    simd = simd_source(model, p, sig, _simd_prototype(model, sig))
    return single_source(model, p, split_above) + "\n" + loop + "\n" + simd


def _preamble(model: str, split: bool) -> list[str]:
    """What every C file of a model starts with after its comment: includes, the helpers."""
    parts = ["#include <math.h>", "#include <string.h>", f'#include "{model}.h"\n', _HELPERS + _SIMD_HELPERS]
    return parts + ([_NOINLINE] if split else [])


def c_source(bundle: Bundle) -> str:
    """The whole .c file of one model."""
    parts = [_comment(header_lines(bundle, "c"))]
    parts += _preamble(bundle.name, any(len(p.assignments) > SPLIT_ABOVE for p in bundle.programs))
    parts += [function_source(bundle.name, p) for p in bundle.programs]
    return seal("\n".join(parts))


def function_file(model: str, p: Program, comment: list[str]) -> str:
    """One function's C as a file of its own, sealed: `comment`, the preamble and the
    function (the lazy C target keeps one per function; `cunits.function_units` makes its
    translation units from it as from a whole file), split above CACHE_SPLIT_ABOVE lines."""
    split = len(p.assignments) > CACHE_SPLIT_ABOVE
    parts = [_comment(comment), *_preamble(model, split), function_source(model, p, CACHE_SPLIT_ABOVE)]
    return seal("\n".join(parts))


def prototypes(model: str, sigs: list[Signature]) -> str:
    """The prototypes of the functions `sigs` (single, batched, SIMD), as a header lists them."""
    lines = []
    for sig in sigs:
        single, batch = _prototypes(model, sig)
        lines += [f"{single};", f"{batch};", f"{_simd_prototype(model, sig)};"]
    return "\n".join(lines) + "\n"
