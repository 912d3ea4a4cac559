"""Physically consistent standard parameters from base parameters (`symdyn.identify.consistent`).

Specifications: noise-free base parameters of a realisable arm come back
exactly (to solver tolerance) from a prior that is 20 % off; the robot
found carries them back to its own link frames exactly (the reference `rne`
of `.robot` equals Y·π with the generated regressor); every pseudo-inertia
is positive semidefinite; a physically impossible base set is moved to a
realisable one and the move is reported.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from symdyn import models
from symdyn.codegen.entry import load
from symdyn.identify.consistent import _base, base_vector, physical, pseudo_inertia
from symdyn.numeric.reference import rne


def _perturbed(robot, seed: int, amount: float = 0.2):
    """Masses, COMs, inertias (kept physical: scaled, plus a little isotropic inertia) and
    friction changed by up to ±amount."""
    rng = np.random.default_rng(seed)
    links = []
    for link in robot.links:
        k = 1 + amount * rng.uniform(-1, 1)
        I = np.array(link.I, dtype=float) * k + 1e-3 * np.eye(3)
        links.append(
            dataclasses.replace(
                link,
                m=float(link.m) * k,
                r=tuple(float(x) * (1 + amount * rng.uniform(-1, 1)) + 0.01 for x in link.r),
                I=tuple(map(tuple, I)),
                B=float(link.B) * (1 + amount * rng.uniform(-1, 1)),
                Tc=tuple(float(x) * (1 + amount * rng.uniform(-1, 1)) for x in link.Tc),
            )
        )
    return dataclasses.replace(robot, links=tuple(links))


def _states(robot, count=16, seed=0):
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    return (
        rng.uniform(lo, hi, (count, robot.n)),
        rng.uniform(-2, 2, (count, robot.n)),
        rng.uniform(-5, 5, (count, robot.n)),
    )


def _assert_realisable(result, tol=1e-9):
    for j, v in enumerate(np.array(list(result.standard.values())).reshape(result.robot.n, 14)):
        J = pseudo_inertia([[v[0], v[1], v[2]], [v[1], v[3], v[4]], [v[2], v[4], v[5]]], v[6:9], v[9])
        assert np.linalg.eigvalsh(J).min() >= -tol * max(1.0, np.abs(J).max()), f"link {j + 1}"
        assert v[10] >= 0 and v[11] >= 0 and v[12] >= abs(v[13]), f"link {j + 1}: IA, FV, FS ≥ |FO|"
    assert np.all(result.margins >= -tol)


def test_noise_free_base_parameters_of_a_realisable_arm_come_back_exactly():
    """The Puma (standard DH, α = ±π/2: the regressor's modified-DH frames are turned and
    shifted from the robot's own) from a prior 20 % off.  The robot found carries the standard
    parameters back to its own frames exactly: the reference's torques of `.robot` equal
    Y(q, q̇, q̈)·π with the generated regressor, and equal the truth's."""
    robot = models.load("puma560")
    base = _base(robot)
    truth = _perturbed(robot, seed=1)
    names, values = base_vector(truth, base)
    result = physical(robot, names, values, base=base)
    assert result.method == "sdp"
    np.testing.assert_allclose(result.achieved, values, rtol=1e-7, atol=1e-9 * np.abs(values).max())
    assert result.moved < 1e-8
    _assert_realisable(result)
    q, qd, qdd = _states(robot)
    got = rne(result.robot, q, qd, qdd)
    Y = load("puma560", "casadi").functions["Y"]
    pi = np.array(list(result.standard.values()))
    regressor = np.array([np.asarray(Y(a, b, c)) @ pi for a, b, c in zip(q, qd, qdd)])
    assert np.abs(got - regressor).max() <= 1e-10 * np.abs(regressor).max()
    want = rne(truth, q, qd, qdd)
    assert np.abs(got - want).max() <= 1e-6 * np.abs(want).max()


@pytest.mark.parametrize("method", ["sdp", "casadi"])
def test_an_impossible_base_set_is_moved_to_a_realisable_one_and_says_how_far(method):
    """The two-link arm's ZZ2 made negative: no mass distribution has it.  Both solvers return
    a realisable robot, the base parameters moved by a reported amount, and the achieved values
    are the ones the robot's torques show."""
    robot = models.load("twolink")
    names, values = base_vector(robot)
    values = values.copy()
    k = names.index("ZZ2")
    values[k] = -0.5 * abs(values[k]) - 0.05
    result = physical(robot, names, values, method=method)
    _assert_realisable(result)
    assert result.achieved[k] >= 0
    assert 1e-3 < result.moved < 1
    assert result.moved == pytest.approx(
        np.linalg.norm((result.achieved - values) / result.scales) / np.linalg.norm(values / result.scales), rel=1e-9
    )
    # the robot's own base parameters are the achieved ones
    np.testing.assert_allclose(base_vector(result.robot)[1], result.achieved, rtol=1e-9, atol=1e-12)


def test_the_casadi_route_agrees_with_the_sdp_inside_the_cone():
    robot = models.load("twolink")
    truth = dataclasses.replace(
        robot,
        links=tuple(dataclasses.replace(link, I=((0.02, 0, 0), (0, 0.03, 0), (0, 0, 0.04))) for link in robot.links),
    )
    names, values = base_vector(truth)
    sdp = physical(robot, names, values, method="sdp")
    nlp = physical(robot, names, values, method="casadi")
    np.testing.assert_allclose(sdp.achieved, values, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(nlp.achieved, values, rtol=1e-4, atol=1e-6)
    _assert_realisable(nlp, tol=1e-12)


def test_bad_base_names_are_named():
    robot = models.load("twolink")
    names, values = base_vector(robot)
    with pytest.raises(ValueError, match=r"missing \['MX2'\]"):
        physical(robot, [n for n in names if n != "MX2"], [v for n, v in zip(names, values) if n != "MX2"])
    with pytest.raises(ValueError, match=r"not base parameters: \['XX9'\]"):
        physical(robot, [*names, "XX9"], [*values, 1.0])


def test_the_covariance_decides_which_base_parameters_give_way():
    """With ZZ2 uncertain (σ large) and the rest precise, the impossible ZZ2 moves and the rest
    hardly do; `.sigmas` is the move in standard deviations, ‖Σ^{-1/2}(Pπ − β̂)‖."""
    robot = models.load("twolink")
    names, values = base_vector(robot)
    values = values.copy()
    k = names.index("ZZ2")
    values[k] = -0.05
    sigma = np.full(len(values), 1e-4)
    sigma[k] = 1.0
    result = physical(robot, names, values, np.diag(sigma**2))
    _assert_realisable(result)
    moved = np.abs(result.achieved - values)
    assert moved[k] > 0.04
    assert np.delete(moved, k).max() < 1e-3 * moved[k]
    assert result.sigmas == pytest.approx(np.linalg.norm((result.achieved - values) / sigma), rel=1e-3)
