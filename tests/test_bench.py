"""Smoke tests of the benchmark (symdyn.bench): the C harness compiles, runs and
times code that agrees with the reference; the table reports speed-ups.  No
timing assertions (the machine is shared and noisy)."""

import math
import re

import numpy as np
import pytest

from symdyn import models
from symdyn.bench import compare as bench
from symdyn.codegen.entry import GENERATED

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


def test_op_counts_read_from_generated_header(tmp_path):
    header = ("/*\n * operation counts (a - b counts as one add, negation is free):\n"
              " *   tau   230 mul, 171 add, 16 fun (417 total)  [newton-euler]\n"
              " *   fdyn  411 mul, 297 add, 6 div, 16 fun (730 total)  [newton-euler]\n */\n"
              "void m_tau(void) { /* 12 mul (99 total) is not in the header */ }\n")
    (tmp_path / "m.c").write_text(header)
    assert bench.op_counts(tmp_path / "m.c") == {"tau": 417, "fdyn": 730}
    shipped = bench.op_counts(PUMA / "puma560.c")
    functions = re.findall(r"function: (\w+)\(", (PUMA / "puma560.h").read_text())
    assert sorted(shipped) == sorted(functions) and all(n > 0 for n in shipped.values())


def test_table_has_speed_up_and_target_columns():
    rows = [bench.Row("C", "tau", (100.0, 125.0, 90.0), "Pinocchio rnea", (850.0, 900.0, 800.0), 369, 8),
            bench.Row("C", "M", (200.0,), "Pinocchio crba", (850.0,), 196, 6),
            bench.Row("C", "G", (50.0,), "Pinocchio computeGeneralizedGravity", (), 48)]
    assert [r.ratio for r in rows] == [8.5, 4.25, None]
    assert rows[0].spread == (900.0 / 125.0, 800.0 / 90.0) and rows[1].spread is None
    assert [r.met for r in rows] == ["yes", "no", ""]
    text = bench.format_table(rows)
    header = text.splitlines()[0].split()
    assert {"symdyn", "peer", "speed-up", "range", "ops", "target", "met"} <= set(header)
    assert "8.50×" in text and "7.20–8.89" in text and "4.25×" in text and "n/a" in text
    md = bench.markdown_table(rows).splitlines()
    assert md[0].startswith("| level | function | symdyn ns") and "speed-up" in md[0]
    assert len(md) == 2 + len(rows) and "| 8.50× | 7.20–8.89 | 369 | ≥ 8× | yes |" in md[2]


def test_missing_pin_peer_says_how_to_fix(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    binary, why = bench.pin_harness(tmp_path / "nowhere")
    assert binary is None
    assert "--pin-bench-dir" in why or "pip install pin" in why
