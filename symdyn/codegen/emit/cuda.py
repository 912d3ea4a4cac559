"""CUDA target: `<model>.cu` and `<model>_cuda.h`, the C target's program one state per GPU thread.

Each function is the C target's single-state function, unchanged (the same statements, the same
sin/cos reduction, the same operation counts), declared `SYMDYN_HD` (`__host__ __device__` under
nvcc or NVRTC, nothing elsewhere) with C linkage, and one kernel per function over a batch of
row-major (N, size) arrays, one state per thread: `<model>_<f>_kernel(long n, int *bad, const
double *q, …, double *out)` and `<model>_<f>_kernel_f32` on float32 arrays (float64 arithmetic:
the memory traffic halves, the values are the float64 ones rounded once).

Coalescing: a block of B threads copies its B states' inputs, contiguous in memory, into shared
memory with consecutive threads reading consecutive doubles, each thread computes its state from
there into shared memory, and the block copies its outputs out the same way (a thread writing its
own 49 entries of M straight to memory was 10x slower in our probe).  B is the largest multiple of
32, at most 256, whose rows fit 48 KB of shared memory (the limit every card grants without
asking); a function whose row (inputs and outputs of one state) exceeds 192 doubles reads and
writes its rows directly (`direct`), float64 only.  `*bad` is set when an input is NaN or infinite.

Without CUDA (`__CUDACC__` undefined) the file is plain C++: the kernels are replaced by
`<model>_<f>_host(long n, int block, …)`, which run the same three phases (load, compute, store)
for every thread of every block in turn, so that the arithmetic and the staging's indexing are
tested on any machine (tests/test_cuda.py)."""

from __future__ import annotations

from dataclasses import dataclass

from ...derivation.program import Program
from . import Bundle, header_lines, seal
from .c import _HELPERS, SPLIT_ABOVE, Signature, _comment, _size, signature, single_source

__all__ = ["cu_source", "h_source", "Launch", "launch", "HEADER_SUFFIX"]

#: The header's name after the model's: `<model>_cuda.h`.
HEADER_SUFFIX = "_cuda.h"
#: Doubles of shared memory a block may stage: 48 KB, what every card grants without opting in.
SHARED_DOUBLES = 6144
MAX_BLOCK = 256
#: Threads per block of a direct kernel (rows too large to stage).
DIRECT_BLOCK = 128

_PRELUDE = r"""#if defined(__CUDACC__)
#define SYMDYN_HD __host__ __device__
#define SYMDYN_NOINLINE __noinline__
#else
#define SYMDYN_HD
#if defined(__GNUC__)
#define SYMDYN_NOINLINE __attribute__((noinline))
#else
#define SYMDYN_NOINLINE
#endif
#endif
#if !defined(__CUDACC_RTC__)
#include <math.h>
#include <stdlib.h>
#endif
"""

_DEVICE_HELPERS = r"""
/* s[j], c[j] = sin, cos of x[j] for j < m (the C target's sincos_loop_, by sincos_ each). */
SYMDYN_HD static inline void sincos_loop_(const double *x, int m, double *s, double *c)
{
    for (int j = 0; j < m; ++j)
        sincos_(x[j], &s[j], &c[j]);
}

/* Copy `count` values from g into s as doubles, thread t of B taking every B-th (consecutive
   threads, consecutive addresses); nonzero when one of them is NaN or infinite. */
template <typename T>
SYMDYN_HD static inline int symdyn_load_(const T *g, double *s, int count, int t, int B)
{
    double check = 0.0;
    for (int j = t; j < count; j += B) {
        const double x = (double)g[j];
        s[j] = x;
        check += x * 0.0;
    }
    return check != 0.0;
}

/* Copy `count` doubles from s to g (rounded to T), thread t of B taking every B-th. */
template <typename T>
SYMDYN_HD static inline void symdyn_store_(const double *s, T *g, int count, int t, int B)
{
    for (int j = t; j < count; j += B)
        g[j] = (T)s[j];
}
"""


@dataclass(frozen=True)
class Launch:
    """How one function's kernel runs: `block` threads per block, `shared` bytes of dynamic
    shared memory per block (0: direct, rows read and written by their thread)."""

    block: int
    shared: int

    @property
    def staged(self) -> bool:
        return self.shared > 0


def _row(sig: Signature) -> int:
    return sum(k for _, k in sig.inputs) + sum(_size(s) for _, s in sig.outputs)


def launch(sig: Signature) -> Launch:
    """The block size and shared memory of one function's kernel (see the module's doc)."""
    row = _row(sig)
    block = min(MAX_BLOCK, SHARED_DOUBLES // row // 32 * 32)
    if block < 32:
        return Launch(DIRECT_BLOCK, 0)
    return Launch(block, block * row * 8)


def _params(sig: Signature, real: str) -> list[str]:
    return [f"const {real} *{a}" for a, _ in sig.inputs] + [f"{real} *{o}" for o, _ in sig.outputs]


def _names(sig: Signature) -> list[str]:
    return [a for a, _ in sig.inputs] + [o for o, _ in sig.outputs]


def _staged_step(f: str, sig: Signature) -> list[str]:
    """The three phases of a staged kernel's thread t of block b, as one function template."""
    lines = [
        "template <typename T>",
        f"SYMDYN_HD static void {f}_step_(int phase_, long n_, long b_, int t_, int B_, double *sh_, int *bad_, "
        + ", ".join(_params(sig, "T"))
        + ")",
        "{",
        "    const long i0_ = b_ * (long)B_;",
        "    const int m_ = n_ - i0_ < B_ ? (int)(n_ - i0_) : B_;",
    ]
    previous, size = "sh_", 0
    for name, k in [*sig.inputs, *((o, _size(s)) for o, s in sig.outputs)]:
        lines.append(f"    double *{name}_ = {previous}{f' + B_ * {size}' if size else ''};")
        previous, size = f"{name}_", k
    loads = " | ".join(f"symdyn_load_({a} + i0_ * {k}, {a}_, m_ * {k}, t_, B_)" for a, k in sig.inputs) or "0"
    calls = [f"{a}_ + t_ * {k}" for a, k in sig.inputs] + [f"{o}_ + t_ * {_size(s)}" for o, s in sig.outputs]
    lines += [
        "    if (phase_ == 0) {",
        f"        if ({loads})",
        "            *bad_ = 1;",
        "    } else if (phase_ == 1) {",
        "        if (t_ < m_)",
        f"            {f}({', '.join(calls)});",
        "    } else {",
    ]
    lines += [f"        symdyn_store_({o}_, {o} + i0_ * {_size(s)}, m_ * {_size(s)}, t_, B_);" for o, s in sig.outputs]
    lines += ["    }", "}", ""]
    return lines


def _direct_step(f: str, sig: Signature) -> list[str]:
    """A direct kernel's thread: its inputs copied (and checked) into local arrays, its outputs
    written by the scalar function straight into the batch's rows."""
    lines = [
        f"SYMDYN_HD static void {f}_step_(long n_, long b_, int t_, int B_, int *bad_, "
        + ", ".join(_params(sig, "double"))
        + ")",
        "{",
        "    const long i_ = b_ * (long)B_ + t_;",
        "    if (i_ >= n_)",
        "        return;",
    ]
    lines += [f"    double {a}_[{k}];" for a, k in sig.inputs]
    loads = " | ".join(f"symdyn_load_({a} + i_ * {k}, {a}_, {k}, 0, 1)" for a, k in sig.inputs) or "0"
    calls = [f"{a}_" for a, _ in sig.inputs] + [f"{o} + i_ * {_size(s)}" for o, s in sig.outputs]
    lines += [f"    if ({loads})", "        *bad_ = 1;", f"    {f}({', '.join(calls)});", "}", ""]
    return lines


def _kernels(f: str, sig: Signature, how: Launch) -> list[str]:
    """The kernels (under CUDA) or their host emulations (plain C++) of one function."""
    names = ", ".join(_names(sig))
    kinds = [("", "double"), ("_f32", "float")] if how.staged else [("", "double")]
    cuda, host = [], []
    for suffix, real in kinds:
        params = ", ".join(["long n_", "int *bad_", *_params(sig, real)])
        cuda.append(f'extern "C" __global__ void {f}_kernel{suffix}({params})')
        host_params = ", ".join(["long n_", "int block_", *_params(sig, real)])
        host.append(f'extern "C" int {f}_host{suffix}({host_params})')
        if how.staged:
            cuda += [
                "{",
                "    extern __shared__ double sh_[];",
                *(
                    f"    {'__syncthreads();' + chr(10) + '    ' if phase else ''}"
                    f"{f}_step_<{real}>({phase}, n_, blockIdx.x, threadIdx.x, blockDim.x, sh_, bad_, {names});"
                    for phase in range(3)
                ),
                "}",
                "",
            ]
            host += [
                "{",
                f"    double *sh_ = (double *)malloc(sizeof(double) * (size_t)block_ * {_row(sig)});",
                "    int bad_ = 0;",
                "    if (!sh_)",
                "        return -1;",
                "    for (long b_ = 0; b_ * block_ < n_; ++b_)",
                "        for (int phase_ = 0; phase_ < 3; ++phase_)",
                "            for (int t_ = 0; t_ < block_; ++t_)",
                f"                {f}_step_<{real}>(phase_, n_, b_, t_, block_, sh_, &bad_, {names});",
                "    free(sh_);",
                "    return bad_;",
                "}",
                "",
            ]
        else:
            cuda += ["{", f"    {f}_step_(n_, blockIdx.x, threadIdx.x, blockDim.x, bad_, {names});", "}", ""]
            host += [
                "{",
                "    int bad_ = 0;",
                "    for (long b_ = 0; b_ * block_ < n_; ++b_)",
                "        for (int t_ = 0; t_ < block_; ++t_)",
                f"            {f}_step_(n_, b_, t_, block_, &bad_, {names});",
                "    return bad_;",
                "}",
                "",
            ]
    return ["#if defined(__CUDACC__)", *cuda, "#else", *host, "#endif", ""]


def function_source(model: str, p: Program) -> str:
    """One function's kernel machinery (the scalar function comes before, in the C block)."""
    sig = signature(p)
    how = launch(sig)
    f = f"{model}_{p.name}"
    step = _staged_step(f, sig) if how.staged else _direct_step(f, sig)
    return "\n".join(step + _kernels(f, sig, how))


def cu_source(bundle: Bundle) -> str:
    """The whole .cu file of one model: the helpers, the scalar functions (C linkage), the kernels."""
    helpers = _HELPERS.replace("static inline", "SYMDYN_HD static inline")
    parts = [_comment(header_lines(bundle, "cuda")), _PRELUDE, helpers, _DEVICE_HELPERS]
    parts.append('extern "C" {\n')
    parts += [single_source(bundle.name, p, SPLIT_ABOVE, "SYMDYN_HD ") for p in bundle.programs]
    parts.append('}  /* extern "C" */\n')
    parts += [function_source(bundle.name, p) for p in bundle.programs]
    return seal("\n".join(parts))


def h_source(bundle: Bundle) -> str:
    """The header: provenance, signatures, each kernel's launch (block, shared bytes), prototypes."""
    guard = f"SYMDYN_{bundle.name.upper()}_CUDA_H"
    sigs = [signature(p) for p in bundle.programs]
    lines = header_lines(bundle, "cuda") + [
        "",
        "Matrices are row-major; <f>_kernel runs one state per thread over n states of row-major",
        "(n, size) arrays, launched with <F>_CUDA_BLOCK threads per block and <F>_CUDA_SHARED bytes",
        "of dynamic shared memory; it sets *bad to 1 when an input is NaN or infinite.",
        "signatures:",
        *(f"  {s.line()}" for s in sigs),
    ]
    parts = [_comment(lines), f"#ifndef {guard}\n#define {guard}\n", _PRELUDE]
    parts.append(f"#define {bundle.name.upper()}_NDOF {bundle.n}")
    parts.append(f'#define {bundle.name.upper()}_FINGERPRINT "{bundle.fingerprint}"\n')
    for p, sig in zip(bundle.programs, sigs):
        how = launch(sig)
        f = f"{bundle.name}_{p.name}"
        ins = [f"const double {a}[{k}]" for a, k in sig.inputs]
        outs = [f"double {o}[{_size(s)}]" for o, s in sig.outputs]
        parts.append(f"#define {f.upper()}_CUDA_BLOCK {how.block}\n#define {f.upper()}_CUDA_SHARED {how.shared}")
        parts.append(f'extern "C" SYMDYN_HD void {f}({", ".join(ins + outs)});')
        kinds = [("", "double"), ("_f32", "float")] if how.staged else [("", "double")]
        parts.append("#if defined(__CUDACC__)")
        parts += [
            f'extern "C" __global__ void {f}_kernel{s}({", ".join(["long n_", "int *bad_", *_params(sig, r)])});'
            for s, r in kinds
        ]
        parts.append("#else")
        parts += [
            f'extern "C" int {f}_host{s}({", ".join(["long n_", "int block_", *_params(sig, r)])});' for s, r in kinds
        ]
        parts.append("#endif\n")
    parts.append("#endif")
    return seal("\n".join(parts) + "\n")
