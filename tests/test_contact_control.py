"""Whole-body inverse dynamics under contacts (issue 43, item 4): the torques and forces it gives,
fed back into the generated contact dynamics, give the desired acceleration and those forces;
the least-norm forces are the smallest that carry the base, weights move the load."""

import numpy as np
import pytest

from symdyn.apps.contact_control import WholeBodyInverseDynamics
from symdyn.codegen.entry import load
from symdyn.model.random_robots import random_tree_robot
from tests.test_task_space import states, with_random_frames


@pytest.fixture(scope="module")
def tree():
    """A random tree on a free base on a point and a surface (9 force rows for 6 base equations)."""
    robot = with_random_frames(random_tree_robot(3, n=5, base_joint="free"), 3).nofriction(all=True)
    return robot.with_frames(["f4", "f5"]).with_contacts({"f4": "point", "f5": "surface"})


@pytest.fixture(scope="module")
def standing(tree):
    """The tree, its generated contact dynamics (the lazy C target: only contact_fdyn is built, not
    every function as the NumPy target's whole file would) and its whole-body inverse dynamics."""
    return tree, load(tree, "c"), WholeBodyInverseDynamics(tree)


def _consistent(robot, f, count, seed):
    """States and accelerations the contacts allow: contact_fdyn's under random joint torques."""
    q, v, _ = states(robot, count, seed=seed)
    tau = np.random.default_rng(seed).uniform(-5, 5, (count, robot.nv))
    tau[:, :6] = 0.0
    a, force = f.contact_fdyn(q, v, tau)
    return q, v, a, tau, force


def test_fed_back_the_torques_give_the_acceleration_and_the_forces(standing):
    robot, f, wbid = standing
    q, v, a, _, _ = _consistent(robot, f, 20, seed=3)
    tau, force = wbid(q, v, a)  # a batch
    assert tau.shape == (20, robot.nv) and force.shape == (20, 9)
    assert np.all(tau[:, :6] == 0.0)  # the base is unactuated
    back_a, back_force = f.contact_fdyn(q, v, tau)
    assert np.abs(back_a - a).max() < 1e-9 * max(1.0, np.abs(a).max())
    assert np.abs(back_force - force).max() < 1e-9 * max(1.0, np.abs(force).max())
    one_tau, one_force = wbid(q[4], v[4], a[4])  # one state: the same numbers
    assert np.allclose(one_tau, tau[4], rtol=0, atol=1e-12) and np.allclose(one_force, force[4], rtol=0, atol=1e-12)


def test_least_norm_forces_are_the_smallest_that_carry_the_base(standing):
    """contact_fdyn's forces also realise a (with its torques); the least-norm ones are no larger,
    and weights shift the load away from the heavily weighted rows."""
    robot, f, wbid = standing
    q, v, a, _, force_fdyn = _consistent(robot, f, 10, seed=4)
    _, force = wbid(q, v, a)
    assert np.all(np.linalg.norm(force, axis=1) <= np.linalg.norm(force_fdyn, axis=1) + 1e-9)
    heavy = WholeBodyInverseDynamics(robot, weights=[100.0] * 3 + [1.0] * 6)
    tau_w, force_w = heavy(q, v, a)
    assert np.linalg.norm(force_w[:, :3]) < np.linalg.norm(force[:, :3])
    back_a, back_force = f.contact_fdyn(q, v, tau_w)
    assert np.abs(back_a - a).max() < 1e-9 * max(1.0, np.abs(a).max())
    assert np.abs(back_force - force_w).max() < 1e-9 * max(1.0, np.abs(force_w).max())


def test_a_set_that_cannot_carry_the_base_is_refused(tree):
    """On the default target (lazy C: only τ and the Jacobian are built, not every NumPy function)."""
    one_point = tree.with_contacts({"f4": "point"})
    wbid = WholeBodyInverseDynamics(one_point)
    q, v, a = states(one_point, 1, seed=5)
    with pytest.raises(ValueError, match=r"cannot carry its base: its forces span 3 of the base's 6 equations"):
        wbid(q[0], v[0], a[0])
    with pytest.raises(ValueError, match="weights must be 3 positive numbers"):
        WholeBodyInverseDynamics(one_point, weights=[1.0, -1.0, 1.0])
