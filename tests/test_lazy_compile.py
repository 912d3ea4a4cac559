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

import numpy as np
import pytest

from symdyn.codegen import entry as codegen
from symdyn.codegen.emit import clib
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
    units = clib.function_units("twolink", c_emit.c_source(bundle), c_emit.h_source(bundle), ["tau", "M"])
    assert "twolink_tau_part1(" in units["tau", "scalar"] and "twolink_tau_part1(" not in units["tau", "simd"]
    assert "twolink_tau_part1(" not in units["M", "scalar"] + units["M", "simd"]
    assert "twolink_M_lanes(" in units["M", "simd"] and "twolink_M_lanes(" not in units["M", "scalar"]
    assert "model-fingerprint" not in units["M", "scalar"]  # provenance is not the code: units are shared


def test_a_file_not_laid_out_as_symdyn_writes_it_is_one_library_for_every_function(twolink, tmp_path):
    c_path, h_path = twolink
    c_path.write_text(c_path.read_text() + "\nstatic double helper(double x) { return x; }\n")
    units = clib.function_units("twolink", c_path.read_text(), h_path.read_text(), ["tau", "M"])
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
from symdyn.codegen.emit import clib

if sys.argv[2] == "cached":  # from now on compiling is an error
    def refuse(*args, **kwargs):
        raise AssertionError("compiled something")
    clib._compile_units = clib._build = refuse
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
    assert clib._intact(unit)


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
