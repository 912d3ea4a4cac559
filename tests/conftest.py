"""Shared fixtures: the shipped models and random states within joint limits."""

import numpy as np
import pytest

from symdyn import models


@pytest.fixture(scope="session", autouse=True)
def _private_cache(tmp_path_factory):
    """Every test session derives into its own fresh cache directory, which the
    session's xdist workers share (as processes on one machine share a user's
    cache): a model's library is compiled once, not once per worker."""
    import os

    base = tmp_path_factory.getbasetemp()
    folder = base.parent / "symdyn-cache" if os.environ.get("PYTEST_XDIST_WORKER") else base / "symdyn-cache"
    folder.mkdir(exist_ok=True)
    old = os.environ.get("SYMDYN_CACHE_DIR")
    os.environ["SYMDYN_CACHE_DIR"] = str(folder)
    yield
    if old is None:
        os.environ.pop("SYMDYN_CACHE_DIR", None)
    else:
        os.environ["SYMDYN_CACHE_DIR"] = old


def tiered(values, main: int) -> list:
    """Parameters of which the first `main` run in the main suite (`make test`) and the rest are
    marked slow (`make test-all`): cases held back for the suite's time, never deleted."""
    return [
        v if i < main else pytest.param(*(v if isinstance(v, tuple) else (v,)), marks=pytest.mark.slow)
        for i, v in enumerate(values)
    ]


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
