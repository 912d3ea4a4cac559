"""The C target: plain C entry points, compiled on first use, equal to the reference."""

import dataclasses
import re
import shutil

import numpy as np
import pytest

from symdyn.codegen import entry as codegen
from symdyn.codegen.emit import c as c_emit
from symdyn.codegen.emit import cbuild
from symdyn.codegen.emit.clib import CompileOptions, load_library
from tests.codegen_cases import MODELS, assert_close, cases


@pytest.fixture(scope="module", params=MODELS)
def model(request):
    return codegen.load(request.param, target="c")


@pytest.fixture(scope="module")
def twolink_ctypes():
    return codegen.load("twolink", target="c", options=CompileOptions(binding="ctypes"))


def test_leading_shapes_lists_and_integers(model):
    (q, qd, qdd), tau = cases(model.name)["tau"]
    n = model.n
    got = model.tau(q[:6].reshape(2, 3, n), qd[:6].reshape(2, 3, n), qdd[:6].reshape(2, 3, n))
    assert got.shape == (2, 3, n)
    assert np.array_equal(got.reshape(6, n), model.tau(q[:6], qd[:6], qdd[:6]))
    assert model.M([0] * n).shape == (n, n)
    assert model.M(q[:0]).shape == (0, n, n)


def test_ctypes_binding_agrees_with_the_reference(twolink_ctypes):
    for function, (args, expected) in cases("twolink").items():
        assert_close(getattr(twolink_ctypes, function)(*args), expected, f"ctypes {function}")
        assert_close(getattr(twolink_ctypes, function)(*(a[7] for a in args)), expected[7], function)


def _copy_model(tmp_path, name="twolink"):
    src = codegen.GENERATED / name
    for suffix in (".c", ".h"):
        shutil.copy(src / f"{name}{suffix}", tmp_path / f"{name}{suffix}")
    return tmp_path / f"{name}.c", tmp_path / f"{name}.h"


def test_library_is_rebuilt_when_its_source_changes_and_reused_otherwise(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    c_path, h_path = _copy_model(tmp_path)
    first = load_library(c_path, h_path)
    assert first.functions["M"](np.zeros(2))[1, 1] == 0.25
    stamp = first.library("M").stat().st_mtime_ns
    again = load_library(c_path, h_path)
    assert again.library("M") == first.library("M") and again.library("M").stat().st_mtime_ns == stamp
    text = c_path.read_text()
    assert "M[3] = 0.25;" in text
    c_path.write_text(text.replace("M[3] = 0.25;", "M[3] = 0.5;"))
    changed = load_library(c_path, h_path)
    assert changed.library("M") != first.library("M")
    assert changed.functions["M"](np.zeros(2))[1, 1] == 0.5


def test_missing_compiler_says_what_to_install(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    c_path, h_path = _copy_model(tmp_path)
    with pytest.raises(RuntimeError, match="no C compiler found.*apt install gcc"):
        load_library(c_path, h_path)


def test_compile_error_shows_the_compiler_message(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    c_path, h_path = _copy_model(tmp_path)
    c_path.write_text(c_path.read_text() + "\nthis is not C;\n")  # in the last function's kernel
    lib = load_library(c_path, h_path, CompileOptions(binding="ctypes"))
    last = c_emit.read_signatures(h_path.read_text())[-1]
    with pytest.raises(RuntimeError, match=rf"(?s)compiling twolink's {last.name} \(batch kernel\) failed.*error"):
        lib.functions[last.name](*(np.zeros((2, k)) for _, k in last.inputs))


def test_header_signatures_round_trip():
    header = (codegen.GENERATED / "puma560" / "puma560.h").read_text()
    sigs = {s.name: s for s in c_emit.read_signatures(header)}
    assert sigs["M"].inputs == (("q", 6),) and sigs["M"].outputs == (("M", (6, 6)),)
    assert sigs["fdyn"].inputs == (("q", 6), ("qd", 6), ("tau", 6))
    assert "void puma560_tau(const double q[6], const double qd[6], const double qdd[6], double tau[6]);" in header
    assert "void puma560_M(const double q[6], double M[36]);" in header
    assert (
        "void puma560_tau_batch(int n, const double *q, const double *qd, const double *qdd, double *tau);"
    ) in header


def test_inline_sincos_is_within_one_ulp_of_libm(tmp_path, monkeypatch):
    import sympy as sp

    from symdyn.codegen.emit import Bundle
    from symdyn.derivation.program import make_program
    from symdyn.derivation.symbols import joint_symbols

    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    (x,), _, _ = joint_symbols(1)
    program = make_program("sc", [("q", (x,))], [("y", sp.Matrix([sp.sin(x), sp.cos(x)]))])
    bundle = Bundle("trig", 1, "test", "none", (program,))
    (tmp_path / "trig.c").write_text(c_emit.c_source(bundle))
    (tmp_path / "trig.h").write_text(c_emit.h_source(bundle))
    sc = load_library(tmp_path / "trig.c", tmp_path / "trig.h").functions["sc"]
    rng = np.random.default_rng(0)
    xs = np.concatenate(
        [
            rng.uniform(-10, 10, 100_000),
            rng.uniform(-1e5, 1e5, 10_000),
            np.arange(-8, 9) * np.pi / 4,
            [0.0, 1e-300, 3e5, -1e7],
        ]
    )
    got = sc(xs[:, None])
    for k, ref_fn in enumerate((np.sin, np.cos)):
        ulps = np.abs(got[:, k] - ref_fn(xs)) / np.spacing(np.abs(ref_fn(xs)))
        assert np.max(np.abs(got[:, k] - ref_fn(xs))) <= 2.3e-16
        assert np.mean(ulps <= 1.0) > 0.9999, f"{ref_fn.__name__}: {np.sum(ulps > 1)} values beyond 1 ulp"
    with pytest.raises(ValueError, match="contains NaN or infinity"):
        sc(np.array([[np.nan], [np.inf]]))


def test_a_long_source_is_split_into_whole_functions_each_with_the_preamble():
    text = (codegen.GENERATED / "puma560" / "puma560.c").read_text()
    head = text[: text.index("\nvoid ") + 1]
    definitions = re.compile(r"(?m)^(?=(static )?(void|int) \w+\()")  # a SIMD kernel's static lanes and range too
    functions = [f for f in definitions.split(text[len(head) :]) if f]
    parts = cbuild.split_source(text, 3)
    assert len(text) > cbuild.SPLIT_BYTES and len(parts) == 3
    assert all(p.startswith(head) for p in parts)
    bodies = sorted(f for p in parts for f in definitions.split(p[len(head) :]) if f)
    assert bodies == sorted(functions)
    sizes = [len(p) for p in parts]
    # longest first into the lightest part; a kernel's lanes, range and entry point stay together
    assert max(sizes) - min(sizes) <= sum(sorted(len(f) for f in functions)[-3:])


def test_short_or_unusual_sources_compile_in_one_piece(monkeypatch):
    text = (codegen.GENERATED / "puma560" / "puma560.c").read_text()
    assert cbuild.split_source(text, 1) == [text]
    twolink = (codegen.GENERATED / "twolink" / "twolink.c").read_text()
    monkeypatch.setattr(cbuild, "SPLIT_BYTES", len(twolink) + 1)  # shorter than that: one piece
    assert cbuild.split_source(twolink, 4) == [twolink]
    static_after = text + "\nstatic double helper(double x) { return x; }\n"
    assert cbuild.split_source(static_after, 4) == [static_after]


def test_a_split_build_equals_the_reference_and_names_a_failing_part(tmp_path, monkeypatch):
    """A long source built in one library (CasADi's compiled functions) is compiled in parts
    in parallel (`split_source`), then linked."""
    import ctypes

    monkeypatch.setattr(cbuild, "jobs", lambda: 2)
    monkeypatch.setattr(cbuild, "SPLIT_BYTES", 0)  # the two-link arm's short file, in parts too
    c_path, h_path = _copy_model(tmp_path)
    files = {p.name: p.read_text() for p in (c_path, h_path)}
    lib = cbuild.library(tmp_path / "lib" / "libtwolink.so", cbuild.DEFAULT_FLAGS, files, [])
    dll = ctypes.CDLL(str(lib))
    (q,), M = cases("twolink")["M"]
    got = np.empty((len(q), 2, 2))
    dll.twolink_M_batch(ctypes.c_int(len(q)), ctypes.c_void_p(q.ctypes.data), ctypes.c_void_p(got.ctypes.data))
    assert_close(got, M, "split M")
    files["twolink.c"] = files["twolink.c"].replace("void twolink_Minv(", "void twolink_Minv(undeclared_type x, ")
    with pytest.raises(RuntimeError, match=r"compiling twolink\.part\d\.c failed"):
        cbuild.library(tmp_path / "bad" / "libtwolink.so", cbuild.DEFAULT_FLAGS, files, [])


def test_a_large_function_is_emitted_as_parts_that_compute_the_same(tmp_path, monkeypatch):
    """Above SPLIT_ABOVE assignments a function is written as noinline parts passing values
    through an array (gcc's register allocation is superlinear in a function's size), a matrix's
    parts storing the entries they complete, a vector's stored at the end: the Puma's functions
    forced into parts of 17 give the reference's values."""
    monkeypatch.setattr(c_emit, "SPLIT_ABOVE", 40)
    monkeypatch.setattr(c_emit, "PART_SIZE", 17)
    bundle = codegen.bundle(codegen._robot("puma560"))
    bundle = dataclasses.replace(bundle, programs=tuple(p for p in bundle.programs if p.name in ("tau", "M", "fdyn")))
    (tmp_path / "puma560.c").write_text(c_emit.c_source(bundle))
    (tmp_path / "puma560.h").write_text(c_emit.h_source(bundle))
    text = (tmp_path / "puma560.c").read_text()
    assert "static SYMDYN_NOINLINE void puma560_M_part2(const double *q, double *M, double *w_)" in text
    tau_part = "static SYMDYN_NOINLINE void puma560_tau_part2(const double *q, const double *qd, const double *qdd, double *w_)"
    assert tau_part in text
    quick = CompileOptions(flags=("-O1", "-fPIC", "-shared", "-pthread"))
    lib = load_library(tmp_path / "puma560.c", tmp_path / "puma560.h", quick)
    for function, (args, expected) in cases("puma560").items():
        if function not in lib.functions:
            continue
        assert_close(lib.functions[function](*(a[3] for a in args)), expected[3], f"parts {function}")
        assert_close(lib.functions[function](*args), expected, f"parts, batched {function}")


def _compiled(tmp_path, name: str, program, flags: tuple = ()):
    from symdyn.codegen.emit import Bundle

    bundle = Bundle(name, 1, "test", "none", (program,))
    folder = tmp_path / name
    folder.mkdir()
    (folder / f"{name}.c").write_text(c_emit.c_source(bundle))
    (folder / f"{name}.h").write_text(c_emit.h_source(bundle))
    options = CompileOptions(flags=cbuild.DEFAULT_FLAGS + flags)
    return (folder / f"{name}.c").read_text(), load_library(folder / f"{name}.c", folder / f"{name}.h", options)


def test_the_coordinates_sines_in_one_loop_are_sincos_bits_and_zeros_are_one_memset(tmp_path, monkeypatch):
    """q's sin/cos pairs computed in one vectorizable loop (libm beyond |q| ≥ 1e5) give the bits of
    one sincos_ call each (what the sines feed may differ by the compiler's fused multiply-adds); an output of
    many exact zeros (here over a lowered MEMSET_MIN) is zeroed by memset, of fewer zero by zero, whatever the
    buffer held."""
    import sympy as sp

    from symdyn.derivation.program import make_program
    from symdyn.derivation.symbols import joint_symbols

    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(c_emit, "MEMSET_MIN", 16)
    q = joint_symbols(5)[0]
    values = [e for x in q[1:] for e in (sp.sin(x), sp.cos(x))]  # each pair also in a product: named once
    out = sp.Matrix(values + [sp.sin(x) * sp.cos(x) + q[0] for x in q[1:]] + [0] * 20)
    program = make_program("sc", [("q", q)], [("y", out)])
    text, looped = _compiled(tmp_path, "looped", program)
    assert (
        "sincos_loop_(q + 1, 4, sin_q_, cos_q_);" in text
        and "memset(y, 0, sizeof(double) * 32);  /* its 20 exact zeros */" in text
    )
    monkeypatch.setattr(c_emit, "TRIG_LOOP_MIN", 99)
    monkeypatch.setattr(c_emit, "MEMSET_MIN", 10**9)
    text, calls = _compiled(tmp_path, "calls", program)
    assert "sincos_loop_(q" not in text.split("_lanes(")[0].split("void calls_sc(")[1] and "memset" not in text
    rng = np.random.default_rng(1)
    states = rng.uniform(-20, 20, (2000, 5))
    states[:3, 1:] = [[3e5, -1e7, 1e5, 2.5], [np.pi / 2, -np.pi, 99999.9, 0.0], [1e-300, 7.0, -3e5, 1e6]]
    a, b = looped.functions["sc"](states), calls.functions["sc"](states)
    assert np.array_equal(a[:, :8], b[:, :8])  # the sines and cosines: the same bits
    monkeypatch.undo()
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    # the loop called, not inlined, as in a translation unit of several small functions (cunits)
    text, called = _compiled(tmp_path, "called", program, ("-DSYMDYN_TRIG_LOOP_CALLED",))
    assert "memset" not in text and "y[31] = 0.0;" in text  # 20 zeros, under MEMSET_MIN
    assert np.array_equal(called.functions["sc"](states)[:, :8], a[:, :8])
    assert not called.functions["sc"](states[5], out=np.full(32, np.nan))[12:].any()
    assert np.abs(a - b).max() <= 4.5e-16  # what uses them: as the compiler contracts it (fused multiply-adds)
    assert not a[:, 12:].any()
    want = np.column_stack([f(states[:, j]) for j in range(1, 5) for f in (np.sin, np.cos)])
    assert np.abs(a[:, :8] - want).max() <= 2.3e-16


def test_an_input_only_the_trigonometric_loop_reads_is_not_called_unused():
    """A function that reads q only through the sines of its coordinates (the loop over q) does not
    say that it does not depend on q; one that ignores an input says so."""
    import sympy as sp

    from symdyn.derivation.program import make_program
    from symdyn.derivation.symbols import joint_symbols

    q, qd, _ = joint_symbols(4)
    out = sp.Matrix([e for x in q for e in (sp.sin(x), sp.cos(x), sp.sin(x) * sp.cos(x))])
    text = c_emit.single_source("m", make_program("f", [("q", q), ("v", qd)], [("y", out)]))
    assert "sincos_loop_(q + 0, 4," in text
    assert "does not depend on q" not in text and "(void)v;  /* unused: this f does not depend on v */" in text


def test_a_matrix_is_stored_in_the_order_that_holds_fewest_values():
    """Two 2 × 2 outputs, one of sums over x1…x6 and a value of each column, the other over y1…y6:
    taken column by column across them both sets are live at once, output after output one at a
    time, so that order is chosen; its entries are stored as they are computed (all of A's before
    any of B's), and a program of vectors keeps its order, its stores at the end."""
    import sympy as sp

    from symdyn.codegen.emit.schedule import _ORDERS, _entry_schedule, peak_live, schedule
    from symdyn.derivation.program import make_program
    from symdyn.derivation.symbols import joint_symbols

    q = joint_symbols(2)[0]
    xs = [sp.sqrt(q[0] ** 2 + k) for k in range(1, 7)]
    ys = [sp.sqrt(q[1] ** 2 + k) for k in range(1, 7)]
    A = sp.Matrix(2, 2, lambda i, j: sum(x * (i + 2 * j + 1) ** k for k, x in enumerate(xs)) + sp.sqrt(q[0] + j))
    B = sp.Matrix(2, 2, lambda i, j: sum(y * (i + 2 * j + 2) ** k for k, y in enumerate(ys)) + sp.sqrt(q[1] + j))
    p = make_program("two", [("q", q)], [("A", A), ("B", B)])
    entries = [(k % m.cols, i, k // m.cols, o, k, e) for i, (o, m) in enumerate(p.outputs) for k, e in enumerate(m)]
    columns, outputs = (peak_live(_entry_schedule(p, sorted(entries, key=key))) for key in _ORDERS)
    plan = schedule(p)
    assert outputs + 6 <= columns and peak_live(plan) == outputs
    stored = [o for step in plan.steps for o, *_ in step.stores]
    assert stored == ["A"] * 4 + ["B"] * 4 and not plan.tail
    vector = make_program("v", [("q", q)], [("y", sp.Matrix(xs))])
    plan = schedule(vector)
    assert not any(step.stores for step in plan.steps) and [k for _, k, _ in plan.tail] == list(range(6))


def test_peak_live_holds_a_value_from_its_step_through_the_last_that_reads_it():
    """a = q1², b = a + 1, c = a·b, d = c + q2 and stores of c and d: a and b are held through c's
    step, where c starts (3); c through d's step and its store; a value a store of its own step
    alone reads is not held."""
    import sympy as sp

    from symdyn.codegen.emit.schedule import Schedule, Step, peak_live

    q1, q2, a, b, c, d = sp.symbols("q1 q2 a b c d")
    steps = (
        Step((None, a, q1**2)),
        Step((None, b, a + 1)),
        Step((None, c, a * b), (("y", 0, c),)),
        Step((None, d, c + q2), (("y", 1, d + c),)),
    )
    assert peak_live(Schedule((), steps, ())) == 3
    unused = (Step((None, a, q1**2)), Step((None, b, q2**2)), Step((None, c, a + b), (("y", 0, c),)))
    assert peak_live(Schedule((), unused, ())) == 2  # a and b, both read at c's step


@pytest.mark.parametrize("split", [False, True])
@pytest.mark.parametrize("memset", [4, 10**9])
def test_a_matrixs_zeros_and_entries_are_written_into_any_buffer_whole_or_in_parts(
    tmp_path, monkeypatch, split, memset
):
    """A 4 × 5 matrix of 6 exact zeros, constants, an input alone and products, and a vector: every
    entry written over a NaN-filled out=, zeros by memset or one by one, in one function or in parts
    of 3 steps (each part storing what it completes), as sympy evaluates them."""
    import sympy as sp

    from symdyn.derivation.program import make_program
    from symdyn.derivation.symbols import joint_symbols

    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(c_emit, "MEMSET_MIN", memset)
    if split:
        monkeypatch.setattr(c_emit, "SPLIT_ABOVE", 3)
        monkeypatch.setattr(c_emit, "PART_SIZE", 3)
    q = joint_symbols(3)[0]
    s1, c2 = sp.sin(q[0]), sp.cos(q[1])
    cells = [s1 * c2, 0, q[2], sp.Rational(3, 2), s1 + q[2] * c2, 0, c2**2, 0, s1 * q[1], 1, 0, q[0] * q[1] * q[2]]
    cells += [s1 - c2, 0, 0, s1 * c2 * q[2], c2 + 2, q[1] ** 2, 5 * s1, sp.sqrt(q[2] ** 2 + 1)]
    M, v = sp.Matrix(4, 5, cells), sp.Matrix([s1 * q[2], c2 - q[0]])
    program = make_program("mix", [("q", q)], [("M", M), ("v", v)])
    text, lib = _compiled(tmp_path, f"mix{int(split)}{memset}", program)
    assert ("_mix_part2(" in text) == split and ("memset(M" in text) == (memset == 4)
    f = sp.lambdify(q, [M, v], "numpy")
    for x in np.random.default_rng(5).uniform(-2, 2, (4, 3)):
        out = (np.full((4, 5), np.nan), np.full(2, np.nan))
        got = lib.functions["mix"](x, out=out)
        want = f(*x)
        assert np.abs(got[0] - np.array(want[0], dtype=float)).max() <= 1e-15
        assert np.abs(got[1] - np.array(want[1], dtype=float).ravel()).max() <= 1e-15
