/* Two ceilings of this machine for the batched benchmark (symdyn/bench/batched.py),
   compiled with the flags of the generated kernels:

   ceiling_muladd  `threads` threads each run `iters` rounds of x = x * a + b on
                   CHAINS independent doubles held in registers (enough chains to
                   hide the mul-add latency at any SIMD width): 2 operations per
                   element and round — the compute peak of straight-line code.
   ceiling_copy    `threads` threads copy their share of n doubles from src to dst,
                   `rounds` times: 16 bytes moved per element (read and write, as
                   STREAM counts a copy) — the memory bandwidth of a batch.
   ceiling_store   `threads` threads write their share of n doubles with plain
                   stores, as the generated kernels write their outputs (each line
                   read before it is written, where memcpy's large copies bypass
                   the caches): 8 bytes per element — the bandwidth of a batch's
                   outputs.

   Both return a checksum so that the compiler keeps the work. */
#include <pthread.h>
#include <string.h>

#define CHAINS 64
#define MAXTHREADS 256

typedef struct {
    long iters, n, rounds;
    const double *src;
    double *dst;
    double sum;
} job_t;

static void *muladd_job(void *p)
{
    job_t *j = (job_t *)p;
    double x[CHAINS], sum = 0.0;
    const double a = 0.9999999, b = 1e-9;
    long i;
    int k;
    for (k = 0; k < CHAINS; ++k)
        x[k] = 1.0 + k;
    for (i = 0; i < j->iters; ++i) {
#pragma omp simd
        for (k = 0; k < CHAINS; ++k)
            x[k] = x[k] * a + b;
    }
    for (k = 0; k < CHAINS; ++k)
        sum += x[k];
    j->sum = sum;
    return NULL;
}

static void *copy_job(void *p)
{
    job_t *j = (job_t *)p;
    long r;
    for (r = 0; r < j->rounds; ++r)
        memcpy(j->dst, j->src, (size_t)j->n * sizeof(double));
    j->sum = j->dst[j->n - 1];
    return NULL;
}

static void *store_job(void *p)
{
    job_t *j = (job_t *)p;
    long r, i;
    for (r = 0; r < j->rounds; ++r)
        for (i = 0; i < j->n; ++i)
            j->dst[i] = (double)(i + r);  /* not a constant: no memset, whose large sizes bypass the caches */
    j->sum = j->dst[j->n - 1];
    return NULL;
}

static double run(void *(*f)(void *), job_t *job, int threads)
{
    pthread_t tid[MAXTHREADS];
    double sum = 0.0;
    int t;
    for (t = 1; t < threads; ++t)
        pthread_create(&tid[t], NULL, f, &job[t]);
    f(&job[0]);
    for (t = 1; t < threads; ++t)
        pthread_join(tid[t], NULL);
    for (t = 0; t < threads; ++t)
        sum += job[t].sum;
    return sum;
}

double ceiling_muladd(int threads, long iters)
{
    job_t job[MAXTHREADS];
    int t;
    threads = threads < 1 ? 1 : threads > MAXTHREADS ? MAXTHREADS : threads;
    for (t = 0; t < threads; ++t)
        job[t].iters = iters;
    return run(muladd_job, job, threads);
}

/* f on `threads` threads (clamped to 1 … MAXTHREADS), each over its share of the n doubles of
   src (NULL: none) and dst, `rounds` times. */
static double shared(void *(*f)(void *), int threads, const double *src, double *dst, long n, long rounds)
{
    job_t job[MAXTHREADS];
    int t;
    threads = threads < 1 ? 1 : threads > MAXTHREADS ? MAXTHREADS : threads;
    for (t = 0; t < threads; ++t) {
        const long i0 = n * t / threads, i1 = n * (t + 1) / threads;
        job[t].src = src ? src + i0 : NULL;
        job[t].dst = dst + i0;
        job[t].n = i1 - i0;
        job[t].rounds = rounds;
    }
    return run(f, job, threads);
}

double ceiling_copy(int threads, const double *src, double *dst, long n, long rounds)
{
    return shared(copy_job, threads, src, dst, n, rounds);
}

double ceiling_store(int threads, double *dst, long n, long rounds)
{
    return shared(store_job, threads, NULL, dst, n, rounds);
}
