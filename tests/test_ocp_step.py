"""The multiple-shooting interval with explicit derivatives (`symdyn.apps.ocp_step`):
its value, Jacobian, reverse mode and Hessian of λᵀstep equal CasADi's own AD through
the RK4 stages, on arms with and without friction, for one and several substeps, and
compiled they are what IPOPT is handed."""

import casadi as ca
import numpy as np
import pytest

import symdyn
from symdyn.apps import ocp, ocp_step
from symdyn.apps.ocp import functions
from symdyn.model.random_arms import ArmOptions, random_arm

ARMS = {
    "twolink": lambda: symdyn.models.load("twolink").nofriction(),
    "puma560": lambda: symdyn.models.load("puma560"),  # Coulomb friction: sign held
    "random-3": lambda: random_arm(7, ArmOptions(n_min=3, n_max=3)),
}


def _dense(x) -> np.ndarray:
    return np.array(ca.densify(ca.DM(x)))


def _agree(got, expected, what):
    assert len(got) == len(expected), what
    for k, (a, b) in enumerate(zip(got, expected)):
        a, b = _dense(a), _dense(b)
        assert a.shape == b.shape, f"{what} output {k}: {a.shape} vs {b.shape}"
        assert np.abs(a - b).max() <= 1e-11 * max(1.0, np.abs(b).max()), f"{what} output {k}"


@pytest.mark.parametrize("name", list(ARMS))
@pytest.mark.parametrize("substeps, generated", [(1, False), (3, False), (1, True)])
def test_explicit_derivatives_equal_casadis_ad_through_the_stages(name, substeps, generated):
    """generated: fdyn's Jacobian per call from symdyn's fdyn_derivatives (what
    `ocp.dynamics(robot, "symdyn")` uses), else CasADi's AD of fdyn."""
    robot = ARMS[name]()
    fdyn = ocp.dynamics(robot, "symdyn", compiled=False).fdyn
    n = robot.n
    derivatives = symdyn.load(robot, "casadi").functions["fdyn_derivatives"] if generated else None
    mine = ocp_step.step_functions(fdyn, n, substeps, derivatives)
    ref = functions._rk4_step(fdyn, n, substeps)
    ref_fns = (ref, ref.jacobian(), ref.reverse(1), ref.reverse(1).jacobian())
    rng = np.random.default_rng(substeps)
    for _ in range(3):
        z = [rng.uniform(-1, 1, n), rng.uniform(-2, 2, n), rng.uniform(-10, 10, n), rng.uniform(0.01, 0.1)]
        lam = [rng.normal(size=n), rng.normal(size=n)]
        out = ref(*z)
        adj = ref_fns[2](*z, *out, *lam)
        args = (z, [*z, *out], [*z, *out, *lam], [*z, *out, *lam, *adj])
        for f, g, a, what in zip(mine, ref_fns, args, ("rk4", "jac_rk4", "adj1_rk4", "jac_adj1_rk4")):
            assert f.name() == what
            assert [f.name_in(i) for i in range(f.n_in())] == [g.name_in(i) for i in range(g.n_in())]
            _agree(f.call(a), g.call(a), f"{name} {what}")


def test_the_hessian_is_symmetric_and_the_compiled_step_equals_the_graph():
    robot = ARMS["twolink"]()
    fdyn = ocp.dynamics(robot, "symdyn", compiled=False).fdyn
    step, jac, adj, hess = ocp_step.step_functions(fdyn, 2, 1)
    compiled = ocp_step.rk4_step(fdyn, 2, 1)
    assert compiled.class_name() == "External"
    z = [np.array([0.3, -0.4]), np.array([1.0, 0.5]), np.array([3.0, -1.0]), 0.05]
    lam = [np.array([0.7, -0.2]), np.array([0.1, 1.3])]
    out = step(*z)
    blocks = hess.call([*z, *out, *lam, *adj(*z, *out, *lam)])
    H = np.block([[_dense(blocks[8 * r + c]) for c in range(4)] for r in range(4)])
    assert np.abs(H - H.T).max() <= 1e-12 * np.abs(H).max()
    _agree(compiled.call(z), step.call(z), "compiled step")
    _agree(compiled.reverse(1).jacobian().call([*z, *out, *lam, *adj(*z, *out, *lam)]), blocks, "compiled Hessian")
