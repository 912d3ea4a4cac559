"""generated/: reproducible byte for byte, headed with its provenance, stale files detected."""

import argparse
import dataclasses
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import symdyn
from symdyn import models
from symdyn.codegen import entry as codegen
from symdyn.codegen.emit import read_header, write_atomic
from symdyn.numeric import reference as ref
from tests.codegen_cases import assert_close
from tests.conftest import tiered

TARGETS = ("numpy", "c", "casadi")


def difference(got: Path, committed: Path) -> str | None:
    """None where the files are equal byte for byte, else their first differing line: a short
    message (pytest's own diff of two large files takes minutes)."""
    a, b = got.read_bytes(), committed.read_bytes()
    if a == b:
        return None
    for k, (x, y) in enumerate(zip(a.splitlines(), b.splitlines()), 1):
        if x != y:
            return f"{committed} line {k}: regenerated {x[:200]!r}, committed {y[:200]!r}"
    return f"{committed}: {len(a.splitlines())} lines regenerated, {len(b.splitlines())} committed"


def test_generated_holds_exactly_the_shipped_models():
    folders = sorted(p.name for p in codegen.GENERATED.iterdir() if p.is_dir() and p.name != "__pycache__")
    assert folders == sorted(codegen.SHIPPED)


# twolink and the Puma 560 in the main suite; the others (the Panda, the iiwa, the UR5: 9, 9, 4 s): make test-all
MAIN_FIRST = sorted(codegen.SHIPPED, key=lambda name: name not in ("twolink", "puma560"))


@pytest.mark.parametrize("name", tiered(MAIN_FIRST, 2))
def test_regenerating_reproduces_generated_byte_for_byte(tmp_path, name):
    """One model per test, so that the suite's workers share the regeneration."""
    written = codegen.generate(name, "all", tmp_path)
    expected = sorted(p.name for p in (codegen.GENERATED / name).iterdir() if p.is_file())
    assert sorted(p.name for p in written) == expected
    differences = [d for file in expected if (d := difference(tmp_path / file, codegen.GENERATED / name / file))]
    assert not differences, "regenerate with `symdyn generate --all`: " + "; ".join(differences)


@pytest.mark.parametrize("name", codegen.SHIPPED)
def test_files_are_headed_with_version_fingerprint_and_op_counts(name):
    fingerprint = models.load(name).fingerprint()
    for suffix in (".py", ".c", ".h"):
        text = (codegen.GENERATED / name / f"{name}{suffix}").read_text()
        assert read_header(text) == {"symdyn-version": symdyn.__version__, "model-fingerprint": fingerprint}
        assert "operation counts" in text and f"regenerate: symdyn generate {name}" in text


def _stale_copy(tmp_path, monkeypatch):
    """generated/twolink regenerated for a heavier arm, posing as the shipped one."""
    heavy = dataclasses.replace(models.load("twolink").payload(2.5, (0.1, 0, 0)), name="twolink")
    codegen.generate(heavy, "all", tmp_path / "twolink")
    monkeypatch.setattr(codegen, "GENERATED", tmp_path)
    return heavy


@pytest.mark.parametrize("target", TARGETS)
def test_loading_a_stale_file_is_an_error_that_says_how_to_regenerate(tmp_path, monkeypatch, target):
    _stale_copy(tmp_path, monkeypatch)
    with pytest.raises(RuntimeError, match=r"is stale.*symdyn generate twolink"):
        codegen.load("twolink", target)


def test_a_robot_other_than_the_files_is_generated_into_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    heavy = _stale_copy(tmp_path, monkeypatch)
    shutil.rmtree(tmp_path / "twolink")
    robot = dataclasses.replace(heavy, base=models.load("twolink").base)  # same arm, as a Robot object
    m = codegen.load(robot, "numpy")
    assert m.folder.is_relative_to(tmp_path / "cache")
    q = np.array([[0.3, -0.7], [1.1, 0.4]])
    assert_close(m.tau(q, -q, 2 * q), ref.rne(robot, q, -q, 2 * q), "payload arm tau")


def test_loaded_model_lists_its_functions():
    m = codegen.load("puma560", "numpy")
    assert list(m.functions) == [
        "tau",
        "M",
        "C",
        "Cqd",
        "G",
        "F",
        "fdyn",
        "Y",
        "tau_derivatives",
        "fdyn_derivatives",
        "Minv",
        "frame_pose",
        "frame_jacobian",
        "frame_jacobian_aligned",
        "frame_velocity",
        "frame_acceleration",
        "frame_drift",
        "com",
        "com_jacobian",
        "com_drift",
        "centroidal_map",
        "centroidal_drift",
        "frame_kinematics",
        "centroidal",
    ]
    with pytest.raises(AttributeError, match="'aba'"):
        m.aba
    with pytest.raises(ValueError, match="unknown target 'fortran'"):
        codegen.load("puma560", "fortran")
    with pytest.raises(KeyError, match="unknown model 'puma'"):
        codegen.load("puma", "numpy")


def test_write_atomic_leaves_the_old_file_when_interrupted(tmp_path, monkeypatch):
    path = write_atomic(tmp_path / "f.py", "old\n")

    def fail(*args):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError):
        write_atomic(path, "new\n")
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["f.py"]


def test_cli_generate_writes_one_target(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    codegen.configure_parser(parser)
    args = parser.parse_args(["twolink", "--target", "numpy", "--out", str(tmp_path)])
    assert args.func(args) == 0
    assert [p.name for p in tmp_path.iterdir()] == ["twolink.py"]
    assert difference(tmp_path / "twolink.py", codegen.GENERATED / "twolink" / "twolink.py") is None
    with pytest.raises(ValueError, match="model name or --all"):
        args.func(parser.parse_args([]))


def test_generate_needs_out_dir_for_a_model_not_shipped_as_is():
    heavy = models.load("twolink").payload(2.5, (0.1, 0, 0))
    with pytest.raises(ValueError, match="needs out_dir"):
        codegen.generate(heavy, "numpy")


def test_symbolic_model_takes_its_parameters_as_last_argument(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    robot = models.load("twolink", symbolic=True)
    m = codegen.load(robot, "numpy")
    names = [str(s) for s in sorted(robot.free_symbols, key=str)]
    assert m.tau.__doc__.endswith(f"p = ({', '.join(names)}).")
    values = {"a1": 1.0, "a2": 0.8, "c1": -0.5, "c2": -0.3, "g": 9.81, "m1": 1.2, "m2": 0.7}
    numeric = robot.subs(values)
    p = np.array([values[k] for k in names])
    q = np.array([[0.3, -0.7], [1.1, 0.4]])
    assert_close(m.tau(q, -q, 2 * q, p), ref.rne(numeric, q, -q, 2 * q), "symbolic twolink tau")
    assert_close(m.fdyn(q, -q, m.tau(q, -q, 2 * q, p), p), 2 * q, "symbolic twolink fdyn")
