"""Smoke tests of the benchmark (symdyn.bench): the C harness compiles, runs and
times code that agrees with the reference; the table reports speed-ups.  No
timing assertions (the machine is shared and noisy)."""

import importlib.util
import math

import numpy as np
import pytest

from symdyn import bench, models
from symdyn.codegen import GENERATED

PUMA = GENERATED / "puma560"
FUNCTIONS = ("tau", "M", "C", "Cqd", "G", "fdyn", "casadi_rnea")


@pytest.fixture(scope="module")
def harness_run(tmp_path_factory):
    """The shipped Puma 560 and CasADi's plain RNEA in one harness, run with 1000 calls."""
    cache = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SYMDYN_CACHE_DIR", str(cache))
        robot = models.load("puma560")
        states = bench.random_states(robot.nofriction(all=True), bench.POOL, seed=1)
        casadi_c = bench.casadi_rnea_c(robot, cache / "casadi")
        binary = bench.build_harness(PUMA / "puma560.c", PUMA / "puma560.h", casadi_c)
        path = bench.write_states(cache / "states.bin", *states)
        times, checks = bench.run_harness(binary, path, ncalls=1000, reps=3)
    return robot, states, times, checks


def test_harness_times_every_function(harness_run):
    _, _, times, checks = harness_run
    assert set(times) == set(FUNCTIONS) == set(checks)
    assert all(math.isfinite(t) and t > 0 for t in times.values()), times


def test_harness_outputs_agree_with_reference(harness_run):
    robot, states, _, checks = harness_run
    assert bench.check_harness(robot, checks, *states) < 1e-9
    assert checks["M"].shape == (36,) and checks["fdyn"].shape == (6,)


def test_harness_check_rejects_wrong_output(harness_run):
    robot, states, _, checks = harness_run
    wrong = dict(checks, M=checks["M"] + np.eye(6).ravel() * 1e-3)
    with pytest.raises(RuntimeError, match="M at state 3"):
        bench.check_harness(robot, wrong, *states)


def test_states_pool_must_be_power_of_two(tmp_path):
    q = np.zeros((6, 6))
    with pytest.raises(ValueError, match="power-of-two"):
        bench.write_states(tmp_path / "s.bin", q, q, q, q)


def test_op_counts_read_from_generated_header():
    spec = importlib.util.spec_from_file_location("_bench_puma560_numpy", PUMA / "puma560.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert bench.op_counts(PUMA / "puma560.c") == {f: c["total"] for f, c in module.OP_COUNTS.items()}


def test_table_has_speed_up_and_target_columns():
    rows = [bench.Row("C", "tau", 100.0, "Pinocchio rnea", 850.0, 369, 8),
            bench.Row("C", "M", 200.0, "Pinocchio crba", 850.0, 196, 6),
            bench.Row("C", "G", 50.0, "Pinocchio computeGeneralizedGravity", None, 48)]
    assert [r.ratio for r in rows] == [8.5, 4.25, None]
    assert [r.met for r in rows] == ["yes", "no", ""]
    text = bench.format_table(rows)
    header = text.splitlines()[0].split()
    assert {"symdyn", "peer", "speed-up", "ops", "target", "met"} <= set(header)
    assert "8.50×" in text and "4.25×" in text and "n/a" in text
    md = bench.markdown_table(rows).splitlines()
    assert md[0].startswith("| level | function | symdyn ns") and "speed-up" in md[0]
    assert len(md) == 2 + len(rows) and "| 8.50× | 369 | ≥ 8× | yes |" in md[2]


def test_missing_pin_peer_says_how_to_fix(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    binary, why = bench.pin_harness(tmp_path / "nowhere")
    assert binary is None
    assert "--pin-bench-dir" in why or "pip install pin" in why
