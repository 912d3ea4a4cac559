"""Optimal control of a legged robot through contact phases (issue 43, item 3): the free base's
step on its manifold in CasADi, and the Solo 12 jump converging from a standing guess (slow)."""

import numpy as np
import pytest

from symdyn.apps import ocp_legged
from symdyn.model.random_robots import random_tree_robot


def test_the_casadi_step_is_robot_integrate():
    """q ⊕ w in CasADi (the exponential's series) against Robot.integrate (closed forms), turns up
    to 1 rad, and its Jacobian finite at a zero turn (where the closed forms are 0/0)."""
    import casadi as ca

    robot = random_tree_robot(2, n=3, base_joint="free")
    step = ocp_legged.integrate_function(robot)
    rng = np.random.default_rng(0)
    for scale in (0.0, 1e-9, 1e-3, 0.1, 0.5):
        q = robot.normalize(rng.normal(size=robot.nq))
        w = rng.normal(size=robot.nv)
        w[3:6] *= scale / max(np.linalg.norm(w[3:6]), 1e-300) if scale else 0.0
        np.testing.assert_allclose(step(q, w).full().ravel(), robot.integrate(q, w), rtol=0, atol=1e-12)
    q_sym, w_sym = ca.SX.sym("q", robot.nq), ca.SX.sym("w", robot.nv)
    jac = ca.Function("J", [q_sym, w_sym], [ca.jacobian(step(q_sym, w_sym), w_sym)])
    assert np.all(np.isfinite(jac(robot.neutral(), np.zeros(robot.nv)).full()))
    with pytest.raises(ValueError, match="not free"):
        ocp_legged.integrate_function(random_tree_robot(2, n=3))
