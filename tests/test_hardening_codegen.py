"""Generated code and compiled libraries are verified before use: an edited
file is an error, a damaged library is rebuilt, and no input crashes Python.
Whatever could crash runs in a subprocess, so a crash fails the test instead
of ending pytest."""

import os
import subprocess
import sys

import pytest


def _python(code: str, *args: str, **env: str) -> subprocess.CompletedProcess:
    """Run `code` with `args` in a fresh Python, with extra environment variables."""
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=600,
                          env=dict(os.environ, **env))


_LOAD_PUMA_C = """
import sys
import numpy as np
from symdyn import models
from symdyn.codegen import entry as codegen
from symdyn.codegen.emit.clib import CompileOptions, load_library
from symdyn.numeric import reference as ref

folder = codegen.GENERATED / "puma560"
lib = load_library(folder / "puma560.c", folder / "puma560.h", CompileOptions(binding=sys.argv[1]))
q = np.array([0.1, -0.4, 0.3, 0.2, 0.5, -0.6])
print(np.max(np.abs(lib.functions["M"](q) - ref.inertia(models.load("puma560"), q))))
"""


@pytest.mark.parametrize("binding", ["extension", "ctypes"])
def test_a_truncated_library_in_the_cache_is_rebuilt(tmp_path, binding):
    for attempt in ("build", "truncated"):
        run = _python(_LOAD_PUMA_C, binding, SYMDYN_CACHE_DIR=str(tmp_path))
        assert run.returncode == 0, f"{attempt}: exit {run.returncode}: {run.stderr}"
        assert float(run.stdout) < 1e-12, attempt
        (lib,) = tmp_path.glob("c/puma560-*/*.so")
        lib.write_bytes(lib.read_bytes()[:lib.stat().st_size // 3])


_TOO_MANY_DIMENSIONS = """
import sys
import numpy as np
from symdyn.codegen import entry as codegen
from symdyn.codegen.emit.clib import CompileOptions

target, binding = sys.argv[1:]
options = CompileOptions(binding=binding) if target == "c" else None
m = codegen.load("puma560", target, options=options)
q = np.zeros((1,) * 63 + (6,))
for name, args in (("M", (q,)), ("C", (q, q)), ("Y", (q, q, q))):
    try:
        getattr(m, name)(*args)
    except ValueError as exc:
        print(name, exc)
print(m.M(np.zeros((1,) * 62 + (6,))).shape == (1,) * 62 + (6, 6))
"""


@pytest.mark.parametrize("target, binding", [("c", "extension"), ("c", "ctypes"), ("numpy", "")])
def test_too_many_leading_dimensions_are_a_value_error_not_a_crash(target, binding):
    run = _python(_TOO_MANY_DIMENSIONS, target, binding)
    assert run.returncode == 0, f"exit {run.returncode}: {run.stderr}"
    *errors, last = run.stdout.splitlines()
    assert [e.split()[0] for e in errors] == ["M", "C", "Y"]
    for line in errors:
        assert "63 leading dimensions, at most 62" in line and "64" in line, line
    assert last == "True"
