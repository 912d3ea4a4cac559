"""The CUDA target on any machine: its .cu built as plain C++ (the kernels' three phases run thread
by thread on the host) equals the C target on every function of the shipped arms; nvcc, where
installed, compiles it for a GPU; load(model, "cuda") without a GPU says what is missing."""

import ctypes
import shutil
import subprocess

import numpy as np
import pytest

import symdyn
from symdyn.codegen.entry import generate
from symdyn.codegen.emit import cuda, cudalib
from symdyn.codegen.emit.c import Signature, read_signatures
from symdyn.codegen.shipped import SHIPPED
from symdyn.models import load as load_model

from conftest import tiered

CXX = shutil.which("g++") or shutil.which("clang++")


def _host_library(folder, name):
    """The .cu compiled as C++ into a shared library (no CUDA anywhere)."""
    if CXX is None:
        pytest.skip("no C++ compiler (g++ or clang++) to build the .cu as host code")
    lib = folder / f"lib{name}_cuda_host.so"
    subprocess.run(
        [CXX, "-x", "c++", "-std=c++17", "-O1", "-shared", "-fPIC", "-o", str(lib), str(folder / f"{name}.cu")],
        check=True,
        capture_output=True,
    )
    return ctypes.CDLL(str(lib))


def _host_call(lib, name, sig, block, inputs, real=np.float64):
    """Run `<name>_<f>_host[_f32]` on the rows of `inputs`: (outputs, its return value)."""
    n = len(inputs[0])
    args = [np.ascontiguousarray(x, dtype=real) for x in inputs]
    outs = [np.full((n, *shape), np.nan, dtype=real) for _, shape in sig.outputs]
    f = getattr(lib, f"{name}_{sig.name}_host{'_f32' if real == np.float32 else ''}")
    pointer = ctypes.c_void_p
    f.argtypes = [ctypes.c_long, ctypes.c_int] + [pointer] * (len(args) + len(outs))
    f.restype = ctypes.c_int
    status = f(n, block, *(a.ctypes.data for a in args), *(o.ctypes.data for o in outs))
    return outs, status


@pytest.fixture(scope="module", params=tiered(SHIPPED, 1))
def built(request, tmp_path_factory):
    name = request.param
    folder = tmp_path_factory.mktemp(f"cuda-{name}")
    generate(name, "cuda", folder)
    return name, folder, _host_library(folder, name), symdyn.load(name, "c")


def _states(sig, count, seed=1):
    rng = np.random.default_rng(seed)
    return [rng.uniform(-1.5, 1.5, (count, k)) for _, k in sig.inputs]


def test_host_build_equals_the_c_target_on_every_function(built):
    """Every function, 77 states (blocks of 32 and of the kernel's own size, the last one partial),
    to 1e-14 relative to the output's largest entry."""
    name, folder, lib, c_model = built
    sigs = read_signatures((folder / f"{name}_cuda.h").read_text())
    assert [s.name for s in sigs] == list(c_model.functions)
    for sig in sigs:
        inputs = _states(sig, 77)
        expected = c_model.functions[sig.name](*inputs)
        expected = expected if isinstance(expected, tuple) else (expected,)
        for block in (32, cuda.launch(sig).block):
            outs, status = _host_call(lib, name, sig, block, inputs)
            assert status == 0
            for (o, _), got, want in zip(sig.outputs, outs, expected):
                scale = max(1.0, float(np.abs(want).max()))
                assert np.abs(got - want).max() <= 1e-14 * scale, (sig.name, o, block)


def test_float32_kernels_round_the_float64_values_once(built):
    """The _f32 kernels read float32, compute in float64, write float32: the float64 values of
    the float32 inputs rounded once (half a float32 ulp, beyond the float64 values' own 1e-14)."""
    name, folder, lib, c_model = built
    for sig in read_signatures((folder / f"{name}_cuda.h").read_text()):
        if not cuda.launch(sig).staged:
            assert not hasattr(lib, f"{name}_{sig.name}_host_f32")
            continue
        inputs = [x.astype(np.float32) for x in _states(sig, 40, seed=2)]
        outs, status = _host_call(lib, name, sig, 32, inputs, np.float32)
        expected = c_model.functions[sig.name](*(x.astype(np.float64) for x in inputs))
        expected = expected if isinstance(expected, tuple) else (expected,)
        assert status == 0
        for got, want in zip(outs, expected):
            scale = max(1.0, float(np.abs(want).max()))
            assert np.all(np.abs(got - want) <= 2.0**-24 * np.abs(want) + 1e-14 * scale), sig.name


def test_a_nonfinite_input_sets_the_flag(built):
    name, folder, lib, _ = built
    sig = next(s for s in read_signatures((folder / f"{name}_cuda.h").read_text()) if s.name == "tau")
    inputs = _states(sig, 50)
    inputs[1][37, 0] = np.inf
    assert _host_call(lib, name, sig, 32, inputs)[1] == 1
    inputs[1][37, 0] = np.nan
    assert _host_call(lib, name, sig, 32, inputs)[1] == 1
    inputs[1][37, 0] = 0.0
    assert _host_call(lib, name, sig, 32, inputs)[1] == 0


def test_launches_fit_the_shared_memory_every_card_grants():
    """Staged kernels: a multiple of 32 threads, at most 48 KB of shared memory; rows too large
    to stage for 32 threads go direct."""
    for row_in, row_out in [(21, 7), (7, 49), (21, 168), (21, 490), (3, 189), (3, 190)]:
        sig = Signature("f", (("q", row_in),), (("out", (row_out,)),))
        how = cuda.launch(sig)
        if 32 * (row_in + row_out) * 8 <= 48 * 1024:
            assert how.staged and how.block % 32 == 0 and 32 <= how.block <= 256
            assert how.shared == how.block * (row_in + row_out) * 8 <= 48 * 1024
            assert (how.block + 32) * (row_in + row_out) * 8 > 48 * 1024 or how.block == 256
        else:
            assert not how.staged


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("nvcc") is None, reason="nvcc (the CUDA toolkit) is not installed here")
def test_nvcc_compiles_the_source_for_a_gpu(tmp_path):
    """The .cu is valid CUDA: nvcc builds a cubin for sm_80 (no GPU needed), cached by the loader's
    key: a second compile is a file lookup."""
    generate("twolink", "cuda", tmp_path)
    source = (tmp_path / "twolink.cu").read_text()
    use = cudalib.compiler()
    assert use[0] == "nvcc"
    cubin = cudalib.compile_cubin(source, "80", tmp_path, "twolink", use)
    assert cubin.stat().st_size > 0 and cubin.read_bytes()[:4] == b"\x7fELF"
    assert cudalib.compile_cubin(source, "80", tmp_path, "twolink", use) == cubin
    assert cudalib.compile_cubin(source + "\n", "80", tmp_path, "twolink", use) != cubin


@pytest.mark.slow
def test_nvrtc_compiles_the_source_for_a_gpu(tmp_path):
    """The loader's other compiler, NVRTC through its C API (the nvidia-cuda-nvrtc-cu12 wheel of the
    cuda and test extras): a cubin for sm_90 without a GPU."""
    library = cudalib._nvrtc_library()
    if library is None:
        pytest.skip("NVRTC is not installed here (pip install nvidia-cuda-nvrtc-cu12: the test extra has it)")
    generate("twolink", "cuda", tmp_path)
    source = (tmp_path / "twolink.cu").read_text()
    cubin = cudalib.compile_cubin(source, "90", tmp_path, "twolink", ("nvrtc", library, "test"))
    assert cubin.read_bytes()[:4] == b"\x7fELF"
    with pytest.raises(RuntimeError, match="NVRTC failed on twolink.cu"):
        cudalib.compile_cubin(source + "\nthis is not C++;\n", "90", tmp_path, "twolink", ("nvrtc", library, "test"))


def test_the_header_and_source_compile_together_as_cpp(tmp_path):
    """The header's prototypes agree with the source's definitions (one translation unit)."""
    if CXX is None:
        pytest.skip("no C++ compiler")
    generate("twolink", "cuda", tmp_path)
    unit = tmp_path / "both.cpp"
    unit.write_text('#include "twolink_cuda.h"\n#include "twolink.cu"\n')
    subprocess.run([CXX, "-std=c++17", "-fsyntax-only", "-I", str(tmp_path), str(unit)], check=True)


def test_load_without_a_gpu_says_what_is_missing():
    try:
        cudalib.device()
    except RuntimeError as exc:
        message = str(exc)
    else:
        pytest.skip("a GPU with CuPy is here: tests/test_cuda_gpu.py's script checks it")
    with pytest.raises(RuntimeError) as info:
        symdyn.load("puma560", "cuda")
    assert str(info.value) == message
    assert "GPU" in message and ("CuPy" in message or "CUDA" in message)


def test_generate_all_leaves_cuda_out_and_target_cuda_writes_both_files(tmp_path):
    written = generate("twolink", "cuda", tmp_path)
    assert sorted(p.name for p in written) == ["twolink.cu", "twolink_cuda.h"]
    assert not any(p.suffix == ".cu" for p in generate(load_model("twolink"), "all", tmp_path / "all"))
