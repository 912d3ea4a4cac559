"""The CUDA target in Python: a model's `.cu` compiled for this GPU (cached), its kernels called on
device arrays.

Compiled by nvcc where one is found (`$CUDA_PATH/bin`, `$PATH`), else by NVRTC (the library of
CUDA 12's `nvidia-cuda-nvrtc-cu12` wheel, which the `cuda` extra installs, or the toolkit's), into
a cubin for the GPU's architecture, kept in the model's cache folder under a name made of the
source's sha256, the flags, the architecture and the compiler's version: a second load compiles
nothing.  The kernels run through CuPy; arrays of PyTorch (CUDA tensors) and JAX (GPU arrays)
pass by DLPack without a copy and the outputs come back in the caller's library, NumPy arrays are
copied to the device and back (the slow way: the copies cost more than the kernel)."""

from __future__ import annotations

import ctypes
import ctypes.util
import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from ..contract import given
from . import write_atomic
from .c import Signature, read_signatures
from .cuda import HEADER_SUFFIX, launch

__all__ = ["device", "compile_cubin", "compiler", "CudaFunction", "load"]

#: nvcc's and NVRTC's flags: no fast math (IEEE division and square root, as the C target);
#: multiply-adds fused as the GPU does by default (each rounds once: the values stay within
#: ~1e-15 relative of the C target's, and twice the arithmetic per instruction).
NVCC_FLAGS = ("-O3", "-std=c++17")
NVRTC_FLAGS = ("-std=c++17",)


def device():
    """(cupy, the GPU's architecture as "90"), or a RuntimeError saying what is missing."""
    try:
        import cupy
    except ImportError:
        raise RuntimeError(
            "the cuda target needs CuPy and an NVIDIA GPU: pip install 'symdyn[cuda]' (CuPy for CUDA 12); "
            "CuPy is not installed in this Python"
        ) from None
    try:
        count = cupy.cuda.runtime.getDeviceCount()
    except Exception as exc:  # CuPy's CUDARuntimeError: no driver, no device
        raise RuntimeError(f"the cuda target needs an NVIDIA GPU: CUDA finds none here ({exc})") from None
    if count < 1:
        raise RuntimeError("the cuda target needs an NVIDIA GPU: CUDA finds none here")
    return cupy, str(cupy.cuda.Device().compute_capability)


def _nvcc() -> str | None:
    home = os.environ.get("CUDA_PATH") or os.environ.get("CUDA_HOME")
    if home and (Path(home) / "bin" / "nvcc").is_file():
        return str(Path(home) / "bin" / "nvcc")
    return shutil.which("nvcc")


def _nvrtc_library() -> str | None:
    """libnvrtc's path: the nvidia-cuda-nvrtc wheel's, the toolkit's, or the system's."""
    try:
        import nvidia.cuda_nvrtc  # the wheel of the `cuda` extra

        for folder in nvidia.cuda_nvrtc.__path__:
            found = sorted((Path(folder) / "lib").glob("libnvrtc.so*"))
            if found:
                return str(found[0])
    except ImportError:
        pass
    home = os.environ.get("CUDA_PATH") or os.environ.get("CUDA_HOME") or "/usr/local/cuda"
    found = sorted((Path(home) / "lib64").glob("libnvrtc.so*"))
    return str(found[0]) if found else ctypes.util.find_library("nvrtc")


def compiler() -> tuple[str, str, str]:
    """("nvcc" or "nvrtc", its path, its version), or a RuntimeError naming what to install."""
    nvcc = _nvcc()
    if nvcc:
        version = subprocess.run([nvcc, "--version"], capture_output=True, text=True, check=False).stdout
        return "nvcc", nvcc, version.strip().splitlines()[-1] if version.strip() else "?"
    library = _nvrtc_library()
    if library:
        lib = ctypes.CDLL(library)
        major, minor = ctypes.c_int(), ctypes.c_int()
        lib.nvrtcVersion(ctypes.byref(major), ctypes.byref(minor))
        return "nvrtc", library, f"{major.value}.{minor.value}"
    raise RuntimeError(
        "the cuda target needs a CUDA compiler: nvcc (the CUDA toolkit; set CUDA_PATH) or NVRTC "
        "(pip install 'symdyn[cuda]' installs nvidia-cuda-nvrtc-cu12); neither is found"
    )


def _nvrtc(library: str, source: str, arch: str, name: str) -> bytes:
    """The cubin of `source` for sm_`arch` by NVRTC (through its C API)."""
    lib = ctypes.CDLL(library)
    program = ctypes.c_void_p()
    if lib.nvrtcCreateProgram(ctypes.byref(program), source.encode(), f"{name}.cu".encode(), 0, None, None):
        raise RuntimeError(f"NVRTC could not take the source of {name}")
    try:
        options = [f"--gpu-architecture=sm_{arch}".encode(), *(f.encode() for f in NVRTC_FLAGS)]
        status = lib.nvrtcCompileProgram(program, len(options), (ctypes.c_char_p * len(options))(*options))
        if status:
            size = ctypes.c_size_t()
            lib.nvrtcGetProgramLogSize(program, ctypes.byref(size))
            log = ctypes.create_string_buffer(size.value)
            lib.nvrtcGetProgramLog(program, log)
            raise RuntimeError(f"NVRTC failed on {name}.cu (status {status}):\n{log.value.decode(errors='replace')}")
        size = ctypes.c_size_t()
        lib.nvrtcGetCUBINSize(program, ctypes.byref(size))
        cubin = ctypes.create_string_buffer(size.value)
        lib.nvrtcGetCUBIN(program, cubin)
        return cubin.raw
    finally:
        lib.nvrtcDestroyProgram(ctypes.byref(program))


def compile_cubin(source: str, arch: str, folder: Path, name: str, use: tuple[str, str, str] | None = None) -> Path:
    """The cubin of `source` for sm_`arch`, compiled once into `folder` (keyed by the source, the
    flags, the architecture and the compiler's version), by `use` (default: `compiler()`)."""
    kind, path, version = use or compiler()
    flags = NVCC_FLAGS if kind == "nvcc" else NVRTC_FLAGS
    key = hashlib.sha256("\0".join([source, arch, kind, version, *flags]).encode()).hexdigest()[:16]
    cubin = Path(folder) / f"{name}-sm{arch}-{key}.cubin"
    if cubin.is_file():
        return cubin
    if kind == "nvrtc":
        data = _nvrtc(path, source, arch, name)
    else:
        with tempfile.TemporaryDirectory(prefix="symdyn-cuda-") as tmp:
            cu, out = Path(tmp) / f"{name}.cu", Path(tmp) / f"{name}.cubin"
            cu.write_text(source)
            done = subprocess.run(
                [path, "-cubin", f"-arch=sm_{arch}", *flags, "-o", str(out), str(cu)],
                capture_output=True,
                text=True,
                check=False,
            )
            if done.returncode:
                raise RuntimeError(f"nvcc failed on {name}.cu:\n{done.stderr[-4000:]}")
            data = out.read_bytes()
    write_atomic(cubin, data)
    return cubin


def _library(x) -> str:
    """Which library an array belongs to: "cupy", "torch", "jax" or "numpy" (anything else)."""
    root = type(x).__module__.split(".", 1)[0]
    return {"cupy": "cupy", "torch": "torch", "jax": "jax", "jaxlib": "jax"}.get(root, "numpy")


class CudaFunction:
    """One generated function on the GPU: called as the other targets' functions are
    (docs/functions.md), on CuPy, PyTorch or JAX device arrays (or NumPy, copied)."""

    def __init__(self, cupy, module, model: str, sig: Signature) -> None:
        self.__name__ = sig.name
        self.signature = sig
        self.launch = launch(sig)
        self._cupy = cupy
        kinds = ("", "_f32") if self.launch.staged else ("",)
        self._kernels = {s: module.get_function(f"{model}_{sig.name}_kernel{s}") for s in kinds}

    def _device_array(self, x, name: str):
        cp = self._cupy
        library = _library(x)
        if library == "cupy":
            array = x
        elif library in ("torch", "jax") and _on_gpu(x, library):
            array = cp.from_dlpack(x)
        else:
            array = cp.asarray(np.asarray(x))
        if array.dtype.kind == "c":
            raise ValueError(f"{self.__name__}(): {name} is complex; the dynamics take real numbers")
        if array.dtype.kind not in "fiub":
            raise ValueError(f"{self.__name__}(): {name} must be real numbers, got {array.dtype} {array.shape}")
        return array, library

    def __call__(self, *args, out=None, **kwargs):
        cp = self._cupy
        sig = self.signature
        values = given(sig.name, sig.inputs, args, kwargs)
        arrays, libraries = [], []
        for a, size in sig.inputs:
            array, library = self._device_array(values[a], a)
            if array.ndim == 0 or array.shape[-1] != size:
                raise ValueError(f"{sig.name}(): {a} must have shape (..., {size}), got {tuple(array.shape)}")
            arrays.append(array)
            libraries.append(library)
        try:
            lead = np.broadcast_shapes(*(tuple(x.shape[:-1]) for x in arrays))
        except ValueError:
            shapes = ", ".join(f"{a} {tuple(x.shape[:-1])}" for (a, _), x in zip(sig.inputs, arrays))
            raise ValueError(
                f"{sig.name}(): the leading shapes of the arguments do not broadcast together: {shapes}"
            ) from None
        single = all(x.dtype == cp.float32 for x in arrays) and "_f32" in self._kernels
        dtype = cp.float32 if single else cp.float64
        n = int(np.prod(lead, dtype=np.int64))
        flat = [
            cp.ascontiguousarray(cp.broadcast_to(x.astype(dtype, copy=False), (*lead, x.shape[-1]))) for x in arrays
        ]
        outs = self._outputs(out, lead, dtype)
        chosen = list(zip(sig.outputs, outs)) if out is not None else []
        for j, ((o, _), view) in enumerate(chosen):
            for (a, _), x in zip(sig.inputs, flat):  # a matrix's entries are stored as they are computed
                if cp.may_share_memory(view, x):
                    raise ValueError(
                        f"{sig.name}(): out= for {o} shares memory with the input {a}: give it an array of its own"
                    )
            for (p, _), other in chosen[:j]:
                if cp.may_share_memory(view, other):
                    raise ValueError(f"{sig.name}(): out= for {o} and {p} share memory: give each an array of its own")
        if n:
            bad = cp.zeros(1, dtype=cp.int32)
            self.run(n, flat, outs, bad)
            if int(bad.get()[0]):
                for (a, _), x in zip(sig.inputs, flat):
                    if not bool(cp.isfinite(x).all()):
                        raise ValueError(f"{sig.name}(): {a} contains NaN or infinity")
        library = "numpy" if "numpy" in libraries else next((lib for lib in libraries if lib != "cupy"), "cupy")
        results = tuple(_back(o, library) for o in outs) if out is None else out
        return results[0] if len(results) == 1 and out is None else (results if out is None else out)

    def run(self, n: int, inputs: list, outputs: list, bad) -> None:
        """Launch the kernel on the current CuPy stream, without checks and without waiting: `n`
        states of C-contiguous CuPy arrays, all float64 or all float32 (a staged function), of
        shapes (n, size); `bad`, an int32 CuPy array set to 1 where an input is NaN or infinite.
        What a pipeline of kernels or a benchmark calls; everyone else calls the function."""
        how = self.launch
        kernel = self._kernels["_f32" if inputs[0].dtype == self._cupy.float32 else ""]
        grid = ((n + how.block - 1) // how.block,)
        kernel(grid, (how.block,), (np.int64(n), bad, *inputs, *outputs), shared_mem=how.shared)

    def _outputs(self, out, lead: tuple, dtype) -> list:
        """Fresh device arrays for the outputs, or the caller's `out=` (CuPy or PyTorch CUDA arrays of
        exactly the right shape and dtype, C-contiguous: written in place)."""
        cp = self._cupy
        shapes = [(*lead, *s) for _, s in self.signature.outputs]
        if out is None:
            return [cp.empty(s, dtype=dtype) for s in shapes]
        given_out = out if isinstance(out, tuple) else (out,)
        if len(given_out) != len(shapes):
            raise ValueError(f"{self.__name__}(): out= needs {len(shapes)} arrays, got {len(given_out)}")
        views = []
        for (o, _), x, shape in zip(self.signature.outputs, given_out, shapes):
            library = _library(x)
            view = x if library == "cupy" else cp.from_dlpack(x) if library == "torch" and _on_gpu(x, library) else None
            if view is None or tuple(view.shape) != shape or view.dtype != dtype or not view.flags.c_contiguous:
                raise ValueError(
                    f"{self.__name__}(): out= for {o} must be a C-contiguous {np.dtype(dtype).name} CuPy array or "
                    f"PyTorch CUDA tensor of shape {shape}"
                )
            views.append(view)
        return views

    def __repr__(self) -> str:
        return f"<{self.__name__} on the GPU: {self.signature.line()}>"


def _on_gpu(x, library: str) -> bool:
    if library == "torch":
        return x.device.type == "cuda"
    return any(d.platform == "gpu" for d in x.devices())


def _back(array, library: str):
    """A device array in the caller's library: CuPy itself, PyTorch and JAX by DLPack, NumPy copied."""
    if library == "torch":
        import torch

        return torch.from_dlpack(array)
    if library == "jax":
        import jax.numpy as jnp

        return jnp.from_dlpack(array)
    if library == "numpy":
        return array.get()
    return array


def load(folder: Path, name: str, cupy, arch: str) -> dict:
    """{function name: CudaFunction} of the model `name` whose .cu and header lie in `folder`."""
    folder = Path(folder)
    source = (folder / f"{name}.cu").read_text()
    cubin = compile_cubin(source, arch, folder, name)
    module = cupy.RawModule(path=str(cubin))
    sigs = read_signatures((folder / f"{name}{HEADER_SUFFIX}").read_text())
    return {s.name: CudaFunction(cupy, module, name, s) for s in sigs}
