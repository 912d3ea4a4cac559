"""The C target compiles what is called, when it is first called (issue 33, item 2):
`load_library` compiles nothing of the model; a function's scalar code is its own
translation unit, built into the cache at its first single-state call, its SIMD
kernel another, built at its first batch; each is cached by the sha256 of its text,
verified before it is loaded, and a compiler error names the function.  The
two-link arm: its units compile in a fraction of a second."""

import os
import shutil
import subprocess
import sys
import threading

import numpy as np
import pytest

from symdyn.codegen import entry as codegen
from symdyn.codegen.emit import cbuild, cunits
from symdyn.codegen.emit.clib import CompileOptions, load_library
from tests.codegen_cases import assert_close, cases

BINDINGS = ["extension", "ctypes"]


@pytest.fixture
def twolink(tmp_path, monkeypatch):
    """(c, h) paths of a copy of the two-link arm's code, with a fresh cache."""
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    for suffix in (".c", ".h"):
        shutil.copy(codegen.GENERATED / "twolink" / f"twolink{suffix}", tmp_path / f"twolink{suffix}")
    return tmp_path / "twolink.c", tmp_path / "twolink.h"


def _built(tmp_path) -> list[str]:
    """The unit libraries in the cache, as `<function>.<kind>`."""
    folder = tmp_path / "cache" / "c" / "units"
    return sorted(
        p.name.split(".", 2)[0].removeprefix("twolink_") + "." + p.name.split(".")[1] for p in folder.glob("*.so")
    )


@pytest.mark.parametrize("binding", BINDINGS)
def test_nothing_is_compiled_before_a_call_and_a_call_builds_only_what_it_needs(twolink, tmp_path, binding):
    lib = load_library(*twolink, CompileOptions(binding=binding))
    assert _built(tmp_path) == []
    (q, qd, qdd), tau = cases("twolink")["tau"]
    assert_close(lib.functions["tau"](q[3], qd[3], qdd[3]), tau[3], "tau")
    assert _built(tmp_path) == ["tau.scalar"]
    assert_close(lib.functions["tau"](q, qd, qdd), tau, "tau batched")
    assert _built(tmp_path) == ["tau.scalar", "tau.simd"]
    (q,), M = cases("twolink")["M"]
    assert_close(lib.functions["M"](q), M, "M batched")  # a first batch builds the kernel and its fallback
    assert _built(tmp_path) == ["M.scalar", "M.simd", "tau.scalar", "tau.simd"]
    lib.functions["M"](q[:0])  # an empty batch runs no code
    assert lib.functions["G"](q[:0]).shape == (0, 2) and "G.simd" not in _built(tmp_path)


# make test-all: build() compiling every function ahead is in the main suite on a 3-joint arm's scalar code
# (tests/test_lazy_generation.py::test_build_generates_and_compiles_every_function_ahead), units cached
# by their text in test_nothing_is_compiled_before_a_call_and_a_call_builds_only_what_it_needs
@pytest.mark.slow
def test_build_compiles_every_unit_ahead_and_two_models_share_a_function_of_the_same_text(twolink, tmp_path):
    lib = load_library(*twolink)
    lib.build(["tau", "C"], batch=False)
    assert _built(tmp_path) == ["C.scalar", "tau.scalar"]
    lib.build()
    assert len(_built(tmp_path)) == 2 * len(lib.signatures)
    c_path, h_path = twolink
    c_path.write_text(c_path.read_text().replace("M[3] = 0.25;", "M[3] = 0.5;"))
    changed = load_library(c_path, h_path)
    assert changed.library("tau") == lib.library("tau") and changed.library("M") != lib.library("M")
    assert changed.functions["M"](np.zeros(2))[1, 1] == 0.5 and lib.functions["M"](np.zeros(2))[1, 1] == 0.25


def test_a_large_function_s_parts_travel_with_its_scalar_code(monkeypatch):
    from symdyn.codegen.emit import c as c_emit

    monkeypatch.setattr(c_emit, "SPLIT_ABOVE", 5)
    monkeypatch.setattr(c_emit, "PART_SIZE", 3)
    bundle = codegen.bundle(codegen._robot("twolink"))
    units = cunits.function_units("twolink", c_emit.c_source(bundle), c_emit.h_source(bundle), ["tau", "M"])
    assert "twolink_tau_part1(" in units["tau", "scalar"] and "twolink_tau_part1(" not in units["tau", "simd"]
    assert "twolink_tau_part1(" not in units["M", "scalar"] + units["M", "simd"]
    assert "twolink_M_lanes(" in units["M", "simd"] and "twolink_M_lanes(" not in units["M", "scalar"]
    assert "model-fingerprint" not in units["M", "scalar"]  # provenance is not the code: units are shared


def test_a_file_not_laid_out_as_symdyn_writes_it_is_one_library_for_every_function(twolink, tmp_path):
    c_path, h_path = twolink
    c_path.write_text(c_path.read_text() + "\nstatic double helper(double x) { return x; }\n")
    units = cunits.function_units("twolink", c_path.read_text(), h_path.read_text(), ["tau", "M"])
    assert len(set(units.values())) == 1
    lib = load_library(c_path, h_path)
    (q, qd, qdd), tau = cases("twolink")["tau"]
    assert_close(lib.functions["tau"](q, qd, qdd), tau, "tau batched")
    assert lib.functions["M"](np.zeros(2))[1, 1] == 0.25
    assert [p.name.split(".")[:2] for p in (tmp_path / "cache" / "c" / "units").glob("*.so")] == [["twolink", "whole"]]


_CALL_ALL = """
import sys
import numpy as np
from symdyn.codegen import entry as codegen
from symdyn.codegen.emit import cbuild, clib, cunits

if sys.argv[2] == "cached":  # from now on compiling is an error
    def refuse(*args, **kwargs):
        raise AssertionError("compiled something")
    cunits._compile_units = cbuild.build = refuse
folder = codegen.GENERATED / "twolink"
lib = clib.load_library(folder / "twolink.c", folder / "twolink.h", clib.CompileOptions(binding=sys.argv[1]))
for sig in (s for s in lib.signatures if s.name in ("tau", "M", "fdyn")):
    args = [np.full(k, 0.3) for _, k in sig.inputs]
    one, many = lib.functions[sig.name](*args), lib.functions[sig.name](*(np.stack([a, a]) for a in args))
print(lib.functions["M"](np.array([0.1, -0.4]))[0, 0])
"""


def _python(code: str, *args: str, cache) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code, *args],
        capture_output=True,
        text=True,
        timeout=300,
        env=dict(os.environ, SYMDYN_CACHE_DIR=str(cache)),
    )


# make test-all: a second process and a truncated unit are in the main suite on the two-link arm's M
# (tests/test_hardening_codegen.py::test_a_truncated_library_in_the_cache_is_rebuilt)
@pytest.mark.slow
def test_a_second_process_compiles_nothing_and_a_truncated_unit_is_rebuilt_not_loaded(tmp_path):
    binding = "extension"  # the cache is the binding's, whichever it is (test_hardening_codegen: both)
    first = _python(_CALL_ALL, binding, "build", cache=tmp_path)
    assert first.returncode == 0, first.stderr
    second = _python(_CALL_ALL, binding, "cached", cache=tmp_path)
    assert second.returncode == 0, second.stderr
    assert second.stdout == first.stdout
    (unit,) = (tmp_path / "c" / "units").glob("twolink_M.scalar.*.so")
    unit.write_bytes(unit.read_bytes()[: unit.stat().st_size // 3])  # loaded, it would crash Python
    again = _python(_CALL_ALL, binding, "build", cache=tmp_path)
    assert again.returncode == 0, again.stderr
    assert again.stdout == first.stdout
    assert cbuild.intact(unit)


@pytest.mark.parametrize("binding", BINDINGS)
def test_a_compiler_error_names_the_function_and_spares_the_others(twolink, binding):
    c_path, h_path = twolink
    c_path.write_text(c_path.read_text().replace("void twolink_Minv(", "void twolink_Minv(undeclared_type x, "))
    lib = load_library(c_path, h_path, CompileOptions(binding=binding))
    with pytest.raises(RuntimeError, match=r"(?s)compiling twolink's Minv \(scalar code\) failed .*undeclared_type"):
        lib.functions["Minv"](np.zeros(2))
    with pytest.raises(RuntimeError, match=r"compiling twolink's Minv \(scalar code\) failed"):
        lib.functions["Minv"](np.zeros((3, 2)))  # the kernel needs the scalar code
    assert lib.functions["M"](np.zeros(2))[1, 1] == 0.25


def test_small_units_built_together_share_a_compiler_run_and_a_broken_one_is_named_alone(
    twolink, tmp_path, monkeypatch
):
    runs, sources = [], []
    start = cunits._start

    def spy(cc, job, source, *a):
        runs.append(len(job))
        sources.append(source.read_text())
        return start(cc, job, source, *a)

    monkeypatch.setattr(cunits, "_start", spy)
    lib = load_library(*twolink)
    lib.build(["tau", "M", "G", "F"], batch=False)
    assert _built(tmp_path) == ["F.scalar", "G.scalar", "M.scalar", "tau.scalar"] and max(runs) > 1
    assert len(runs) < 4
    for size, text in zip(runs, sources):  # a group calls one copy of the trigonometric loop
        assert text.startswith("#define SYMDYN_TRIG_LOOP_CALLED\n") == (size > 1)
    folder = tmp_path / "cache" / "c" / "units"
    for unit in folder.glob("*.so"):
        assert cbuild.intact(unit)  # each under its own name, its own hash
    assert not list(folder.glob("*.group.*")) and not list(folder.glob(".*.tmp"))  # nothing left over
    for name in ("tau", "M", "G"):
        args, want = cases("twolink")[name]
        assert_close(lib.functions[name](*args), want, name)
    runs.clear()
    again = load_library(*twolink)  # another library of the same code: each unit found by its own name
    assert_close(again.functions["F"](cases("twolink")["F"][0][0][3]), cases("twolink")["F"][1][3], "F")
    again.build(["tau", "M", "G", "F"], batch=False)
    assert runs == []
    c_path, h_path = twolink
    c_path.write_text(c_path.read_text().replace("void twolink_Minv(", "void twolink_Minv(undeclared_type x, "))
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "other"))
    broken = load_library(c_path, h_path)
    with pytest.raises(RuntimeError, match=r"compiling twolink's Minv \(scalar code\) failed") as failed:
        broken.build(["Minv", "Cqd", "G"], batch=False)
    assert "Cqd" not in str(failed.value) and "G " not in str(failed.value)
    assert_close(broken.functions["Cqd"](*cases("twolink")["Cqd"][0]), cases("twolink")["Cqd"][1], "Cqd")


def test_placing_a_group_s_library_never_writes_into_a_file_a_killed_process_left_linked(tmp_path):
    built, placed, other = tmp_path / "group.tmp", tmp_path / "twolink_M.scalar.x.so", tmp_path / "in_use.so"
    built.write_bytes(b"new library")
    other.write_bytes(b"a library another process has loaded")
    cbuild.record(other)
    stale = placed.with_name(f".{placed.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    os.link(other, stale)  # what a process killed between placing and renaming leaves
    cunits._place(built, placed)
    assert placed.read_bytes() == b"new library" and cbuild.intact(placed)
    assert other.read_bytes() == b"a library another process has loaded" and cbuild.intact(other)
    assert not stale.exists()


def _wait_for_kernel(lib, function: str, seconds: float = 60.0) -> None:
    import time

    end = time.monotonic() + seconds
    while function in lib.units._compiling and time.monotonic() < end:
        time.sleep(0.05)
    assert function not in lib.units._compiling, "the background compile did not finish"


@pytest.mark.parametrize("binding", BINDINGS)
def test_a_large_kernel_compiles_in_the_background_while_the_scalar_code_answers(
    twolink, tmp_path, binding, monkeypatch
):
    """Issue 44, item 6: a batch call never waits for a large kernel's compiler: the scalar code
    answers (the single calls' values, a NaN still refused by name), the kernel is built in the
    background and serves the calls after."""
    monkeypatch.setattr(cunits, "BACKGROUND_BYTES", 0)  # every kernel counts as large
    gate = __import__("threading").Event()
    real = cunits._build_units

    def slow(units):  # the kernel's compile waits until the first batch call has been answered
        if any(u.kind == "simd" for u in units):
            gate.wait(30)
        real(units)

    monkeypatch.setattr(cunits, "_build_units", slow)
    lib = load_library(*twolink, CompileOptions(binding=binding))
    (q, qd, qdd), tau = cases("twolink")["tau"]
    got = lib.functions["tau"](q, qd, qdd)  # answered while the kernel waits to compile
    assert "tau" in lib.units._compiling and _built(tmp_path) == ["tau.scalar"]
    single = np.array([lib.functions["tau"](q[k], qd[k], qdd[k]) for k in range(len(q))])
    np.testing.assert_array_equal(got, single)
    bad = qd.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match="qd contains NaN or infinity"):
        lib.functions["tau"](q, bad, qdd)
    gate.set()
    _wait_for_kernel(lib, "tau")
    assert _built(tmp_path) == ["tau.scalar", "tau.simd"]
    assert_close(lib.functions["tau"](q, qd, qdd), tau, "tau by its kernel")


def test_a_background_kernel_that_fails_raises_at_the_next_batch_call(twolink, monkeypatch):
    monkeypatch.setattr(cunits, "BACKGROUND_BYTES", 0)
    real = cunits._build_units

    def broken(units):
        if any(u.kind == "simd" for u in units):
            raise RuntimeError("compiling twolink's M (batch kernel) failed: injected")
        real(units)

    monkeypatch.setattr(cunits, "_build_units", broken)
    lib = load_library(*twolink)
    (q,), M = cases("twolink")["M"]
    assert_close(lib.functions["M"](q), M, "M by the scalar code")
    _wait_for_kernel(lib, "M")
    with pytest.raises(RuntimeError, match="M \\(batch kernel\\) failed: injected"):
        lib.functions["M"](q)
    assert_close(lib.functions["M"](q[0]), M[0], "the single call still works")


def test_a_compiler_ends_with_the_process_that_started_it(tmp_path):
    """A compile outliving its Python (killed) is ended by the kernel (Linux: PR_SET_PDEATHSIG)."""
    if not sys.platform.startswith("linux"):
        pytest.skip("PR_SET_PDEATHSIG is Linux's")
    script = (
        "import subprocess, sys, time\n"
        "from symdyn.codegen.emit import cunits\n"
        "p = subprocess.Popen([*cunits._with_parent(), 'sleep', '60'])\n"
        "print(p.pid, flush=True)\n"
        "time.sleep(60)\n"
    )
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    child = int(parent.stdout.readline())
    parent.kill()
    parent.wait()
    import time

    for _ in range(100):
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)
    os.kill(child, 9)
    pytest.fail("the child outlived its killed parent")


def test_a_kernel_too_large_to_compile_at_a_call_is_left_to_the_scalar_code(twolink, tmp_path, monkeypatch):
    monkeypatch.setattr(cunits, "BACKGROUND_BYTES", 0)
    monkeypatch.setattr(cunits, "SCALAR_ONLY_BYTES", 0)
    lib = load_library(*twolink)
    (q, qd), C = cases("twolink")["C"]
    assert_close(lib.functions["C"](q, qd), C, "C by the scalar code")
    assert _built(tmp_path) == ["C.scalar"] and not lib.units._compiling
    lib.build(["C"])  # ahead, on request: the kernel after all
    assert _built(tmp_path) == ["C.scalar", "C.simd"]
    assert_close(lib.functions["C"](q, qd), C, "C by its kernel")


def test_a_build_pauses_full_collections_and_gives_the_process_its_thresholds_back(twolink, monkeypatch):
    """No full collection of the cyclic GC while units are made and compiled (it walks every sympy
    expression alive); the process's own thresholds are back after, a failed build's too."""
    import gc

    seen = []
    build = cunits._build_units
    monkeypatch.setattr(cunits, "_build_units", lambda units: seen.append(gc.get_threshold()) or build(units))
    before = gc.get_threshold()
    lib = load_library(*twolink)
    lib.build(["G"], batch=False)
    assert seen == [(before[0], before[1], 10**6)] and gc.get_threshold() == before
    monkeypatch.setattr(cunits, "_build_units", lambda units: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        lib.build(["M"], batch=False)
    assert gc.get_threshold() == before and gc.isenabled()


def test_a_compiler_that_rejects_an_optional_flag_builds_without_it(twolink, tmp_path, monkeypatch):
    """A compiler without gcc's --param or -march=native (`cunits.OPTIONAL_FLAGS`) still builds
    every unit: each flag its message names is dropped in turn and the unit compiled again; the
    values are the reference's.  A fake compiler that rejects both, in that order, logs its runs."""
    log = tmp_path / "runs.log"
    fake = tmp_path / "picky-cc"
    fake.write_text(
        "#!/bin/sh\n"
        f'echo "$*" >> {log}\n'
        'case " $* " in *" --param="*) echo "error: unrecognized option --param=loop-max-datarefs-for-datadeps" >&2; exit 1;; esac\n'
        'case " $* " in *" -march=native "*) echo "error: bad value \'native\' for \'-march=\' switch" >&2; exit 1;; esac\n'
        f'exec {cbuild.compiler()} "$@"\n'
    )
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    lib = load_library(*twolink)
    (q, qd, qdd), tau = cases("twolink")["tau"]
    assert_close(lib.functions["tau"](q, qd, qdd), tau, "tau by its kernel")
    assert _built(tmp_path) == ["tau.scalar", "tau.simd"]
    runs = [line for line in log.read_text().splitlines() if "tau.simd" in line]
    assert [("--param=" in r, "-march=native" in r) for r in runs] == [(True, True), (False, True), (False, False)]


def test_flags_that_set_gcc_s_limit_on_a_loop_s_references_are_kept():
    """A user's own --param=loop-max-datarefs-for-datadeps (its compile cost grows with the square
    of the references) is not overridden by `cunits.WIDE_LOOPS`; a scalar unit never gets it."""
    own = ("-O3", "--param=loop-max-datarefs-for-datadeps=1000")
    assert cunits._unit_flags(own, "", "simd") == own
    assert cunits._unit_flags(("-O3",), "", "simd") == ("-O3", cunits.WIDE_LOOPS)
    assert cunits._unit_flags(("-O3",), "", "scalar") == ("-O3",)
