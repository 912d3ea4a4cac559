"""Shared by the emitter tests: reference values of every generated function.

`cases(name)` gives, for a shipped model, the arguments and the values
`symdyn.reference` computes at 200 random states within the joint limits;
`assert_close` compares to 1e-12 relative to the function's scale.
"""

import functools

import numpy as np

from tests.conftest import random_states
from symdyn import models
from symdyn.derivation.regressor import parameter_values
from symdyn.numeric import reference as ref

MODELS = ("twolink", "puma560")
STATES = 200
RTOL = 1e-12


@functools.lru_cache(maxsize=None)
def cases(name: str) -> dict:
    """{function: (args, expected)} for every generated function of model `name`."""
    robot = models.load(name)
    q, qd, qdd = random_states(robot, STATES, seed=4)
    qd[:5] = 0.0  # Coulomb friction at rest is 0: exercise sign(0)
    tau = ref.rne(robot, q, qd, qdd)
    C = ref.coriolis(robot, q, qd)
    return {
        "tau": ((q, qd, qdd), tau),
        "M": ((q,), ref.inertia(robot, q)),
        "C": ((q, qd), C),
        "Cqd": ((q, qd), np.einsum("nij,nj->ni", C, qd)),
        "G": ((q,), ref.gravload(robot, q)),
        "F": ((qd,), ref.friction(robot, qd)),
        "fdyn": ((q, qd, tau), qdd),
    }


@functools.lru_cache(maxsize=None)
def parameters(name: str) -> np.ndarray:
    """The standard parameters π of the model, with τ = Y·π."""
    return np.array([float(v) for v in parameter_values(models.load(name))])


def assert_close(got, expected, what: str, rtol: float = RTOL) -> None:
    """|got − expected| ≤ rtol·max(1, max|expected|) elementwise, shapes equal."""
    got = np.asarray(got)
    assert got.shape == expected.shape, f"{what}: shape {got.shape}, expected {expected.shape}"
    scale = max(1.0, float(np.max(np.abs(expected))))
    err = float(np.max(np.abs(got - expected))) / scale
    assert err <= rtol, f"{what}: relative error {err:.2e} > {rtol:.0e}"
