"""The numeric reference agrees with Pinocchio (rung 1 of the ladder in DESIGN.md).

At 200 random states within the joint limits, for every shipped arm and for
payload, tool and base variants: τ, M, G, C·q̇, the full Christoffel C, forward
dynamics, base wrench, end-effector wrench, fkine and jacob0.  Pinocchio has
no friction: it is compared with the frictionless robot, and the friction law
is added outside Pinocchio from the link parameters.
"""

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

from conftest import random_states
from symdyn import models
from symdyn.bench import peers
from symdyn.bench.differential import friction_law
from symdyn.model import rotx, roty, transl
from symdyn.numeric import reference as ref

N = 200
RTOL = 1e-10
PAYLOAD = (2.5, (0.01, -0.02, 0.1))


def _puma():
    return models.load("puma560")


CASES = {
    "puma560": _puma,
    "puma560_mdh": lambda: models.load("puma560_mdh"),
    "twolink": lambda: models.load("twolink"),
    "rrp": lambda: models.load("rrp"),
    "puma560_payload_book": lambda: _puma().payload(*PAYLOAD),
    "puma560_payload_additive": lambda: _puma().payload(*PAYLOAD, additive=True),
    "puma560_upside_down_moon": lambda: dataclasses.replace(_puma(), base=rotx(math.pi), gravity=(0, 0, 1.62)),
}


def _tooled(robot):
    """The robot with a non-trivial tool and a tilted, shifted base."""
    tool = np.array(transl(0.05, -0.03, 0.12), float) @ np.array(roty(0.4), float)
    base = np.array(transl(0.3, 0.2, 0.5), float) @ np.array(rotx(0.7), float)
    return dataclasses.replace(robot, tool=tool, base=base)


WRENCH_CASES = {
    "puma560_tool": lambda: _tooled(_puma()),
    "puma560_mdh": lambda: models.load("puma560_mdh"),  # to_modified moves Tx(a6)Rx(α6) into the tool
    "rrp_tool": lambda: _tooled(models.load("rrp")),
    "twolink": lambda: models.load("twolink"),
}


def assert_close(actual, expected, rtol=RTOL, what=""):
    """|actual − expected| ≤ rtol·max|expected| (relative to the quantity's largest value)."""
    actual, expected = np.asarray(actual), np.asarray(expected)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(np.abs(expected).max(), 1e-300)
    err = np.abs(actual - expected).max() / scale
    assert err <= rtol, f"{what}: relative error {err:.3e} > {rtol:.0e} (scale {scale:.3e})"


def _sym(A):
    return np.triu(A) + np.triu(A, 1).T


def pinocchio_at(model, q, qd, qdd, tau):
    """Pinocchio's τ, M, G, C·q̇, ∂M/∂q, forward dynamics and base wrench at each state."""
    data = model.createData()
    n = q.shape[1]
    out = {k: [] for k in ("tau", "base", "M", "G", "Cqd", "dM", "ddq")}
    for x, v, a, t in zip(q, qd, qdd, tau):
        out["tau"].append(pin.rnea(model, data, x, v, a).copy())
        pin.forwardKinematics(model, data, x)  # rnea leaves data.oMi stale; data.f[1] is kept
        out["base"].append(data.oMi[1].act(data.f[1]).vector.copy())
        out["M"].append(_sym(pin.crba(model, data, x)))
        g = pin.computeGeneralizedGravity(model, data, x).copy()
        out["G"].append(g)
        out["Cqd"].append(pin.nonLinearEffects(model, data, x, v) - g)
        # Pinocchio's C satisfies Ṁ = C + Cᵀ, and is linear in q̇: q̇ = e_i gives ∂M/∂q_i
        out["dM"].append(
            np.stack([(lambda C: C + C.T)(pin.computeCoriolisMatrix(model, data, x, e).copy()) for e in np.eye(n)])
        )
        out["ddq"].append(pin.aba(model, data, x, v, t).copy())
    return SimpleNamespace(**{k: np.array(v) for k, v in out.items()})


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    robot = CASES[request.param]()
    q, qd, qdd = random_states(robot, N, seed=7)
    tau = np.random.default_rng(8).uniform(-30, 30, (N, robot.n))
    peer = pinocchio_at(peers.pinocchio_model(robot), q, qd, qdd, tau)
    return SimpleNamespace(
        name=request.param, robot=robot, bare=robot.nofriction(all=True), q=q, qd=qd, qdd=qdd, tau=tau, peer=peer
    )


def test_inverse_dynamics_matches_pinocchio(case):
    c = case
    assert_close(ref.rne(c.bare, c.q, c.qd, c.qdd), c.peer.tau, what="tau (frictionless)")


def test_inverse_dynamics_with_friction_is_pinocchio_plus_friction_law(case):
    c = case
    expected = c.peer.tau + friction_law(c.robot, c.qd)
    assert_close(ref.rne(c.robot, c.q, c.qd, c.qdd), expected, what="tau (with friction)")


def test_mass_matrix_matches_pinocchio(case):
    assert_close(ref.inertia(case.robot, case.q), case.peer.M, what="M")


def test_gravity_load_matches_pinocchio(case):
    assert_close(ref.gravload(case.robot, case.q), case.peer.G, what="G")


def test_coriolis_times_velocity_matches_pinocchio(case):
    C = ref.coriolis(case.robot, case.q, case.qd)
    assert_close(np.einsum("...kj,...j->...k", C, case.qd), case.peer.Cqd, what="C qd")


def test_coriolis_matrix_is_the_christoffel_matrix_of_pinocchios_mass_matrix(case):
    """Γ_kij = ½(∂_i M_kj + ∂_j M_ki − ∂_k M_ij) from Pinocchio's exact ∂M/∂q; C_kj = Σ_i Γ_kij q̇_i."""
    dM = case.peer.dM  # dM[s, i, k, j] = ∂M_kj/∂q_i
    gamma = 0.5 * (np.einsum("sikj->skij", dM) + np.einsum("sjki->skij", dM) - np.einsum("skij->skij", dM))
    expected = np.einsum("skij,si->skj", gamma, case.qd)
    assert_close(ref.christoffel(case.robot, case.q), gamma, what="Christoffel symbols")
    assert_close(ref.coriolis(case.robot, case.q, case.qd), expected, what="C")


def test_forward_dynamics_matches_pinocchio_aba(case):
    c = case
    assert_close(ref.accel(c.bare, c.q, c.qd, c.tau), c.peer.ddq, what="qdd (frictionless)")
    assert_close(
        ref.accel(c.robot, c.q, c.qd, c.tau + friction_law(c.robot, c.qd)),
        c.peer.ddq,
        what="qdd (friction added to the torque)",
    )


def test_base_wrench_matches_pinocchio_joint_force(case):
    """[f; n] of the base on link 1, frame {0}, about its origin: Pinocchio's data.f[1] in the universe."""
    c = case
    tau, wrench = ref.rne(c.robot, c.q, c.qd, c.qdd, base_wrench=True)
    assert wrench.shape == (N, 6)
    assert_close(wrench[:, :3], c.peer.base[:, :3], what="base force")
    assert_close(wrench[:, 3:], c.peer.base[:, 3:], what="base moment")


# --------------------------------------------------------------------------- payloads as Pinocchio inertias


def _with_payload(robot, inertia_of_payload):
    """Pinocchio model of `robot` with the last body's inertia rebuilt by `inertia_of_payload(old)`."""
    model = peers.pinocchio_model(robot)
    n = robot.n
    place = model.frames[model.getFrameId(f"L{n}")].placement  # DH frame {n} in the joint frame
    model.inertias[n] = inertia_of_payload(model.inertias[n], place)
    return model


@pytest.mark.parametrize("additive", [False, True])
def test_payload_matches_pinocchio_body_inertia(additive):
    """Book: last link's mass := m, COM := p, inertia kept.  Additive: a point mass added (pin.Inertia sum)."""
    puma = _puma()
    m, p = PAYLOAD
    last = puma.links[-1]
    if additive:
        rebuild = lambda old, X: old + X.act(pin.Inertia(m, np.array(p), np.zeros((3, 3))))  # noqa: E731
    else:
        rebuild = lambda old, X: X.act(pin.Inertia(m, np.array(p), np.array(last.I, float)))  # noqa: E731
    model = _with_payload(puma, rebuild)
    robot = puma.payload(m, p, additive=additive)
    q, qd, qdd = random_states(robot, N, seed=11)
    peer = pinocchio_at(model, q, qd, qdd, np.zeros_like(q))
    assert_close(ref.rne(robot.nofriction(all=True), q, qd, qdd), peer.tau, what="tau with payload")
    assert_close(ref.inertia(robot, q), peer.M, what="M with payload")
    assert_close(ref.rne(robot, q, qd, qdd, base_wrench=True)[1], peer.base, what="base wrench with payload")


# --------------------------------------------------------------------------- kinematics and end-effector wrench


@pytest.fixture(scope="module", params=sorted(WRENCH_CASES))
def tooled(request):
    robot = WRENCH_CASES[request.param]()
    q, qd, qdd = random_states(robot, N, seed=5)
    W = np.random.default_rng(6).uniform(-10, 10, (N, 6))
    return SimpleNamespace(robot=robot, q=q, qd=qd, qdd=qdd, W=W)


def test_fkine_and_jacob0_match_pinocchio_tool_frame(tooled):
    robot, q = tooled.robot, tooled.q
    model = peers.pinocchio_model(robot)
    data = model.createData()
    tool = model.getFrameId("tool")
    base = np.array(robot.base, float)
    B6 = np.kron(np.eye(2), base[:3, :3])
    T, J = [], []
    for x in q:
        pin.framesForwardKinematics(model, data, x)
        T.append(base @ data.oMf[tool].homogeneous)
        J.append(B6 @ pin.computeFrameJacobian(model, data, x, tool, pin.LOCAL_WORLD_ALIGNED))
    assert_close(ref.fkine(robot, q), np.array(T), what="fkine")
    assert_close(ref.jacob0(robot, q), np.array(J), what="jacob0")


def test_end_effector_wrench_adds_jacobian_transpose(tooled):
    """rne(W) − rne() = J0ᵀ [R f; R n], R the tool's world rotation (W in the tool frame)."""
    t = tooled
    R = ref.fkine(t.robot, t.q)[:, :3, :3]
    W0 = np.concatenate([np.einsum("sij,sj->si", R, t.W[:, :3]), np.einsum("sij,sj->si", R, t.W[:, 3:])], 1)
    expected = np.einsum("sji,sj->si", ref.jacob0(t.robot, t.q), W0)
    actual = ref.rne(t.robot, t.q, t.qd, t.qdd, wrench=t.W) - ref.rne(t.robot, t.q, t.qd, t.qdd)
    assert_close(actual, expected, what="J^T W")


def test_end_effector_wrench_matches_pinocchio_external_force(tooled):
    """W is exerted by the end-effector on the environment: Pinocchio's fext on the last body is −W."""
    t = tooled
    model = peers.pinocchio_model(t.robot)
    data = model.createData()
    X = model.frames[model.getFrameId("tool")].placement  # tool in the last joint frame
    n = t.robot.n
    tau = []
    for x, v, a, w in zip(t.q, t.qd, t.qdd, t.W):
        fext = [pin.Force.Zero() for _ in range(model.njoints)]
        fext[n] = -X.act(pin.Force(w[:3], w[3:]))
        tau.append(pin.rnea(model, data, x, v, a, fext).copy())
    actual = ref.rne(t.robot.nofriction(all=True), t.q, t.qd, t.qdd, wrench=t.W)
    assert_close(actual, np.array(tau), what="tau with end-effector wrench")


def test_pinocchio_model_refuses_a_symbolic_robot():
    with pytest.raises(ValueError, match="numeric robot.*a1"):
        peers.pinocchio_model(models.load("twolink", symbolic=True))
