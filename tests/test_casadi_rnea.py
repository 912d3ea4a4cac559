"""The plain CasADi SX Newton–Euler agrees with the numeric reference."""

import casadi as ca
import numpy as np
import pytest

from symdyn import models
from symdyn.numeric import casadi_rnea, reference as ref
from tests.conftest import random_states

COUNT = 200


def _close(a, b, rtol=1e-12):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = max(1.0, np.abs(b).max())
    assert np.abs(a - b).max() <= rtol * scale, np.abs(a - b).max()


@pytest.fixture(scope="module", params=models.NAMES)
def arm(request):
    robot = models.load(request.param)
    return robot, casadi_rnea.functions(robot)


def _batched(f, *args):
    """Evaluate a casadi Function column-wise on (N, n) arrays, returning (N, ...) rows."""
    out = f.map(args[0].shape[0])(*(a.T for a in args))
    return np.array(out).T


def test_tau_matches_reference_with_friction(arm):
    robot, f = arm
    q, qd, qdd = random_states(robot, COUNT, seed=1)
    _close(_batched(f.tau, q, qd, qdd), ref.rne(robot, q, qd, qdd))


def test_mass_matrix_matches_reference(arm):
    robot, f = arm
    q, _, _ = random_states(robot, COUNT, seed=2)
    M = np.array([np.array(f.M(qi)) for qi in q])
    _close(M, ref.inertia(robot, q))


def test_gravity_coriolis_friction_terms_match_reference(arm):
    robot, f = arm
    q, qd, _ = random_states(robot, COUNT, seed=3)
    _close(_batched(f.G, q), ref.gravload(robot, q))
    _close(_batched(f.Cqd, q, qd), np.einsum("nij,nj->ni", ref.coriolis(robot, q, qd), qd))
    _close(_batched(f.F, qd), ref.friction(robot, qd))


def test_forward_dynamics_matches_reference(arm):
    robot, f = arm
    q, qd, tau = random_states(robot, COUNT, seed=4)
    tau = 10 * tau
    _close(_batched(f.fdyn, q, qd, tau), ref.accel(robot, q, qd, tau), rtol=1e-11)


def test_coulomb_friction_is_zero_at_rest_and_picks_branch_by_sign(puma):
    tau = casadi_rnea.rnea_function(puma)
    q = puma.qn
    for qd in (np.zeros(6), np.full(6, 1e-3), np.full(6, -1e-3)):
        _close(np.array(tau(q, qd, np.zeros(6))).ravel(), ref.rne(puma, q, qd, np.zeros(6)))


def test_friction_can_be_left_out(puma):
    tau = casadi_rnea.rnea_function(puma, friction=False)
    q, qd, qdd = random_states(puma, 20, seed=5)
    _close(_batched(tau, q, qd, qdd), ref.rne(puma.nofriction(all=True), q, qd, qdd))


def test_functions_are_sx_with_named_ports(puma):
    f = casadi_rnea.rnea_function(puma)
    assert f.is_a("SXFunction")
    assert f.name_in() == ["q", "qd", "qdd"] and f.name_out() == ["tau"]
    assert casadi_rnea.fdyn_function(puma).name_in() == ["q", "qd", "tau"]


def test_symbolic_robot_is_refused():
    with pytest.raises(ValueError, match="symbolic"):
        casadi_rnea.rnea_function(models.load("twolink", symbolic=True))


def test_jacobian_by_ad_matches_finite_differences(puma):
    tau = casadi_rnea.rnea_function(puma)
    q, qd, qdd = (x[0] for x in random_states(puma, 1, seed=6))
    J = np.array(
        ca.Function("J", [tau.sx_in(0), tau.sx_in(1), tau.sx_in(2)], [ca.jacobian(tau(*tau.sx_in()), tau.sx_in(0))])(
            q, qd, qdd
        )
    )
    eps = 1e-6
    fd = np.column_stack(
        [(ref.rne(puma, q + eps * e, qd, qdd) - ref.rne(puma, q - eps * e, qd, qdd)) / (2 * eps) for e in np.eye(6)]
    )
    assert np.abs(J - fd).max() < 1e-6 * max(1.0, np.abs(fd).max())
