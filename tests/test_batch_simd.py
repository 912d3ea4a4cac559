"""The C target's SIMD batch kernels (issue 23): W states per instruction, blocks over threads.

Every batched call of a compiled model runs `<model>_<f>_simd`: the states are
gathered W at a time into structure-of-arrays blocks, the straight-line
program runs once per lane in a loop the compiler vectorizes, and the results
are scattered back.  Each lane does the scalar function's arithmetic (the
same sin/cos reduction and polynomials, sign as a select), so a batch equals
the single calls state by state: to rounding (the compiler may fuse a
multiply-add differently in the vector loop than in the scalar function),
bitwise where it does not, and bitwise whatever the thread count.
"""

import ctypes
import math
import re
import shutil
import subprocess

import numpy as np
import pytest

from symdyn.codegen import entry as codegen
from symdyn.codegen.emit import c as c_emit
from symdyn.codegen.emit import csimd
from symdyn.codegen.emit import cbuild
from symdyn.model.random_arms import random_arm
from symdyn.codegen.task_functions import TASK_NAMES
from tests.conftest import tiered

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")

#: 0, 1, W - 1, W, W + 1 for W = 2, 4 and 8, then longer runs, one of them odd.
SIZES = (0, 1, 2, 3, 4, 5, 7, 8, 9, 17, 1000, 1001)
RTOL = 1e-14


#: The Panda's and the iiwa's batched C runs through test_real_arms' target stage (200 states against the
#: reference); here the general-joint UR5 stands for them (its library compiles in half the Panda's time).
@pytest.fixture(scope="module", params=tiered(["puma560", "ur5", "random"], 1))  # ur5, random: make test-all
def model(request):
    if request.param == "random":
        return codegen.load(random_arm(3, n=4), "c")
    return codegen.load(request.param, "c")


def _states(n, count, seed=0):
    rng = np.random.default_rng(seed)
    q, qd, qdd = (rng.uniform(-3, 3, (count, n)) for _ in range(3))
    qd[::5, : n // 2] = 0.0  # Coulomb friction at rest: sign(0)
    return {"q": q, "qd": qd, "qdd": qdd, "tau": qdd * 10, "v": qd, "a": qdd}  # the task space's v, a


def _one_by_one(f, names, args, count):
    outs = [f(*(args[a][i] for a in names)) for i in range(count)]
    outs = [o if isinstance(o, tuple) else (o,) for o in outs]
    return [np.array([o[j] for o in outs]) for j in range(len(outs[0]))] if outs else None


@pytest.mark.parametrize("space", tiered(["joint", "task"], 1))  # the task space's kernels: make test-all
def test_every_kernel_equals_the_scalar_function_state_by_state(model, space):
    """(The task space's kernels are also checked against Pinocchio in the main suite:
    test_task_space's every-target test calls the C target on a batch.)"""
    task = set(TASK_NAMES)
    lib_sigs = {name: getattr(model, name) for name in model.functions if (name in task) == (space == "task")}
    args = _states(model.n, max(SIZES), seed=1)
    for name, f in lib_sigs.items():
        names = (
            [
                a.split("=")[0].strip()
                for a in f.__text_signature__.split("(")[1].split(")")[0].split(",")[1:]
                if a.strip() and "*" not in a and "=" not in a
            ]
            if f.__text_signature__
            else None
        )
        names = names or ["q", "qd", "qdd"][:1]
        single = _one_by_one(f, names, args, max(SIZES))
        for count in SIZES:
            got = f(*(args[a][:count] for a in names))
            got = got if isinstance(got, tuple) else (got,)
            for g, s in zip(got, single):
                want = s[:count]
                assert g.shape == want.shape, (name, count)
                if count == 0:
                    continue
                scale = np.max(np.abs(want.reshape(count, -1)), axis=1)
                err = np.max(np.abs(g - want).reshape(count, -1), axis=1)
                assert np.all(err <= RTOL * scale), f"{model.name}.{name} at N={count}: {np.max(err / scale):.1e}"
        if name == "F":  # no sin/cos: the same arithmetic, bitwise
            assert np.array_equal(f(args["qd"]), single[0])


def test_threads_give_bitwise_the_same_results_and_out_is_written_in_place(model):
    count = 20_001  # not a multiple of 2, long enough for two threads to start
    args = _states(model.n, count, seed=2)
    for name, ins in (("tau", "q qd qdd"), ("M", "q"), ("fdyn", "q qd tau")):
        f = getattr(model, name)
        xs = [args[a] for a in ins.split()]
        one = f(*xs, threads=1)
        two = f(*xs, threads=2)
        default = f(*xs)
        assert np.array_equal(one, two) and np.array_equal(one, default), name
        out = np.full_like(one, np.nan)
        assert f(*xs, out=out, threads=2) is out
        assert np.array_equal(out, one)
    tau, dq, dqd = model.tau_derivatives(args["q"], args["qd"], args["qdd"], threads=1)
    outs = tuple(np.empty_like(a) for a in (tau, dq, dqd))
    assert model.tau_derivatives(args["q"], args["qd"], args["qdd"], out=outs, threads=2) == outs
    assert all(np.array_equal(a, b) for a, b in zip(outs, (tau, dq, dqd)))


def test_out_and_threads_are_checked(model):
    q = np.zeros((10, model.n))
    with pytest.raises(ValueError, match="out must be a C-contiguous"):
        model.M(q, out=np.empty((10, model.n, model.n), dtype=np.float32))
    with pytest.raises(ValueError, match="out must be a C-contiguous"):
        model.M(q, out=np.empty((10, model.n, model.n + 1)))
    with pytest.raises(ValueError, match="out must be a C-contiguous"):
        model.M(q, out=np.empty((model.n, model.n, 10)).T)
    with pytest.raises(ValueError, match="out must be a tuple of 3 arrays"):
        model.tau_derivatives(q, q, q, out=np.empty((10, model.n)))
    with pytest.raises(ValueError, match="threads must be at least 1"):
        model.M(q, threads=0)
    with pytest.raises(ValueError, match="contains NaN"):
        model.M(np.full((10, model.n), np.nan), threads=2)


def test_a_state_with_a_huge_angle_is_computed_by_the_scalar_function():
    model = codegen.load("twolink", "c")  # G is all sin/cos; a library that compiles in a second
    q = _states(2, 17, seed=3)["q"]
    q[5, 1] = 3e5  # outside the inline range: libm in the scalar function, that lane recomputed
    q[9, 0] = -1e9
    np.testing.assert_allclose(model.G(q), np.array([model.G(x) for x in q]), rtol=RTOL, atol=0)


def test_an_output_s_own_sines_send_a_huge_angle_to_the_scalar_function(tmp_path, monkeypatch):
    """sin/cos written in an output itself (not in an assignment) is checked as an assignment's
    is: a lane beyond the vector range is computed again by the scalar function (libm), in a
    kernel of vectors and in one of matrices (each stores where it is ready)."""
    import sympy as sp

    from symdyn.codegen.emit import Bundle
    from symdyn.codegen.emit.clib import load_library
    from symdyn.derivation.program import make_program
    from symdyn.derivation.symbols import joint_symbols

    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    q, qd, _ = joint_symbols(2)
    terms = [sp.sin(q[0]) * qd[0], sp.cos(q[0]) * qd[1]]
    rng = np.random.default_rng(4)
    qs, vs = rng.uniform(-3, 3, (17, 2)), rng.uniform(-2, 2, (17, 2))
    qs[5, 0], qs[9, 0] = 1e22, -3e5
    for name, out in (("column", sp.Matrix(terms)), ("row", sp.Matrix([terms]))):
        folder = tmp_path / name
        folder.mkdir()
        bundle = Bundle(name, 2, "test", "none", (make_program("f", [("q", q), ("v", qd)], [("y", out)]),))
        (folder / f"{name}.c").write_text(c_emit.c_source(bundle))
        (folder / f"{name}.h").write_text(c_emit.h_source(bundle))
        f = load_library(folder / f"{name}.c", folder / f"{name}.h").functions["f"]
        single = np.array([f(a, b) for a, b in zip(qs, vs)])
        np.testing.assert_allclose(f(qs, vs), single, rtol=RTOL, atol=0, err_msg=name)


@pytest.fixture(scope="module")
def sincos(tmp_path_factory):
    """The kernels' sincosv_ over an array (SYMDYN_W lanes at a time) and the scalar sincos_, via ctypes."""
    folder = tmp_path_factory.mktemp("sincos")
    src = folder / "sincos.c"
    src.write_text(
        "#include <math.h>\n"
        + c_emit._HELPERS
        + c_emit._SIMD_HELPERS
        + r"""
void sincos_simd(long n, const double *x, double *s, double *c);
void sincos_scalar(long n, const double *x, double *s, double *c);
void sincos_simd(long n, const double *x, double *s, double *c)
{
    long i;
    int k;
    for (i = 0; i + SYMDYN_W <= n; i += SYMDYN_W) {
        SYMDYN_SIMD
        for (k = 0; k < SYMDYN_W; ++k)
            sincosv_(x[i + k], &s[i + k], &c[i + k]);
    }
    for (; i < n; ++i)
        sincosv_(x[i], &s[i], &c[i]);
}
void sincos_scalar(long n, const double *x, double *s, double *c)
{
    long i;
    for (i = 0; i < n; ++i)
        sincos_(x[i], &s[i], &c[i]);
}
void sincos_libm(long n, const double *x, double *s, double *c);
void sincos_libm(long n, const double *x, double *s, double *c)
{
    long i;
    for (i = 0; i < n; ++i) {
        s[i] = sin(x[i]);
        c[i] = cos(x[i]);
    }
}
"""
    )
    lib = folder / "libsincos.so"
    subprocess.run(
        [
            cbuild.compiler(),
            *cbuild.DEFAULT_FLAGS,
            "-Wall",
            "-Wextra",
            "-Werror",
            "-Wno-unused-function",
            str(src),
            "-o",
            str(lib),
            "-lm",
        ],
        check=True,
    )
    dll = ctypes.CDLL(str(lib))

    def run(fn, xs):
        xs = np.ascontiguousarray(xs, dtype=np.float64)
        s, c = np.empty_like(xs), np.empty_like(xs)
        getattr(dll, fn)(ctypes.c_long(len(xs)), *(ctypes.c_void_p(a.ctypes.data) for a in (xs, s, c)))
        return s, c

    return run


def _errors(got, want):
    """(ulps, absolute errors) of got against want."""
    return np.abs(got - want) / np.spacing(np.abs(want)), np.abs(got - want)


def _math(sincos, xs):
    """math.sin and math.cos at xs: the C library's sin and cos, which math calls (checked on a sample)."""
    s, c = sincos("sincos_libm", xs)
    sample = xs[:: max(1, len(xs) // 2000)]
    assert np.array_equal(s[:: max(1, len(xs) // 2000)], [math.sin(x) for x in sample])
    assert np.array_equal(c[:: max(1, len(xs) // 2000)], [math.cos(x) for x in sample])
    return s, c


def test_vector_sincos_is_the_scalar_one_and_within_one_ulp_of_math(sincos):
    """Measured (10^7 points in [-4pi, 4pi]): <= 1 ulp; at multiples of pi/2, where sin or cos
    is ~1e-16, below 3e-26 absolute (the reduction's pi/2 to 86 bits); in [-1e6, 1e6] <= 1.2e-16 absolute, 99.9997 % within 1 ulp."""
    rng = np.random.default_rng(4)
    xs = rng.uniform(-4 * np.pi, 4 * np.pi, 10_000_000)
    multiples = np.concatenate([np.arange(-16, 17) * np.pi / 4, [0.0, -0.0, 1e-300, 5e-324]])
    for points, within in ((xs, None), (multiples, 3e-26)):
        s, c = sincos("sincos_simd", points)
        s1, c1 = sincos("sincos_scalar", points)
        assert np.array_equal(s, s1) and np.array_equal(c, c1)  # the same bits as the scalar functions' sincos_
        for got, want, fn in zip((s, c), _math(sincos, points), ("sin", "cos")):
            ulps, absolute = _errors(got, want)
            if within is None:
                assert np.max(ulps) <= 1.0, (fn, np.max(ulps))
            else:
                assert np.all((ulps <= 1.0) | (absolute <= within)), (fn, np.max(absolute[ulps > 1]))
    big = np.concatenate([rng.uniform(-1e6, 1e6, 1_000_000), [1e6, -1e6, 1e5, -1e5]])
    s, c = sincos("sincos_simd", big)
    for got, want, fn in zip((s, c), _math(sincos, big), ("sin", "cos")):
        ulps, absolute = _errors(got, want)
        assert np.max(absolute) <= 2.3e-16 and np.mean(ulps <= 1.0) > 0.9999, (fn, np.max(absolute))


def test_batches_not_divisible_by_the_threads_are_bitwise_the_single_thread_results(model):
    count = 3 * 4096 + 5  # enough blocks for three threads, a short last block
    args = _states(model.n, count, seed=5)
    one = model.tau(args["q"], args["qd"], args["qdd"], threads=1)
    for threads in (2, 3, 7):
        assert np.array_equal(model.tau(args["q"], args["qd"], args["qdd"], threads=threads), one), threads


@pytest.mark.parametrize("where", [0, 6, 7, 8, 9, 4999])
def test_nan_or_inf_anywhere_in_a_batch_is_the_contracts_error_naming_the_argument(model, where):
    """The kernels test their inputs as they run (no pass of their own): at the first lane, in a
    block's middle, at a block's edges and in the short last block, in every argument."""
    args = _states(model.n, 5000, seed=6)
    for name, bad in (("q", np.nan), ("qd", np.inf), ("qdd", -np.inf)):
        xs = {a: args[a].copy() for a in ("q", "qd", "qdd")}
        xs[name][where, model.n - 1] = bad
        with pytest.raises(ValueError, match=rf"tau\(\): {name} contains NaN or infinity"):
            model.tau(xs["q"], xs["qd"], xs["qdd"], threads=2)
        out = np.empty((5000, model.n, model.n))
        if name == "q":
            with pytest.raises(ValueError, match=r"M\(\): q contains NaN or infinity"):
                model.M(xs["q"], out=out)


def test_float32_and_strided_inputs_are_converted_once_and_equal_float64_ones(model):
    args = _states(model.n, 1001, seed=7)
    q, qd, qdd = args["q"], args["qd"], args["qdd"]
    want = model.tau(q, qd, qdd)
    wide = np.empty((1001, 2 * model.n))
    wide[:, ::2] = q  # a strided view: (1001, n) with a step of 2
    assert np.array_equal(model.tau(wide[:, ::2], qd, qdd), want)
    assert np.array_equal(model.tau(np.asfortranarray(q), qd, qdd), want)
    q32 = q.astype(np.float32)
    assert np.array_equal(model.tau(q32, qd, qdd), model.tau(q32.astype(np.float64), qd, qdd))
    assert model.tau(q32, qd, qdd).dtype == np.float64
    with pytest.raises(ValueError, match=rf"q must have shape \(\.\.\., {model.n}\)"):
        model.tau(q[:, :-1], qd, qdd)
    with pytest.raises(ValueError, match="do not broadcast"):
        model.tau(q, qd[:10], qdd)


def test_a_million_states_take_no_memory_beyond_the_inputs_and_outputs():
    """tracemalloc sees every NumPy allocation: a call allocates its outputs and nothing else of
    a batch's size (the kernels' blocks live on the stack); with out= it allocates nothing."""
    import tracemalloc

    model = codegen.load("puma560", "c")
    args = _states(6, 1_000_000, seed=8)
    out = np.empty((1_000_000, 6))
    model.tau(args["q"], args["qd"], args["qdd"], out=out)
    tracemalloc.start()
    try:
        tau = model.tau(args["q"], args["qd"], args["qdd"])
        allocated = tracemalloc.get_traced_memory()[1]
        del tau
        tracemalloc.reset_peak()
        model.tau(args["q"], args["qd"], args["qdd"], out=out)
        into_out = tracemalloc.get_traced_memory()[1] - tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert out.nbytes <= allocated <= out.nbytes + 64_000
    assert into_out <= 64_000


def test_the_lane_loop_computes_a_jacobian_column_by_column_storing_each_entry_when_ready():
    """A kernel of matrix outputs computes them column after column, each stored as soon as its
    operands are: a column's values die with it (Talos' centroidal kernel 166 → 131 ns a state in
    the caches); one of vectors keeps the program's order (the kernels' values: the tests above)."""
    import sympy as sp

    from symdyn.derivation.program import make_program
    from symdyn.derivation.symbols import joint_symbols

    q = joint_symbols(3)[0]
    J = sp.Matrix(2, 3, lambda i, j: (q[j] ** 2 + 1) ** (i + 2) + q[j] ** 3)  # column j: its own values
    lines = csimd._lane_statements(make_program("jac", [("q", q)], [("J", J)]))
    stores = [i for i, line in enumerate(lines) if line.strip().startswith("J_[")]
    order = [int(lines[i].split("J_[")[1].split("]")[0]) for i in stores]
    assert order == [0, 3, 1, 4, 2, 5]  # (row 0, col 0), (row 1, col 0), (0, 1) …: column by column
    reads = [i for i, line in enumerate(lines) if "q3" in line and not line.strip().startswith("J_[")]
    assert min(reads) > stores[3], "column 2's values are computed after column 1 is stored"
    vector = make_program("vec", [("q", q)], [("y", J[:, 0])])  # a vector: the program's order, stores last
    lines = csimd._lane_statements(vector)
    assert [line.split("=")[0].strip() for line in lines[-2:]] == ["y_[0][k]", "y_[1][k]"]


def test_a_batch_that_asks_for_its_output_lines_ahead_gives_the_small_batches_bits():
    """A thread writing more than SYMDYN_AHEAD_BYTES of a matrix output asks for each block's lines
    before its arithmetic (a hint, no value changes): 120 000 states of the Puma's M (35 MB) on one
    and two threads are bitwise the same states computed in batches of 1 000."""
    model = codegen.load("puma560", "c")
    q = _states(6, 120_000, seed=9)["q"]
    pieces = np.concatenate([model.M(q[i : i + 1000], threads=1) for i in range(0, len(q), 1000)])
    for threads in (1, 2):
        assert np.array_equal(model.M(q, threads=threads), pieces)


def _is_gcc(cc: str) -> bool:
    done = subprocess.run([cc, "--version"], capture_output=True, text=True)
    return "Free Software Foundation" in done.stdout and "clang" not in done.stdout


def test_a_kernel_of_more_than_a_thousand_outputs_is_vectorized_and_equals_the_single_calls(tmp_path, monkeypatch):
    """gcc leaves a loop of more than 1000 memory references scalar unless told otherwise: a lane
    loop stores each output, so Talos' M (1296 outputs) ran its lanes one by one, 2.6× slower than
    the scalar function in a loop.  A SIMD unit is compiled with the limit raised
    (`cunits.WIDE_LOOPS`): gcc's report names the lane loop of a 1 100-output kernel vectorized
    under the unit's own flags, and the batch is the single calls."""
    import sympy as sp

    from symdyn.codegen.emit import Bundle, cunits
    from symdyn.codegen.emit.clib import load_library
    from symdyn.derivation.program import make_program
    from symdyn.derivation.symbols import joint_symbols

    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    q, qd, _ = joint_symbols(2)
    wide = sp.Matrix(11, 100, lambda i, j: (i + 1) * sp.sin(q[0]) * qd[0] + (j + 1) * sp.cos(q[1]) * qd[1])
    bundle = Bundle("wide", 2, "test", "none", (make_program("f", [("q", q), ("v", qd)], [("y", wide)]),))
    (tmp_path / "wide.c").write_text(c_emit.c_source(bundle))
    (tmp_path / "wide.h").write_text(c_emit.h_source(bundle))
    lib = load_library(tmp_path / "wide.c", tmp_path / "wide.h")
    rng = np.random.default_rng(5)
    qs, vs = rng.uniform(-3, 3, (37, 2)), rng.uniform(-2, 2, (37, 2))
    f = lib.functions["f"]
    single = np.array([f(a, b) for a, b in zip(qs, vs)])  # a sum that cancels: rounding of its terms' size
    np.testing.assert_allclose(f(qs, vs), single, rtol=RTOL, atol=RTOL * np.abs(single).max())

    cc = cbuild.compiler()
    if not _is_gcc(cc):
        pytest.skip(f"{cc} is not gcc: the limit is gcc's")
    unit = lib.units.unit("f", "simd")
    assert cunits.WIDE_LOOPS in unit.flags
    lines = unit.text.splitlines()
    lanes = next(i for i, line in enumerate(lines) if line.startswith("static int wide_f_lanes("))
    start = next(i for i in range(lanes, len(lines)) if lines[i].strip() == "SYMDYN_SIMD") + 2  # 1-based
    end = next(i for i in range(start, len(lines)) if lines[i].strip() == "bad_[k] = bad;") + 1
    source = tmp_path / "unit.c"
    source.write_text(unit.text)
    flags = [f for f in unit.flags if f != "-shared"]
    done = subprocess.run(
        [cc, *flags, "-c", str(source), "-o", str(tmp_path / "unit.o"), "-fopt-info-vec-optimized"],
        capture_output=True,
        text=True,
        check=True,
    )
    vectorized = [int(line) for line in re.findall(r"unit\.c:(\d+):\d+: optimized: loop vectorized", done.stderr)]
    assert any(start <= line <= end for line in vectorized), (start, end, done.stderr[-2000:])


def test_a_kernel_wider_than_a_vectorized_lane_loop_runs_the_scalar_function_over_the_threads(tmp_path, monkeypatch):
    """Past `csimd.LANE_REFERENCES` (a state's inputs and outputs; 3000, lowered here to 10) gcc
    leaves the lane loop scalar and the kernel would run slower than the scalar function in a
    loop (Solo 12's regressor): the batch entry calls the scalar function state after state over
    the threads, the single calls' bits, a NaN still the contract's error naming the argument."""
    import sympy as sp

    from symdyn.codegen.emit import Bundle
    from symdyn.codegen.emit.clib import load_library
    from symdyn.derivation.program import make_program
    from symdyn.derivation.symbols import joint_symbols

    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(csimd, "LANE_REFERENCES", 10)
    q, qd, _ = joint_symbols(2)
    y = sp.Matrix(3, 3, lambda i, j: (i + 1) * sp.sin(q[0]) * qd[j % 2] + (j + 1) * sp.cos(q[1]))
    programs = (
        make_program("wide", [("q", q), ("v", qd)], [("y", y)]),  # 4 + 9 references: the loop
        make_program("narrow", [("q", q)], [("z", sp.Matrix([sp.sin(q[0]), q[1]]))]),  # 2 + 2: a lane loop
    )
    bundle = Bundle("loops", 2, "test", "none", programs)
    (tmp_path / "loops.c").write_text(c_emit.c_source(bundle))
    (tmp_path / "loops.h").write_text(c_emit.h_source(bundle))
    lib = load_library(tmp_path / "loops.c", tmp_path / "loops.h")
    assert "_lanes(" not in lib.units.unit("wide", "simd").text
    assert "loops_narrow_lanes(" in lib.units.unit("narrow", "simd").text
    rng = np.random.default_rng(6)
    qs, vs = rng.uniform(-3, 3, (1001, 2)), rng.uniform(-2, 2, (1001, 2))
    f = lib.functions["wide"]
    single = np.array([f(a, b) for a, b in zip(qs, vs)])
    for threads in (1, 2):
        assert np.array_equal(f(qs, vs, threads=threads), single)
    vs[700, 1] = np.nan
    with pytest.raises(ValueError, match="v contains NaN or infinity"):
        f(qs, vs)
