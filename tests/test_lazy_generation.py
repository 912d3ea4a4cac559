"""A model that is not shipped is generated function by function (issue 33): `load(robot, "c")`
derives, prints and compiles a function when it is first called, keeps its C file in the
model's cache folder (sealed), and a second process derives nothing for what is there."""

import subprocess
import sys

import numpy as np
import pytest

import symdyn
from symdyn.codegen.lazy import signatures
from symdyn.model.random_arms import ArmOptions, random_arm
from symdyn.numeric import reference as ref

ARM = "random_arm(31, ArmOptions(general=1.0, symbolic=0.0), n=3)"


def _arm():
    return random_arm(31, ArmOptions(general=1.0, symbolic=0.0), n=3)


def test_a_function_is_generated_when_first_called_and_agrees_with_the_reference(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    robot = _arm()
    model = symdyn.load(robot, "c")
    assert sorted(p.name for p in model.folder.glob("*.c")) == []
    q, qd, qdd = (np.random.default_rng(3).uniform(-1, 1, (5, robot.n)) for _ in range(3))
    np.testing.assert_allclose(model.tau(q[0], qd[0], qdd[0]), ref.rne(robot, q[0], qd[0], qdd[0]), atol=1e-12)
    assert sorted(p.name for p in model.folder.glob("*.c")) == [f"{model.name}.tau.c"]
    tau = ref.rne(robot, q, qd, qdd)
    np.testing.assert_allclose(model.fdyn(q, qd, tau), qdd, atol=1e-11)  # a batch: its kernel too
    assert sorted(p.name for p in model.folder.glob("*.c")) == sorted(f"{model.name}.{f}.c" for f in ("tau", "fdyn"))
    assert list(model.functions) == [s.name for s in signatures(robot)]
    for sig in signatures(robot):  # every function's shapes are those of the whole file's
        out = model.functions[sig.name](*(np.zeros(k) for _, k in sig.inputs))
        shapes = [o.shape for o in (out if isinstance(out, tuple) else (out,))]
        assert shapes == [shape for _, shape in sig.outputs], sig.name


def _second_process(cache, code: str) -> subprocess.CompletedProcess:
    prelude = (
        "import numpy as np, symdyn, symdyn.derivation.entry as de\n"
        "from symdyn.model.random_arms import ArmOptions, random_arm\n"
        "def refuse(*a, **k): raise SystemExit('derived')\n"
        "de.derive = refuse\n"
        f"robot = {ARM}\nmodel = symdyn.load(robot, 'c')\nz = np.full(robot.n, 0.2)\n"
    )
    env = {"SYMDYN_CACHE_DIR": str(cache), "PATH": "/usr/bin:/bin"}
    return subprocess.run([sys.executable, "-c", prelude + code], env=env, capture_output=True, text=True)


def test_a_second_process_derives_nothing_and_an_edited_file_is_rebuilt(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    robot = _arm()
    model = symdyn.load(robot, "c")
    z = np.full(robot.n, 0.2)
    expected = model.tau(z, z, z)
    run = _second_process(tmp_path, "print(repr(model.tau(z, z, z).tolist()))")
    assert run.returncode == 0, run.stderr
    assert np.array_equal(eval(run.stdout), expected)
    path = model.folder / f"{model.name}.tau.c"
    path.write_text(path.read_text().replace("const double", "const  double", 1))  # edited: not intact
    run = _second_process(tmp_path, "model.tau(z, z, z)")
    assert run.returncode != 0 and "derived" in run.stdout + run.stderr  # it wanted to generate tau again
    assert np.array_equal(symdyn.load(robot, "c").tau(z, z, z), expected)
    assert "const  double" not in path.read_text()


def test_build_generates_and_compiles_every_function_ahead(tmp_path, monkeypatch):
    """`build()` makes every function's C file and compiles it (the next one generated while the
    last compiles), so that no later call generates or compiles anything."""
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    robot = _arm()
    model = symdyn.load(robot, "c")
    model.build(batch=False)
    assert sorted(p.name for p in model.folder.glob("*.c")) == sorted(
        f"{model.name}.{s.name}.c" for s in signatures(robot)
    )
    built = set((tmp_path / "c" / "units").glob(f"{model.name}_*.scalar.*.so"))
    assert sorted(p.name.split(".")[0] for p in built) == sorted(f"{model.name}_{s.name}" for s in signatures(robot))
    run = _second_process(tmp_path, "model.fdyn_derivatives(z, z, z); model.Y(z, z, z)")  # derives nothing
    assert run.returncode == 0, run.stderr
    assert set((tmp_path / "c" / "units").glob(f"{model.name}_*.scalar.*.so")) == built  # compiles nothing
    with pytest.raises(ValueError, match="build\\(\\) compiles the C target"):
        symdyn.load(robot, "numpy").build()
