/*
 * symdyn C timing harness: ns per call of a generated model's functions, no
 * Python involved.  The C counterpart of pin_peer.cpp (same
 * loop: a pool of K states cycled, one volatile sink per call, median of
 * `reps` repetitions of `ncalls` calls).  symdyn.bench compiles it with the
 * generated model source as a separate translation unit (the functions are
 * called as a library user calls them, never inlined):
 *
 *   cc -O3 -march=native -DMODEL=puma560 -DNDOF=6 -DMODEL_HEADER='"puma560.h"'
 *      [-DWITH_CASADI] harness.c puma560.c [casadi_rnea.c] -lm
 *
 * A floating base: -DNQ=<NAME>_NQ -DNV=<NAME>_NV as well (q has NQ entries,
 * qd, qdd, tau and the outputs NV; both default to NDOF).
 *
 * Run: harness STATES NCALLS REPS [FUNCTION ...]
 * STATES: K (a power of two) states, each q, qd, qdd, tau as NQ + 3*NV doubles.
 * Prints "time NAME NS" per function, then "check NAME v..." with its
 * outputs at state 3 (compared with symdyn.reference by the caller).
 * With -DWITH_CASADI the function "casadi_rnea" (a CasADi-generated plain
 * RNEA, arg/res pointer-array calling convention) is timed as well; with
 * -DWITH_DERIVATIVES the model's tau_derivatives, fdyn_derivatives (checked
 * by dtau/dq and dqdd/dq) and Minv.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include MODEL_HEADER
#ifdef WITH_CASADI
#include "casadi_rnea.h"
#endif

#ifndef NQ
#define NQ NDOF
#endif
#ifndef NV
#define NV NDOF
#endif

#define CAT_(a, b) a##_##b
#define CAT(a, b) CAT_(a, b)
#define FN(f) CAT(MODEL, f)

static double now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return 1e9 * (double)t.tv_sec + (double)t.tv_nsec;
}

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, n, sizeof *v, by_value);
    return v[n / 2];
}

static int wanted(int argc, char **argv, const char *name)
{
    int i;
    if (argc <= 4)
        return 1;
    for (i = 4; i < argc; ++i)
        if (!strcmp(argv[i], name))
            return 1;
    return 0;
}

static void check(const char *name, const double *out, int size)
{
    int i;
    printf("check %s", name);
    for (i = 0; i < size; ++i)
        printf(" %.17g", out[i]);
    printf("\n");
}

/* Bytes that shift the stack in repetition r, spread over a page: where a generated function's
   stack arrays fall beside its outputs modulo 4 kB changes its time by up to 2x (stores and
   loads 4 kB apart wait on each other), so each repetition runs at another placement and the
   median is over placements, not one placement's luck. */
#define PLACEMENT(r) (1 + 64 * ((r) * 37 % 64))

/* Time CALL (which writes out[]) over the state pool; then its outputs at state 3. */
#define TIME(NAME, SIZE, CALL)                                                  \
    if (wanted(argc, argv, NAME)) {                                             \
        int r;                                                                  \
        long i, k;                                                              \
        for (r = 0; r < reps; ++r) {                                            \
            volatile char pad[PLACEMENT(r)]; /* each repetition's stack apart */ \
            double t0 = (pad[0] = 0, now_ns());                                 \
            for (i = 0; i < ncalls; ++i) {                                      \
                k = i & (K - 1);                                                \
                CALL;                                                           \
                sink += out[0];                                                 \
            }                                                                   \
            v[r] = (now_ns() - t0) / (double)ncalls;                            \
        }                                                                       \
        printf("time %s %.3f\n", NAME, median(v, reps));                       \
        k = 3;                                                                  \
        CALL;                                                                   \
        check(NAME, out, SIZE);                                                 \
    }

int main(int argc, char **argv)
{
    enum { W = NQ + 3 * NV };
    static double out[NV * NV];
    volatile double sink = 0.0;
    double *S, *v;
    long K, ncalls, size;
    int reps;
    FILE *fh;
    if (argc < 4) {
        fprintf(stderr, "usage: %s STATES NCALLS REPS [FUNCTION ...]\n", argv[0]);
        return 2;
    }
    ncalls = atol(argv[2]);
    reps = atoi(argv[3]);
    fh = fopen(argv[1], "rb");
    if (!fh || ncalls < 1 || reps < 1) {
        fprintf(stderr, "cannot read %s, or NCALLS/REPS not positive\n", argv[1]);
        return 2;
    }
    fseek(fh, 0, SEEK_END);
    size = ftell(fh) / (long)sizeof(double);
    rewind(fh);
    K = size / W;
    if (K < 4 || (K & (K - 1)) || K * W != size) {
        fprintf(stderr, "%s: %ld doubles, expected K*%d with K a power of two >= 4\n", argv[1], size, W);
        return 2;
    }
    S = malloc(size * sizeof *S);
    v = malloc(reps * sizeof *v);
    if (!S || !v || fread(S, sizeof *S, size, fh) != (size_t)size) {
        fprintf(stderr, "cannot read %s\n", argv[1]);
        return 2;
    }
    fclose(fh);
#define Q (S + k * W)
#define QD (S + k * W + NQ)
#define QDD (S + k * W + NQ + NV)
#define TAU (S + k * W + NQ + 2 * NV)
    printf("states %ld calls %ld reps %d\n", K, ncalls, reps);
    TIME("tau", NV, FN(tau)(Q, QD, QDD, out))
    TIME("M", NV * NV, FN(M)(Q, out))
#ifndef WITHOUT_C  /* code generated without its C function (a subset of the functions) */
    TIME("C", NV * NV, FN(C)(Q, QD, out))
#endif
    TIME("Cqd", NV, FN(Cqd)(Q, QD, out))
    TIME("G", NV, FN(G)(Q, out))
    TIME("fdyn", NV, FN(fdyn)(Q, QD, TAU, out))
#ifdef WITH_DERIVATIVES
    {
        static double a[NV], b[NV * NV], c[NV * NV];
        TIME("tau_derivatives", NV * NV, FN(tau_derivatives)(Q, QD, QDD, a, out, b))
        TIME("fdyn_derivatives", NV * NV, FN(fdyn_derivatives)(Q, QD, TAU, a, out, b, c))
        TIME("Minv", NV * NV, FN(Minv)(Q, out))
    }
#endif
#ifdef WITH_CASADI
    {
        casadi_int sz_arg, sz_res, sz_iw, sz_w;
        const double **arg;
        double **res, *w;
        casadi_int *iw;
        casadi_rnea_work(&sz_arg, &sz_res, &sz_iw, &sz_w);
        arg = malloc((sz_arg + 3) * sizeof *arg);
        res = malloc((sz_res + 1) * sizeof *res);
        iw = malloc((sz_iw + 1) * sizeof *iw);
        w = malloc((sz_w + 1) * sizeof *w);
        res[0] = out;
        TIME("casadi_rnea", NV, (arg[0] = Q, arg[1] = QD, arg[2] = QDD, casadi_rnea(arg, res, iw, w, 0)))
        free(arg);
        free(res);
        free(iw);
        free(w);
    }
#endif
    free(S);
    free(v);
    return 0;
}
