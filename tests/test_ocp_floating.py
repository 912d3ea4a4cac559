"""Optimal control over a planar floating base (issue 35): q̇ = R(yaw)·v on the base, its
torques held at zero (`Problem.unactuated`), every optimum re-simulated with the reference.

A two-link arm on a puck (air table, no gravity in the plane): a sine torque on the arm from
rest moves the free base; the OCP between the same end states (Hermite–Simpson) never pushes
the base, costs no more effort than the sine, re-simulates open loop onto the goal and keeps
the system's momentum at zero; multiple shooting's RK4 interval integrates the base's rates.
"""

from __future__ import annotations

import numpy as np
import pytest

from symdyn.apps import ocp
from symdyn.apps.ocp import functions
from symdyn.model import Link, Robot
from symdyn.model.base_joint import coordinate_rates
from symdyn.numeric import reference as ref

T, AMPLITUDE = 1.0, np.array([0.0, 0.0, 0.0, 2.0, -1.5])  # s; N·m on the arm, none on the base


def _robot() -> Robot:
    arm = (
        Link(a=0.5, m=2.0, r=(-0.25, 0, 0), I=((0.01, 0, 0), (0, 0.05, 0), (0, 0, 0.05))),
        Link(a=0.4, m=1.0, r=(-0.2, 0, 0), I=((0.005, 0, 0), (0, 0.02, 0), (0, 0, 0.02))),
    )
    puck = Link(m=5.0, I=((0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.16)))
    return Robot("two_link_puck", arm, base_joint="planar", base_body=puck)


def _simulate(robot: Robot, steps: int = 400):
    """(t, q, v) from rest under τ = AMPLITUDE·sin(2πt/T), RK4 with the reference."""
    x, h = np.r_[0.0, 0.0, 0.3, 0.4, 1.1, np.zeros(5)], T / steps

    def f(t, x):
        tau = AMPLITUDE * np.sin(2 * np.pi * t / T)
        return np.r_[coordinate_rates(robot, x[:5], x[5:]), ref.accel(robot, x[:5], x[5:], tau)]

    out = [x]
    for k in range(steps):
        t = k * h
        k1 = f(t, x)
        k2 = f(t + h / 2, x + h / 2 * k1)
        k3 = f(t + h / 2, x + h / 2 * k2)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + f(t + h, x + h * k3))
        out.append(x)
    out = np.array(out)
    return np.linspace(0, T, steps + 1), out[:, :5], out[:, 5:]


@pytest.fixture(scope="module")
def puck():
    robot = _robot()
    return robot, ocp.dynamics(robot, compiled=False), _simulate(robot)


def test_planar_rates_are_the_base_joints_coordinate_rates(puck):
    robot, arm, _ = puck
    rng = np.random.default_rng(0)
    for q, v in zip(rng.normal(size=(5, 5)), rng.normal(size=(5, 5))):
        np.testing.assert_allclose(np.array(arm.rates(q, v)).ravel(), coordinate_rates(robot, q, v), atol=1e-14)


def test_the_shooting_interval_integrates_the_planar_rates(puck):
    """Multiple shooting's RK4 interval (q̇ = R(yaw)·v on the base) is the reference's RK4."""
    robot, arm, (t, q, v) = puck
    tau = np.r_[0.0, 0.0, 0.0, 1.0, -2.0]
    got = np.concatenate([np.array(x).ravel() for x in arm.shooting_step(3)(q[40], v[40], tau, 0.06)])

    def f(x):
        return np.r_[coordinate_rates(robot, x[:5], x[5:]), ref.accel(robot, x[:5], x[5:], tau)]

    want = functions.rk4_steps(f, np.r_[q[40], v[40]], 0.06, 3)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_an_unactuated_planar_base_is_moved_by_the_arm_alone(puck):
    robot, arm, (t, q, v) = puck
    assert np.abs(q[-1, :3]).max() > 0.02  # the sine moved the base
    problem = ocp.Problem(
        q[0],
        q[-1],
        T=T,
        N=20,
        method="hermite-simpson",
        qdf=v[-1],
        unactuated=(0, 1, 2),
        cost=ocp.Cost(effort=1.0),
    )
    solution = ocp.solve(problem, arm)
    assert np.abs(solution.tau[:, :3]).max() == 0.0  # the base is never pushed
    sine_effort = float(np.sum(AMPLITUDE**2) * T / 2)  # ∫ τᵀτ dt of a feasible motion (τ smooth, as here)
    assert solution.cost <= sine_effort * (1 + 1e-3)
    check = ocp.verify(robot, problem, solution, tol_q=2e-3, tol_qd=1e-2)
    assert check.ok, check.describe()
    momentum = ref.momentum(robot, check.q, check.qd)[:, [0, 1, 5]]  # in-plane linear, angular about z
    base_share = float(robot.base_body.m) * np.abs(check.qd[:, :2]).max()  # what the arm's must cancel
    assert base_share > 0.05 and np.abs(momentum).max() < 1e-5 * base_share  # from rest: RK4's error only


def test_floating_bases_the_transcription_does_not_take_are_refused_by_name(puck):
    robot, _, (t, q, v) = puck
    free = Robot("free_arm", robot.links, base_joint="free", base_body=robot.base_body)
    with pytest.raises(ValueError, match="a free base is not transcribed"):
        ocp.dynamics(free, compiled=False)
    with pytest.raises(ValueError, match="its base is free, not planar"):
        ocp.planar_rates(free)
    with pytest.raises(ValueError, match="plain source has no floating base"):
        ocp.dynamics(robot, "plain", compiled=False)
    for bad in ((0, 0), (5,), (0.5,), tuple(range(5))):
        with pytest.raises(ValueError, match="unactuated"):
            ocp.Problem(q[0], q[-1], T=T, unactuated=bad)
    with pytest.raises(ValueError, match="guess's q must have shape"):
        ocp.Problem(q[0], q[-1], T=T, guess=(t, q[:, :3], v))
    with pytest.raises(ValueError, match="guess's t must increase from 0"):
        ocp.Problem(q[0], q[-1], T=T, guess=(t[::-1], q, v))
