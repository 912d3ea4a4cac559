"""The numeric reference on trees and floating bases against Pinocchio's full models.

Random trees (links hung on random earlier links, depth-first as a URDF parser
orders them) on a fixed, free or planar base: τ, M, G, C·v, q̇̇, the tool's pose and
Jacobian, at 200 states each, to 1e-10; integrate and difference against
Pinocchio's; momentum conserved by a free-floating tree; a chain written with
explicit parents is the same chain.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import symdyn.reference as ref
from symdyn.model import Link, Robot, placement
from symdyn.model.random_robots import random_tree_robot

pin = pytest.importorskip("pinocchio")
from symdyn.bench.peers import pinocchio_model  # noqa: E402

STATES = 200
BASES = (None, "free", "planar")


def _pin_q(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Pinocchio's q of symdyn's: a planar base's yaw as (cos, sin)."""
    if robot.base_joint != "planar":
        return q
    return np.concatenate([q[..., :2], np.cos(q[..., 2:3]), np.sin(q[..., 2:3]), q[..., 3:]], -1)


def _states(robot: Robot, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = robot.integrate(robot.neutral(), rng.normal(size=(STATES, robot.nv)) * 2)
    return q, rng.normal(size=(STATES, robot.nv)), rng.normal(size=(STATES, robot.nv))


def _close(a: np.ndarray, b: np.ndarray, what: str) -> None:
    err = np.abs(a - b).max() / (1 + np.abs(b).max())
    assert err < 1e-10, f"{what}: {err:.2e}"


@pytest.mark.parametrize("base", BASES)
@pytest.mark.parametrize("seed", range(6))
def test_random_trees_agree_with_pinocchio(seed, base):
    robot = random_tree_robot(seed, base_joint=base).nofriction(all=True)
    assert not robot.is_chain or robot.n < 3 or base is not None or all(p == i - 1 for i, p in enumerate(robot.parents))
    model = pinocchio_model(robot)
    data = model.createData()
    assert (robot.nq + (base == "planar"), robot.nv) == (model.nq, model.nv)
    q, v, a = _states(robot, seed)
    C = ref.coriolis(robot, q, v)
    tau, M, G, h, acc = (
        ref.rne(robot, q, v, a),
        ref.inertia(robot, q),
        ref.gravload(robot, q),
        ref.rne(robot, q, v, 0 * v, gravity=(0, 0, 0)),
        ref.accel(robot, q, v, a),
    )
    for k in range(STATES):
        qp = _pin_q(robot, q[k])
        _close(tau[k], pin.rnea(model, data, qp, v[k], a[k]), "tau")
        Mp = pin.crba(model, data, qp)
        _close(M[k], np.triu(Mp) + np.triu(Mp, 1).T, "M")
        _close(G[k], pin.computeGeneralizedGravity(model, data, qp), "G")
        _close(
            h[k], pin.nonLinearEffects(model, data, qp, v[k]) - pin.computeGeneralizedGravity(model, data, qp), "C v"
        )
        _close(acc[k], pin.aba(model, data, qp, v[k], a[k]), "accel")
        _close(C[k], pin.computeCoriolisMatrix(model, data, qp, v[k]), "C")


@pytest.mark.parametrize("base", BASES)
def test_tool_pose_and_jacobian_on_trees(base):
    robot = random_tree_robot(7, n=6, base_joint=base)
    model = pinocchio_model(robot)
    data = model.createData()
    tool = model.getFrameId("tool")
    q, _, _ = _states(robot, 7)
    T, J = ref.fkine(robot, q[:20]), ref.jacob0(robot, q[:20])
    base_T = np.array(robot.base, dtype=float)
    for k in range(20):
        qp = _pin_q(robot, q[k])
        pin.framesForwardKinematics(model, data, qp)
        _close(T[k], base_T @ data.oMf[tool].homogeneous, "fkine")
        Jp = pin.computeFrameJacobian(model, data, qp, tool, pin.LOCAL_WORLD_ALIGNED)
        Rb = base_T[:3, :3]
        _close(J[k], np.block([[Rb, np.zeros((3, 3))], [np.zeros((3, 3)), Rb]]) @ Jp, "jacob0")


def test_cross_branch_inertia_is_zero():
    """Two arms on one base: M couples no joint of one arm with one of the other."""
    robot = random_tree_robot(3, n=4)
    robot = dataclasses.replace(
        robot, links=tuple(dataclasses.replace(l, parent=p) for l, p in zip(robot.links, (-1, 0, -1, 2)))
    )
    M = ref.inertia(robot, np.random.default_rng(0).normal(size=(50, 4)))
    assert np.all(M[:, :2, 2:] == 0) and np.all(M[:, 2:, :2] == 0)
    assert np.all(np.abs(M[:, 0, 1]) > 0)


@pytest.mark.parametrize("base", ("free", "planar"))
def test_integrate_and_difference_agree_with_pinocchio(base):
    robot = random_tree_robot(2, n=3, base_joint=base)
    model = pinocchio_model(robot)
    rng = np.random.default_rng(5)
    q0 = robot.integrate(robot.neutral(), rng.normal(size=(200, robot.nv)) * 3)
    q1 = robot.integrate(robot.neutral(), rng.normal(size=(200, robot.nv)) * 3)
    v = rng.normal(size=(200, robot.nv)) * 2
    ours, diff = robot.integrate(q0, v), robot.difference(q0, q1)
    for k in range(200):
        theirs = pin.integrate(model, _pin_q(robot, q0[k]), v[k])
        mine = _pin_q(robot, ours[k])
        if base == "free" and mine[6] * theirs[6] < 0:  # q and −q are one orientation
            mine[3:7] *= -1
        _close(mine, theirs, "integrate")
        _close(diff[k], pin.difference(model, _pin_q(robot, q0[k]), _pin_q(robot, q1[k])), "difference")
    back = robot.integrate(q0, diff)
    if base == "free":
        back[:, 3:7] *= np.sign((back[:, 3:7] * q1[:, 3:7]).sum(-1, keepdims=True))
    else:  # yaw modulo a turn
        back[:, 2] = q1[:, 2] + np.angle(np.exp(1j * (back[:, 2] - q1[:, 2])))
    _close(back, q1, "q0 ⊕ (q1 ⊖ q0)")


def test_quaternion_of_wrong_norm_is_refused():
    robot = random_tree_robot(1, n=3, base_joint="free")
    q = robot.neutral()
    q[3:7] = (0.1, 0.2, 0.3, 0.9)  # norm 0.9747
    with pytest.raises(ValueError, match="norm 0.97467.*normalise"):
        ref.rne(robot, q, np.zeros(robot.nv), np.zeros(robot.nv))
    with pytest.raises(ValueError, match="quaternion"):
        robot.integrate(q, np.zeros(robot.nv))
    fixed = robot.normalize(q)
    assert abs(np.linalg.norm(fixed[3:7]) - 1) < 1e-15
    assert np.all(np.isfinite(ref.rne(robot, fixed, np.zeros(robot.nv), np.zeros(robot.nv))))


def test_free_floating_tree_conserves_momentum():
    """No gravity, no friction, no torque: linear and angular momentum stay what they were."""
    robot = dataclasses.replace(random_tree_robot(4, n=4, base_joint="free").nofriction(all=True), gravity=(0, 0, 0))
    rng = np.random.default_rng(1)
    q0 = robot.integrate(robot.neutral(), rng.normal(size=robot.nv))
    v0 = rng.normal(size=robot.nv)
    _, q, v = ref.fdyn(robot, 1.0, q0, v0, t_eval=np.linspace(0, 1, 11))
    h = ref.momentum(robot, q, v)
    assert np.abs(h[0]).max() > 0.1
    assert np.abs(h - h[0]).max() < 1e-7 * np.abs(h[0]).max()
    kinetic, _ = ref.energy(robot, q, v)
    assert np.abs(kinetic - kinetic[0]).max() < 1e-7 * kinetic[0]


def test_explicit_parents_of_a_chain_are_the_chain():
    arm = random_tree_robot(0, n=3)
    chain = dataclasses.replace(arm, links=tuple(dataclasses.replace(l, parent=None) for l in arm.links))
    spelled = dataclasses.replace(
        arm, links=tuple(dataclasses.replace(l, parent=i - 1) for i, l in enumerate(arm.links))
    )
    assert spelled == chain and spelled.fingerprint() == chain.fingerprint() and spelled.is_chain
    assert spelled.parents == (-1, 0, 1)


def test_bad_parents_and_base_joints_are_named():
    link = Link(origin=placement((0, 0, 0.1)), m=1, I=np.eye(3) * 0.01)
    with pytest.raises(ValueError, match="link 2 .* names parent 1"):
        Robot("bad", (link, dataclasses.replace(link, parent=1)), convention="general")
    with pytest.raises(ValueError, match="parent must be a link index"):
        Link(parent="base")
    with pytest.raises(ValueError, match="unknown base_joint 'floating'"):
        Robot("bad", (link,), convention="general", base_joint="floating")
    with pytest.raises(ValueError, match="base_body but no base_joint"):
        Robot("bad", (link,), convention="general", base_body=link)
    with pytest.raises(ValueError, match="base_wrench"):
        ref.rne(
            Robot("f", (link,), convention="general", base_joint="free"),
            [0] * 6 + [1, 0],
            [0] * 7,
            [0] * 7,
            base_wrench=True,
        )


@pytest.mark.parametrize("base", ("free", "planar"))
def test_floating_coriolis_matrix_is_skew_with_mdot(base):
    """C·v is the velocity-product force exactly; Ṁ − 2C is skew (Ṁ along the motion by central differences)."""
    robot = random_tree_robot(3, n=5, base_joint=base)
    rng = np.random.default_rng(0)
    q = robot.integrate(robot.neutral(), rng.normal(size=(5, robot.nv)))
    v = rng.normal(size=(5, robot.nv))
    C = ref.coriolis(robot, q, v)
    h = ref.rne(robot.nofriction(all=True), q, v, 0 * v, gravity=(0, 0, 0))
    _close(np.einsum("skj,sj->sk", C, v), h, "C v")
    eps = 1e-6
    Mdot = (ref.inertia(robot, robot.integrate(q, v, eps)) - ref.inertia(robot, robot.integrate(q, v, -eps))) / (
        2 * eps
    )
    S = Mdot - 2 * C
    assert np.abs(S + np.swapaxes(S, -1, -2)).max() < 1e-6 * np.abs(S).max()
    with pytest.raises(NotImplementedError, match="base's velocities are not the derivatives"):
        ref.christoffel(robot, q)


def test_air_puck_on_a_planar_base_is_the_three_joint_puck():
    """Exercise 9's Puma on an air puck: a true planar base (body-frame velocities) is the same system
    as the chapter's prismatic x, prismatic y, revolute yaw: with v = T·q̇ (T = Rᵀ(yaw) on x, y) and
    v̇ = d(T·q̇)/dt, τ_planar = T·τ_joints at random states, so the study's numbers carry over."""
    from symdyn.apps.air_puck import puck_robot

    joints, planar = puck_robot(), puck_robot(planar=True)
    assert (planar.nq, planar.nv, planar.n) == (9, 9, 6)
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.normal(size=(STATES, 9)) for _ in range(3))
    c, s = np.cos(q[:, 2]), np.sin(q[:, 2])

    def turned(x):  # Rᵀ(yaw) on the x, y components
        y = x.copy()
        y[:, 0], y[:, 1] = c * x[:, 0] + s * x[:, 1], -s * x[:, 0] + c * x[:, 1]
        return y

    v, vd = turned(qd), turned(qdd)
    vd[:, 0] += qd[:, 2] * (-s * qd[:, 0] + c * qd[:, 1])
    vd[:, 1] += qd[:, 2] * (-c * qd[:, 0] - s * qd[:, 1])
    _close(ref.rne(planar, q, v, vd), turned(ref.rne(joints, q, qd, qdd)), "tau")
