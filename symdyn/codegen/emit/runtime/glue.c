/* symdyn's C binding: a CPython extension that binds every generated model's functions.
 *
 * It holds no model code: each `Function` object keeps a generated function's contract (its
 * inputs' sizes, its outputs' shapes) and, once a call needs them, the addresses of its compiled
 * single-state code and SIMD kernel, which it asks symdyn's Python (`builder`) for.  Calls follow
 * `symdyn.codegen.contract`: shapes, broadcasting over leading axes, keyword arguments, out=,
 * threads=, NaN refused by name.  Built once per Python, NumPy, compiler and flags by
 * `symdyn.codegen.emit.clib` with the module's name defined: -DSYMDYN_MODULE=<name> (or a
 * `#define` in front), as `tests/test_c_runtime.py` compiles it on its own.
 */
#ifndef SYMDYN_MODULE
#error "define SYMDYN_MODULE, the extension module's name (-DSYMDYN_MODULE=_symdyn_glue_...)"
#endif
#define SYMDYN_STR2(x) #x
#define SYMDYN_STR(x) SYMDYN_STR2(x)
#define SYMDYN_CAT2(a, b) a##b
#define SYMDYN_CAT(a, b) SYMDYN_CAT2(a, b)

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>
#include <limits.h>
#include <stdint.h>
#include <float.h>
#include <math.h>
#include <string.h>

#define MAXARGS 8

/* threads= when the call gives none: set by symdyn (the cores this process may use). */
static int default_threads = 1;
#define MAXTHREADS 256
/* One generated function: what the contract needs to know of it, and the addresses of
   its compiled code (`void f(in..., out...)` for one state, `int f_simd(n, threads,
   in..., out...)` for a batch), NULL until a call needs them: the call then asks
   `builder(name, "scalar" or "simd")` (symdyn's Python, which compiles the function's
   translation unit into the cache or finds it there) for the address and keeps it.
   The Python function is a builtin whose self is this object and whose PyMethodDef
   is `def` (CPython drops the function's reference to its self last, for this). */
typedef struct {
    PyObject_HEAD
    PyMethodDef def;
    PyObject *name, *doc, *inputs, *builder;   /* str, str, ((name, size), ...), callable */
    const char *cname;
    int nin, nout;
    npy_intp in_size[MAXARGS];
    int quaternion;   /* the input that is a free base's q (its quaternion at 3:7 must not be zero), or -1 */
    int out_nd[MAXARGS];
    npy_intp out_dims[MAXARGS][3];
    void *one, *many;
} spec_t;

/* The address of the compiled code from the builder into s->one (many = 0) or
   s->many; 0, or -1 with the builder's exception (a compiler error) set. */
static int bind(spec_t *s, int many)
{
    void *p;
    PyObject *r = PyObject_CallFunction(s->builder, "Os", s->name, many ? "simd" : "scalar");
    if (!r)
        return -1;
    p = PyLong_AsVoidPtr(r);
    Py_DECREF(r);
    if (!p && many && !PyErr_Occurred())
        return 0;   /* its kernel is compiling in the background: the scalar code serves meanwhile */
    if (!p) {
        if (!PyErr_Occurred())
            PyErr_Format(PyExc_RuntimeError, "%s(): the builder gave no address", s->cname);
        return -1;
    }
    if (many)
        s->many = p;
    else
        s->one = p;
    return 0;
}

/* f(a[0], ..., a[k-1]): a function's single-state entry point at address f. */
static void call_one(void *f, int k, double *const *a)
{
    switch (k) {
    case 1: ((void (*)(double *))f)(a[0]); break;
    case 2: ((void (*)(double *, double *))f)(a[0], a[1]); break;
    case 3: ((void (*)(double *, double *, double *))f)(a[0], a[1], a[2]); break;
    case 4: ((void (*)(double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3]); break;
    case 5: ((void (*)(double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4]); break;
    case 6: ((void (*)(double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5]); break;
    case 7: ((void (*)(double *, double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5], a[6]); break;
    case 8: ((void (*)(double *, double *, double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]); break;
    case 9: ((void (*)(double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8]); break;
    case 10: ((void (*)(double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9]); break;
    case 11: ((void (*)(double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10]); break;
    case 12: ((void (*)(double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11]); break;
    case 13: ((void (*)(double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12]); break;
    case 14: ((void (*)(double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13]); break;
    case 15: ((void (*)(double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14]); break;
    case 16: ((void (*)(double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14], a[15]); break;
    }
}

/* f(n, threads, a[0], ..., a[k-1]): a function's SIMD kernel at address f. */
static int call_many(void *f, int n, int threads, int k, double *const *a)
{
    switch (k) {
    case 1: return ((int (*)(int, int, double *))f)(n, threads, a[0]);
    case 2: return ((int (*)(int, int, double *, double *))f)(n, threads, a[0], a[1]);
    case 3: return ((int (*)(int, int, double *, double *, double *))f)(n, threads, a[0], a[1], a[2]);
    case 4: return ((int (*)(int, int, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3]);
    case 5: return ((int (*)(int, int, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4]);
    case 6: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5]);
    case 7: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5], a[6]);
    case 8: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]);
    case 9: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8]);
    case 10: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9]);
    case 11: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10]);
    case 12: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11]);
    case 13: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12]);
    case 14: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13]);
    case 15: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14]);
    case 16: return ((int (*)(int, int, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *, double *))f)(n, threads, a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14], a[15]);
    }
    return 0;
}
/* The scalar code state after state, while the batch kernel compiles (`_Units.background`): the
   same values as single calls; nonzero (nothing computed) when an input is NaN or infinite. */
static int call_loop(const spec_t *s, npy_intp n, double *const *all)
{
    double *p[2 * MAXARGS];
    npy_intp k, z, size[2 * MAXARGS];
    int i, d, m = s->nin + s->nout;
    for (i = 0; i < s->nin; ++i)
        size[i] = s->in_size[i];
    for (i = 0; i < s->nout; ++i)
        for (size[s->nin + i] = 1, d = 0; d < s->out_nd[i]; ++d)
            size[s->nin + i] *= s->out_dims[i][d];
    for (i = 0; i < s->nin; ++i)
        for (z = 0; z < n * size[i]; ++z)
            if (!isfinite(all[i][z]))
                return 1;
    for (k = 0; k < n; ++k) {
        for (i = 0; i < m; ++i)
            p[i] = all[i] + k * size[i];
        call_one(s->one, m, p);
    }
    return 0;
}

/* Whether the call is the common one: positional C-contiguous double arrays
   (..., size) of one leading shape with room for the outputs' dimensions, finite
   when they hold one state (a batch's kernel tests its inputs as it gathers them). */
static int plain(const spec_t *s, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames, int out_nd)
{
    int i, nd = 0;
    if (nargs != s->nin || (kwnames && PyTuple_GET_SIZE(kwnames)))
        return 0;
    for (i = 0; i < s->nin; ++i) {
        PyArrayObject *a = (PyArrayObject *)args[i];
        npy_intp size, k;
        const double *x;
        if (!PyArray_CheckExact(args[i]) || PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISCARRAY_RO(a))
            return 0;
        if (i == 0) {
            nd = PyArray_NDIM(a);
            if (nd == 0 || nd - 1 + out_nd > NPY_MAXDIMS)
                return 0;
        } else if (PyArray_NDIM(a) != nd
                   || memcmp(PyArray_DIMS(a), PyArray_DIMS((PyArrayObject *)args[0]), (nd - 1) * sizeof(npy_intp)))
            return 0;
        if (PyArray_DIMS(a)[nd - 1] != s->in_size[i])
            return 0;
        size = PyArray_SIZE(a);
        x = (const double *)PyArray_DATA(a);
        if (i == s->quaternion)   /* |q|² below DBL_MIN (2/|q|² would overflow): the contract names it */
            for (k = 0; k + 7 <= size; k += s->in_size[i])
                if (x[k + 3] * x[k + 3] + x[k + 4] * x[k + 4] + x[k + 5] * x[k + 5] + x[k + 6] * x[k + 6] < DBL_MIN)
                    return 0;
        if (nd > 1)
            continue;
        for (k = 0; k < size; ++k)
            if (!isfinite(x[k]))
                return 0;
    }
    return 1;
}

/* Any other call goes through symdyn.codegen.contract.arguments, the contract
   every target shares: (checked arrays of one leading shape, that shape), or an error. */
static PyObject *checked(const spec_t *s, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames, int out_nd)
{
    static PyObject *arguments = NULL;
    PyObject *pos = NULL, *kw = NULL, *result = NULL;
    Py_ssize_t i, nkw = kwnames ? PyTuple_GET_SIZE(kwnames) : 0;
    if (!arguments) {
        PyObject *module = PyImport_ImportModule("symdyn.codegen.contract");
        if (!module)
            return NULL;
        arguments = PyObject_GetAttrString(module, "arguments");
        Py_DECREF(module);
        if (!arguments)
            return NULL;
    }
    pos = PyTuple_New(nargs);
    kw = PyDict_New();
    if (!pos || !kw)
        goto done;
    for (i = 0; i < nargs; ++i) {
        Py_INCREF(args[i]);
        PyTuple_SET_ITEM(pos, i, args[i]);
    }
    for (i = 0; i < nkw; ++i)
        if (PyDict_SetItem(kw, PyTuple_GET_ITEM(kwnames, i), args[nargs + i]) < 0)
            goto done;
    result = PyObject_CallFunction(arguments, "OOOOiO", s->name, s->inputs, pos, kw, NPY_MAXDIMS - out_nd,
                                   s->quaternion < 0 ? Py_None
                                                     : PyTuple_GET_ITEM(PyTuple_GET_ITEM(s->inputs, s->quaternion), 0));
done:
    Py_XDECREF(pos);
    Py_XDECREF(kw);
    return result;
}

/* The keywords out= and threads= taken out of a call: the other keywords' names
   in *kw (a new tuple, or NULL when none is left), the arguments' values in vals
   (positional, then those keywords'); 0, or -1 with an exception set. */
static int extras(const char *name, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames,
                  PyObject **vals, PyObject **kw, PyObject **outarg, int *threads)
{
    Py_ssize_t i, nkw = kwnames ? PyTuple_GET_SIZE(kwnames) : 0, kept = 0;
    *kw = NULL;
    *outarg = NULL;
    *threads = default_threads;
    if (nargs + nkw > 2 * MAXARGS) {
        PyErr_Format(PyExc_TypeError, "%s(): too many arguments", name);
        return -1;
    }
    for (i = 0; i < nargs; ++i)
        vals[i] = args[i];
    for (i = 0; i < nkw; ++i) {
        PyObject *key = PyTuple_GET_ITEM(kwnames, i), *v = args[nargs + i];
        if (PyUnicode_CompareWithASCIIString(key, "out") == 0) {
            *outarg = v == Py_None ? NULL : v;
        } else if (PyUnicode_CompareWithASCIIString(key, "threads") == 0) {
            long t;
            if (v == Py_None)
                continue;
            t = PyLong_AsLong(v);
            if (t == -1 && PyErr_Occurred())
                return -1;
            if (t < 1) {
                PyErr_Format(PyExc_ValueError, "%s(): threads must be at least 1, got %ld", name, t);
                return -1;
            }
            *threads = t > MAXTHREADS ? MAXTHREADS : (int)t;
        } else {
            vals[nargs + kept++] = v;
        }
    }
    if (kept == 0)
        return 0;
    *kw = PyTuple_New(kept);
    if (!*kw)
        return -1;
    for (i = 0, kept = 0; i < nkw; ++i) {
        PyObject *key = PyTuple_GET_ITEM(kwnames, i);
        if (PyUnicode_CompareWithASCIIString(key, "out") && PyUnicode_CompareWithASCIIString(key, "threads")) {
            Py_INCREF(key);
            PyTuple_SET_ITEM(*kw, kept++, key);
        }
    }
    return 0;
}

/* The caller's array for output j (new reference), or NULL with a ValueError:
   exactly an ndarray, float64, C-contiguous, aligned and writeable, of the output's shape. */
static PyObject *given_out(const spec_t *s, PyObject *outarg, int j, int nd, const npy_intp *dims)
{
    PyObject *o = outarg;
    PyArrayObject *a;
    if (s->nout > 1) {
        if (!PyTuple_Check(outarg) || PyTuple_GET_SIZE(outarg) != s->nout) {
            PyErr_Format(PyExc_ValueError, "%s(): out must be a tuple of %d arrays, one per output", s->cname, s->nout);
            return NULL;
        }
        o = PyTuple_GET_ITEM(outarg, j);
    }
    a = (PyArrayObject *)o;
    if (!PyArray_Check(o) || PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISCARRAY(a) || PyArray_NDIM(a) != nd
        || memcmp(PyArray_DIMS(a), dims, nd * sizeof(npy_intp))) {
        PyErr_Format(PyExc_ValueError, "%s(): out%s must be a C-contiguous writeable float64 array of the "
                     "output's shape (leading dimensions of the inputs, then the output's own)",
                     s->cname, s->nout > 1 ? "[k]" : "");
        return NULL;
    }
    Py_INCREF(o);
    return o;
}

/* Whether two arrays' bytes overlap. */
static int overlap(PyObject *a, PyObject *b)
{
    const uintptr_t x = (uintptr_t)PyArray_BYTES((PyArrayObject *)a), y = (uintptr_t)PyArray_BYTES((PyArrayObject *)b);
    const npy_intp xn = PyArray_NBYTES((PyArrayObject *)a), yn = PyArray_NBYTES((PyArrayObject *)b);
    return xn > 0 && yn > 0 && x < y + (uintptr_t)yn && y < x + (uintptr_t)xn;
}

/* 0 when no out= array shares memory with an input or another output, else -1 with a
   ValueError naming the first pair: a function stores a matrix's entries as it computes
   them, before it has read every input (symdyn.codegen.emit.schedule). */
static int separate(const spec_t *s, PyObject *const *args, PyObject *const *out)
{
    int i, j;
    for (j = 0; j < s->nout; ++j) {
        for (i = 0; i < s->nin; ++i)
            if (overlap(out[j], args[i])) {
                PyErr_Format(PyExc_ValueError, "%s(): out%s shares memory with the input %S: give it an array of "
                             "its own", s->cname, s->nout > 1 ? "[k]" : "",
                             PyTuple_GET_ITEM(PyTuple_GET_ITEM(s->inputs, i), 0));
                return -1;
            }
        for (i = 0; i < j; ++i)
            if (overlap(out[j], out[i])) {
                PyErr_Format(PyExc_ValueError, "%s(): out[%d] and out[%d] share memory: give each an array of its "
                             "own", s->cname, i, j);
                return -1;
            }
    }
    return 0;
}

/* One output array per output, shaped leading + its own shape (or the caller's out=);
   single or batched call (threads= threads, default: the cores this process may use). */
static PyObject *call(spec_t *s, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames)
{
    PyObject *out[MAXARGS] = {0};
    PyObject *normal = NULL, *result = NULL, *vals[2 * MAXARGS], *kw = NULL, *outarg = NULL;
    double *pin[MAXARGS], *pout[MAXARGS], *all[2 * MAXARGS];
    npy_intp dims[NPY_MAXDIMS], count = 1;
    int lead_nd, out_nd = 0, i, j, threads;
    for (j = 0; j < s->nout; ++j)   /* an output has lead_nd + out_nd dimensions: they must fit dims */
        out_nd = s->out_nd[j] > out_nd ? s->out_nd[j] : out_nd;
    if (kwnames && PyTuple_GET_SIZE(kwnames)) {
        if (extras(s->cname, args, nargs, kwnames, vals, &kw, &outarg, &threads) < 0)
            return NULL;
        args = vals;
        kwnames = kw;
    } else {
        threads = default_threads;
    }
    if (!plain(s, args, nargs, kwnames, out_nd)) {
        normal = checked(s, args, nargs, kwnames, out_nd);
        Py_CLEAR(kw);
        if (!normal)
            return NULL;
        args = &PyTuple_GET_ITEM(PyTuple_GET_ITEM(normal, 0), 0);
    }
    lead_nd = PyArray_NDIM((PyArrayObject *)args[0]) - 1;
    memcpy(dims, PyArray_DIMS((PyArrayObject *)args[0]), lead_nd * sizeof(npy_intp));
    for (i = 0; i < lead_nd; ++i)
        count *= dims[i];
    for (i = 0; i < s->nin; ++i)
        pin[i] = (double *)PyArray_DATA((PyArrayObject *)args[i]);
    if (count > INT_MAX) {
        PyErr_Format(PyExc_ValueError, "%s(): %zd states, at most %d per call", s->cname, (Py_ssize_t)count, INT_MAX);
        goto done;
    }
    for (j = 0; j < s->nout; ++j) {
        memcpy(dims + lead_nd, s->out_dims[j], s->out_nd[j] * sizeof(npy_intp));
        out[j] = outarg ? given_out(s, outarg, j, lead_nd + s->out_nd[j], dims)
                        : PyArray_SimpleNew(lead_nd + s->out_nd[j], dims, NPY_DOUBLE);
        if (!out[j])
            goto done;
        pout[j] = (double *)PyArray_DATA((PyArrayObject *)out[j]);
    }
    if (outarg && separate(s, args, out) < 0)
        goto done;
    for (i = 0; i < s->nin; ++i)
        all[i] = pin[i];
    for (j = 0; j < s->nout; ++j)
        all[s->nin + j] = pout[j];
    if (lead_nd == 0) {
        if (!s->one && bind(s, 0) < 0)
            goto done;
        call_one(s->one, s->nin + s->nout, all);
    } else if (count > 0) {
        int nonfinite;
        if (!s->many && bind(s, 1) < 0)
            goto done;
        if (!s->many && !s->one && bind(s, 0) < 0)
            goto done;
        Py_BEGIN_ALLOW_THREADS
        nonfinite = s->many ? call_many(s->many, (int)count, threads, s->nin + s->nout, all) : call_loop(s, count, all);
        Py_END_ALLOW_THREADS
        if (nonfinite) {   /* the contract's check names the argument (a checked call is finite) */
            PyObject *why = normal ? NULL : checked(s, args, nargs, kwnames, out_nd);
            if (!PyErr_Occurred())
                PyErr_Format(PyExc_ValueError, "%s(): an input contains NaN or infinity", s->cname);
            Py_XDECREF(why);
            goto done;
        }
    }
    if (s->nout == 1) {
        result = out[0];
        out[0] = NULL;
    } else {
        result = PyTuple_New(s->nout);
        for (j = 0; result && j < s->nout; ++j) {
            PyTuple_SET_ITEM(result, j, out[j]);
            out[j] = NULL;
        }
    }
done:
    for (j = 0; j < MAXARGS; ++j)
        Py_XDECREF(out[j]);
    Py_XDECREF(normal);
    Py_XDECREF(kw);
    return result;
}

static PyObject *py_set_threads(PyObject *self, PyObject *arg)
{
    long t = PyLong_AsLong(arg);
    (void)self;
    if (t == -1 && PyErr_Occurred())
        return NULL;
    default_threads = t < 1 ? 1 : t > MAXTHREADS ? MAXTHREADS : (int)t;
    Py_RETURN_NONE;
}

static void spec_dealloc(spec_t *s)
{
    Py_XDECREF(s->name);
    Py_XDECREF(s->doc);
    Py_XDECREF(s->inputs);
    Py_XDECREF(s->builder);
    Py_TYPE(s)->tp_free((PyObject *)s);
}

static PyObject *py_call(PyObject *self, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames)
{
    return call((spec_t *)self, args, nargs, kwnames);
}

/* _bind(kind, address): the compiled code of kind "scalar" or "simd" at address. */
static PyObject *spec_bind(spec_t *s, PyObject *args)
{
    const char *kind;
    PyObject *address;
    void *p;
    if (!PyArg_ParseTuple(args, "sO", &kind, &address))
        return NULL;
    p = PyLong_AsVoidPtr(address);
    if (!p && PyErr_Occurred())
        return NULL;
    if (strcmp(kind, "scalar") == 0)
        s->one = p;
    else if (strcmp(kind, "simd") == 0)
        s->many = p;
    else
        return PyErr_Format(PyExc_ValueError, "_bind: kind must be 'scalar' or 'simd', got %s", kind);
    Py_RETURN_NONE;
}

/* _bound(): the kinds bound so far, a tuple of "scalar" and "simd". */
static PyObject *spec_bound(spec_t *s, PyObject *unused)
{
    (void)unused;
    if (s->one && s->many)
        return Py_BuildValue("(ss)", "scalar", "simd");
    if (s->one || s->many)
        return Py_BuildValue("(s)", s->one ? "scalar" : "simd");
    return PyTuple_New(0);
}

static PyMethodDef spec_methods[] = {
    {"_bind", (PyCFunction)spec_bind, METH_VARARGS, "_bind(kind, address): bind compiled code"},
    {"_bound", (PyCFunction)spec_bound, METH_NOARGS, "the kinds of compiled code bound"},
    {NULL, NULL, 0, NULL}
};

static PyTypeObject spec_type = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = SYMDYN_STR(SYMDYN_MODULE) ".Function",
    .tp_basicsize = sizeof(spec_t),
    .tp_dealloc = (destructor)spec_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "a generated function's table: its shapes and compiled code",
    .tp_methods = spec_methods,
};

/* _function(name, doc, inputs, outputs, builder[, quaternion]): a new Python function for a
   generated function of inputs ((name, size), ...) and outputs' shapes ((rows,),
   (rows, cols) or (m, rows, cols), ...), unbound: its first call asks builder(name, kind) for the address
   of its compiled code; quaternion: the index of the input that is a free base's q, or -1 (default).
   Every call makes a new table, so that two models of one name never share their code. */
static PyObject *py_function(PyObject *self, PyObject *args)
{
    PyObject *name, *doc, *inputs, *outputs, *builder, *fn;
    spec_t *s;
    Py_ssize_t i;
    int quaternion = -1;
    (void)self;
    if (!PyArg_ParseTuple(args, "UUO!O!O|i", &name, &doc, &PyTuple_Type, &inputs, &PyTuple_Type, &outputs, &builder,
                          &quaternion))
        return NULL;
    if (PyTuple_GET_SIZE(inputs) < 1 || PyTuple_GET_SIZE(inputs) > MAXARGS || PyTuple_GET_SIZE(outputs) < 1
        || PyTuple_GET_SIZE(outputs) > MAXARGS)
        return PyErr_Format(PyExc_ValueError, "_function: 1 to %d inputs and outputs", MAXARGS);
    if (quaternion < -1 || quaternion >= PyTuple_GET_SIZE(inputs))
        return PyErr_Format(PyExc_ValueError, "_function: quaternion %d is not an input's index", quaternion);
    s = PyObject_New(spec_t, &spec_type);
    if (!s)
        return NULL;
    memset((char *)s + sizeof(PyObject), 0, sizeof(spec_t) - sizeof(PyObject));
    Py_INCREF(name);
    Py_INCREF(doc);
    Py_INCREF(inputs);
    Py_INCREF(builder);
    s->name = name;
    s->doc = doc;
    s->inputs = inputs;
    s->builder = builder;
    s->nin = (int)PyTuple_GET_SIZE(inputs);
    s->nout = (int)PyTuple_GET_SIZE(outputs);
    s->quaternion = quaternion;
    s->cname = PyUnicode_AsUTF8(name);
    if (!s->cname || !PyUnicode_AsUTF8(doc))
        goto fail;
    for (i = 0; i < s->nin; ++i) {
        PyObject *pair = PyTuple_GET_ITEM(inputs, i);
        if (!PyTuple_Check(pair) || PyTuple_GET_SIZE(pair) != 2 || !PyUnicode_Check(PyTuple_GET_ITEM(pair, 0))) {
            PyErr_SetString(PyExc_TypeError, "_function: inputs are (name, size) pairs");
            goto fail;
        }
        s->in_size[i] = PyLong_AsSsize_t(PyTuple_GET_ITEM(pair, 1));
        if (s->in_size[i] < 0)
            goto fail;
    }
    for (i = 0; i < s->nout; ++i) {
        PyObject *shape = PyTuple_GET_ITEM(outputs, i);
        Py_ssize_t k;
        if (!PyTuple_Check(shape) || PyTuple_GET_SIZE(shape) < 1 || PyTuple_GET_SIZE(shape) > 3) {
            PyErr_SetString(PyExc_TypeError, "_function: an output's shape has 1 to 3 dimensions");
            goto fail;
        }
        s->out_nd[i] = (int)PyTuple_GET_SIZE(shape);
        for (k = 0; k < s->out_nd[i]; ++k) {
            s->out_dims[i][k] = PyLong_AsSsize_t(PyTuple_GET_ITEM(shape, k));
            if (s->out_dims[i][k] < 0)
                goto fail;
        }
    }
    s->def.ml_name = s->cname;
    s->def.ml_meth = (PyCFunction)(void (*)(void))py_call;
    s->def.ml_flags = METH_FASTCALL | METH_KEYWORDS;
    s->def.ml_doc = PyUnicode_AsUTF8(doc);
    fn = PyCFunction_NewEx(&s->def, (PyObject *)s, NULL);
    Py_DECREF(s);
    return fn;
fail:
    if (!PyErr_Occurred())
        PyErr_SetString(PyExc_ValueError, "_function: a size or dimension is negative");
    Py_DECREF(s);
    return NULL;
}

static PyMethodDef methods[] = {
    {"_function", py_function, METH_VARARGS,
     "_function(name, doc, inputs, outputs, builder[, quaternion]): a new function"},
    {"_set_threads", py_set_threads, METH_O, "default number of threads of a batched call"},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef moduledef = {
    PyModuleDef_HEAD_INIT, .m_name = SYMDYN_STR(SYMDYN_MODULE), .m_doc = NULL, .m_size = -1, .m_methods = methods,
};

PyMODINIT_FUNC SYMDYN_CAT(PyInit_, SYMDYN_MODULE)(void)
{
    import_array();
    if (PyType_Ready(&spec_type) < 0)
        return NULL;
    return PyModule_Create(&moduledef);
}
