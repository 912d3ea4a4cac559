"""Excitation design (`symdyn.identify.excitation`): better conditioned than its random start,
inside every limit along the sampled trajectory, at rest at both ends, written as CSV/JSON/plot.

The two-link arm, 3 harmonics over 4 s (about a second of IPOPT); the torque limit is set
below what the unconstrained design would use, so the torque constraint is active.
"""

from __future__ import annotations

import argparse
import csv
import json

import numpy as np
import pytest

from symdyn import models
from symdyn.codegen.entry import load
from symdyn.identify.excitation import ExcitationLimits, configure_parser, excitation, run_cli
from symdyn.numeric.reference import rne

TAU = np.array([25.0, 6.0])


@pytest.fixture(scope="module")
def twolink():
    return models.load("twolink")


@pytest.fixture(scope="module")
def designed(twolink):
    limits = ExcitationLimits.for_robot(twolink, q=[[-2.0, 2.5], [-1.5, 1.5]], qd=[1.5, 2.0], qdd=[6.0, 8.0], tau=TAU)
    return excitation(twolink, period=4, harmonics=3, limits=limits, seed=3)


def test_the_optimised_condition_number_is_lower_than_the_random_start(designed, twolink):
    assert designed.condition < 0.2 * designed.random_condition
    # the reported number is the stacked base regressor's, recomputed independently
    Y = load("twolink", "casadi").functions["Y"]
    from symdyn.identify.consistent import _base

    cols = list(_base(twolink).independent)
    t = np.arange(designed.samples) * designed.period / designed.samples
    q, qd, qdd = designed.at(t)
    W = np.vstack([np.asarray(Y(a, b, c))[:, cols] for a, b, c in zip(q, qd, qdd)])
    assert np.linalg.cond(W) == pytest.approx(designed.condition, rel=1e-6)


def test_every_limit_holds_along_the_sampled_trajectory(designed, twolink):
    t, q, qd, qdd = designed.sample(rate=1000)
    lim = designed.limits
    assert np.all(q >= lim.q[:, 0]) and np.all(q <= lim.q[:, 1])
    assert np.all(np.abs(qd) <= lim.qd) and np.all(np.abs(qdd) <= lim.qdd)
    tau = rne(twolink, q, qd, qdd)
    assert np.all(np.abs(tau) <= TAU)
    assert np.abs(tau).max(0) @ (1 / TAU) > 0.9  # the torque limit shapes the design (one joint near it)
    # and the motion uses its room: not a trivially small trajectory
    assert np.all(np.ptp(q, axis=0) > 0.5)


def test_the_trajectory_starts_and_ends_at_rest(designed):
    q, qd, qdd = designed.at([0.0, designed.period])
    np.testing.assert_allclose(qd, 0, atol=1e-12)
    np.testing.assert_allclose(qdd, 0, atol=1e-12)
    np.testing.assert_allclose(q[0], q[1], atol=1e-12)


def test_logdet_criterion_raises_the_determinant(twolink):
    d = excitation(twolink, period=4, harmonics=3, criterion="logdet", seed=3)
    assert d.logdet > d.random_logdet and d.criterion == "logdet"


def test_write_gives_csv_json_and_plot(designed, tmp_path):
    paths = designed.write(tmp_path, rate=50)
    assert sorted(p.name for p in paths) == ["excitation.csv", "excitation.json", "excitation.png"]
    with open(tmp_path / "excitation.csv") as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == ["t", "q1", "q2", "qd1", "qd2", "qdd1", "qdd2"]
    assert len(rows) - 1 == 4 * 50 + 1
    data = np.array(rows[1:], dtype=float)
    t, q, qd, qdd = designed.sample(50)
    np.testing.assert_array_equal(data, np.column_stack([t, q, qd, qdd]))
    info = json.loads((tmp_path / "excitation.json").read_text())
    assert info["condition"] == designed.condition and info["random_condition"] == designed.random_condition


def test_the_command_line_writes_the_design(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    configure_parser(parser)
    args = parser.parse_args(
        ["twolink", "--period", "2", "--harmonics", "2", "--rate", "20", "--max-iter", "15", "--out", str(tmp_path)]
    )
    assert run_cli(args) == 0
    assert "condition number" in capsys.readouterr().out
    assert (tmp_path / "excitation.csv").is_file()


def test_bad_arguments_are_named(twolink):
    with pytest.raises(ValueError, match="unknown criterion 'det'"):
        excitation(twolink, criterion="det")
    with pytest.raises(ValueError, match="harmonics must be an integer ≥ 2"):
        excitation(twolink, harmonics=1)


@pytest.mark.parametrize("rate", [0, 0.0, -50.0, float("nan"), float("inf"), True])
def test_a_rate_that_is_not_a_positive_finite_number_is_named(twolink, rate):
    """rate=0 used to fall back to the default grid and a negative rate gave an empty one."""
    with pytest.raises(ValueError, match=rf"rate must be a positive, finite sample rate in Hz .*got {rate!r}"):
        excitation(twolink, period=2.0, harmonics=2, rate=rate, max_iter=3)
    with pytest.raises(ValueError, match=r"rate=0.1 Hz gives no design sample in a period of 2.0 s"):
        excitation(twolink, period=2.0, harmonics=2, rate=0.1, max_iter=3)
