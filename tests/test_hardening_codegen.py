"""Generated code and compiled libraries are verified before use: an edited
file is an error, a damaged library is rebuilt, and no input crashes Python.
Whatever could crash runs in a subprocess, so a crash fails the test instead
of ending pytest."""

import dataclasses
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from symdyn import models
from symdyn.codegen import entry as codegen
from symdyn.numeric import reference as ref
from tests.conftest import tiered


def _python(code: str, *args: str, **env: str) -> subprocess.CompletedProcess:
    """Run `code` with `args` in a fresh Python, with extra environment variables."""
    return subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=600, env=dict(os.environ, **env)
    )


# The two-link arm: a rebuild is what is tested, and its library compiles in well under a second.
_LOAD_TWOLINK_C = """
import sys
import numpy as np
from symdyn import models
from symdyn.codegen import entry as codegen
from symdyn.codegen.emit.clib import CompileOptions, load_library
from symdyn.numeric import reference as ref

folder = codegen.GENERATED / "twolink"
lib = load_library(folder / "twolink.c", folder / "twolink.h", CompileOptions(binding=sys.argv[1]))
q = np.array([0.1, -0.4])
print(np.max(np.abs(lib.functions["M"](q) - ref.inertia(models.load("twolink"), q))))
"""


@pytest.mark.parametrize("binding", tiered(["ctypes", "extension"], 1))
def test_a_truncated_library_in_the_cache_is_rebuilt(tmp_path, binding):
    for attempt in ("build", "truncated"):
        run = _python(_LOAD_TWOLINK_C, binding, SYMDYN_CACHE_DIR=str(tmp_path))
        assert run.returncode == 0, f"{attempt}: exit {run.returncode}: {run.stderr}"
        assert float(run.stdout) < 1e-12, attempt
        (lib,) = tmp_path.glob("c/units/twolink_M.scalar.*.so")  # M's scalar code: what the call built
        lib.write_bytes(lib.read_bytes()[: lib.stat().st_size // 3])


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


def _edit(path):
    """Change one character of the body of a generated file: the last digit of
    a text file (a coefficient or a size), a letter mid-way through a CasADi file."""
    data = bytearray(path.read_bytes())
    if path.suffix == ".casadi":
        k = len(data) // 2
        data[k] = ord("a") + (data[k] - ord("a") + 1) % 16
    else:
        k = max(data.rfind(str(d).encode()) for d in range(10))
        data[k] = ord("0") + (data[k] - ord("0") + 1) % 10
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("target, suffix", [("numpy", ".py"), ("c", ".c"), ("c", ".h"), ("casadi", ".casadi")])
def test_an_edited_generated_file_is_an_error_that_says_how_to_regenerate(tmp_path, monkeypatch, target, suffix):
    shutil.copytree(codegen.GENERATED / "puma560", tmp_path / "puma560")
    monkeypatch.setattr(codegen, "GENERATED", tmp_path)
    assert codegen.load("puma560", target).G is not None
    path = tmp_path / "puma560" / f"puma560{suffix}"
    _edit(path)
    with pytest.raises(RuntimeError, match=rf"{re.escape(str(path))} was modified.*symdyn generate puma560"):
        codegen.load("puma560", target)


def test_an_edited_file_in_the_generated_code_cache_is_regenerated(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    heavy = dataclasses.replace(models.load("twolink").payload(2.5, (0.1, 0, 0)), name="heavy")
    path = codegen.load(heavy, "numpy").folder / "heavy.py"
    original = path.read_bytes()
    _edit(path)
    q = np.array([[0.3, -0.7], [1.1, 0.4]])
    np.testing.assert_allclose(codegen.load(heavy, "numpy").G(q), ref.gravload(heavy, q), rtol=1e-13)
    assert path.read_bytes() == original


def _snapshot(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_generate_interrupted_midway_leaves_the_old_set(tmp_path, monkeypatch):
    """Issue 12 item 12: a reader sees the old set or the new one, never .py and .h without .c."""
    from symdyn.codegen.emit import c as c_emit

    out = tmp_path / "twolink"
    codegen.generate("twolink", "all", out)
    before = _snapshot(out)
    robot = dataclasses.replace(models.load("twolink"), gravity=(0, 0, 1.62))

    def killed(bundle):
        raise KeyboardInterrupt

    monkeypatch.setattr(c_emit, "c_source", killed)
    with pytest.raises(KeyboardInterrupt):
        codegen.generate(robot, "all", out)
    assert _snapshot(out) == before
    assert [p.name for p in tmp_path.iterdir()] == ["twolink"]


def test_leftovers_of_a_killed_generate_are_cleaned_up_or_restored(tmp_path):
    out = tmp_path / "twolink"
    codegen.generate("twolink", "numpy", out)
    before = _snapshot(out)
    os.rename(out, tmp_path / ".twolink.old-4242")  # killed between the two renames
    (tmp_path / ".twolink.staging-abc").mkdir()  # and a staging folder left behind
    (tmp_path / ".twolink.staging-abc" / "twolink.py").write_text("half")
    codegen.generate("twolink", "c", out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["twolink"]
    after = _snapshot(out)
    assert after["twolink.py"] == before["twolink.py"] and {"twolink.c", "twolink.h"} <= set(after)


def test_generating_and_compiling_into_the_cache_report_progress(tmp_path, monkeypatch, capsys):
    """Steps over REPORT_AFTER_S say what they do on stderr (issue 22 item 6); here the
    threshold is 0 so that a small arm's steps report."""
    from symdyn.derivation import progress
    from symdyn.model.random_arms import ArmOptions, random_arm

    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(progress, "REPORT_AFTER_S", 0.0)
    robot = random_arm(4242, ArmOptions(n_min=2, n_max=2, symbolic=0))
    codegen.load(robot, "numpy")
    err = capsys.readouterr().err
    assert f"symdyn: generating the numpy code of {robot.name}: done in" in err
    # which program it is at, and about how long is left (the quarters of the job, off a terminal)
    from symdyn.codegen.lazy import signatures

    count = len(signatures(robot))  # every function's program: the joint space's and the task space's
    assert re.search(rf"symdyn: programs of {robot.name}: \d+/{count} \w+ \(~\d+ s left\)", err), err
    f = codegen.load(robot, "c")  # each function generated and compiled when first called
    assert "generating" not in capsys.readouterr().err  # (the binding itself may compile, once per Python)
    f.tau(np.zeros(2), np.zeros(2), np.zeros(2))
    err = capsys.readouterr().err
    assert f"symdyn: generating {robot.name}'s tau: done in" in err, err
    assert f"symdyn: compiling {robot.name}'s tau (scalar code): done in" in err, err
    assert "fdyn" not in err
