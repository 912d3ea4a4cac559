"""Shared fixtures: the shipped models and random states within joint limits."""

import numpy as np
import pytest

from symdyn import models


@pytest.fixture(scope="session", autouse=True)
def _private_cache(tmp_path_factory):
    """Every test session derives into its own fresh cache directory."""
    import os

    old = os.environ.get("SYMDYN_CACHE_DIR")
    os.environ["SYMDYN_CACHE_DIR"] = str(tmp_path_factory.mktemp("symdyn-cache"))
    yield
    if old is None:
        os.environ.pop("SYMDYN_CACHE_DIR", None)
    else:
        os.environ["SYMDYN_CACHE_DIR"] = old


@pytest.fixture(scope="session")
def puma():
    return models.load("puma560")


@pytest.fixture(scope="session")
def twolink():
    return models.load("twolink")


def random_states(robot, count, seed=0):
    """(q, qd, qdd), each (count, n): q uniform within the joint limits."""
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    q = rng.uniform(lo, hi, (count, robot.n))
    qd = rng.uniform(-2, 2, (count, robot.n))
    qdd = rng.uniform(-5, 5, (count, robot.n))
    return q, qd, qdd
