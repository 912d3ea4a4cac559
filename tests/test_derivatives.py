"""Generated derivatives: (τ, ∂τ/∂q, ∂τ/∂q̇), (q̈, ∂q̈/∂q, ∂q̈/∂q̇, M⁻¹) and M⁻¹
against Pinocchio's analytical derivatives and central differences of the
generated τ and fdyn, on the shipped arms and random ones, in every target."""

import numpy as np
import pytest

from symdyn.bench.differential import pinocchio_derivatives, states
from symdyn.bench.peers import pinocchio_model
from symdyn.codegen import entry as codegen
from symdyn.codegen.emit.clib import CompileOptions
from symdyn.model import arms
from symdyn.model.random_arms import ArmOptions, random_arm
from tests.conftest import tiered

pin = pytest.importorskip("pinocchio")

RTOL = 1e-10
STATES = 200
ARMS = {
    "twolink": lambda: arms.load("twolink"),
    "puma560": lambda: arms.load("puma560"),
    "rrp": lambda: arms.load("rrp"),
    "random-101": lambda: random_arm(101, ArmOptions(n_max=4)),
    "random-7": lambda: random_arm(7, ArmOptions(n_min=4, n_max=4)),
}


# rrp and random-7 (four joints): make test-all
@pytest.fixture(scope="module", params=tiered(sorted(ARMS, key=lambda name: name in ("rrp", "random-7")), 3))
def arm(request):
    """(robot, its generated C functions, states (q, qd, qdd, tau), Pinocchio's values there)."""
    robot = ARMS[request.param]()
    f = codegen.load(robot, "c")
    q, qd, qdd, tau = states(robot, STATES, seed=5)
    return robot, f, (q, qd, qdd, tau), pinocchio_derivatives(pinocchio_model(robot), robot, q, qd, qdd, tau)


def _close(got, expected, what, rtol=RTOL):
    """|got − expected| ≤ rtol·max(1, max|expected|) over the whole batch."""
    assert got.shape == expected.shape, f"{what}: shape {got.shape}, expected {expected.shape}"
    scale = max(1.0, float(np.abs(expected).max()))
    err = float(np.abs(got - expected).max()) / scale
    assert err <= rtol, f"{what}: relative error {err:.2e} > {rtol:.0e}"


def test_tau_derivatives_agree_with_pinocchio(arm):
    robot, f, (q, qd, qdd, _), peer = arm
    tau, dq, dqd = f.tau_derivatives(q, qd, qdd)
    _close(tau, f.tau(q, qd, qdd), f"{robot.name} tau")
    _close(dq, peer["dtau_dq"], f"{robot.name} dtau_dq")
    _close(dqd, peer["dtau_dqd"], f"{robot.name} dtau_dqd")


def test_fdyn_derivatives_and_minv_agree_with_pinocchio(arm):
    robot, f, (q, qd, _, tau), peer = arm
    qdd, dq, dqd, Minv = f.fdyn_derivatives(q, qd, tau)
    _close(qdd, peer["qdd"], f"{robot.name} qdd")
    _close(dq, peer["dqdd_dq"], f"{robot.name} dqdd_dq")
    _close(dqd, peer["dqdd_dqd"], f"{robot.name} dqdd_dqd")
    _close(Minv, peer["Minv"], f"{robot.name} Minv")
    _close(f.Minv(q), peer["Minv"], f"{robot.name} Minv(q)")


def test_derivatives_match_central_differences_of_the_generated_functions(arm):
    """At moving states (sign q̇ fixed within ±h): ∂/∂x_k ≈ (f(x + h e_k) − f(x − h e_k)) / 2h."""
    robot, f, (q, qd, qdd, tau), _ = arm
    moving = np.all(np.abs(qd) > 1e-3, axis=1)
    q, qd, qdd, tau = q[moving][:40], qd[moving][:40], qdd[moving][:40], tau[moving][:40]
    _, dtau_dq, dtau_dqd = f.tau_derivatives(q, qd, qdd)
    _, dqdd_dq, dqdd_dqd, Minv = f.fdyn_derivatives(q, qd, tau)
    h, n = 1e-6, robot.n
    for k, e in enumerate(np.eye(n) * h):
        for got, fun, args, at in (
            (dtau_dq, f.tau, (q, qd, qdd), 0),
            (dtau_dqd, f.tau, (q, qd, qdd), 1),
            (dqdd_dq, f.fdyn, (q, qd, tau), 0),
            (dqdd_dqd, f.fdyn, (q, qd, tau), 1),
            (Minv, f.fdyn, (q, qd, tau), 2),
        ):
            up, down = list(args), list(args)
            up[at], down[at] = args[at] + e, args[at] - e
            _close(got[..., k], (fun(*up) - fun(*down)) / (2 * h), f"{robot.name} column {k + 1}", 1e-6)


@pytest.mark.parametrize("target, binding", [("numpy", None), ("c", "ctypes"), ("casadi", None)])
def test_every_target_gives_the_same_derivatives(target, binding):
    robot = arms.load("puma560")
    reference = codegen.load(robot, "c")
    other = codegen.load(robot, target, options=CompileOptions(binding=binding) if binding else None)
    q, qd, qdd, tau = states(robot, STATES, seed=6)
    for name, args in (("tau_derivatives", (q, qd, qdd)), ("fdyn_derivatives", (q, qd, tau)), ("Minv", (q,))):
        expected = getattr(reference, name)(*args)
        for k in (slice(None), 3):  # a batch, one state
            got = getattr(other, name)(*(a[k] for a in args))
            for g, x in zip(
                got if isinstance(got, tuple) else (got,), expected if isinstance(expected, tuple) else (expected,)
            ):
                _close(g, x[k], f"{target} {name}", 1e-12)
