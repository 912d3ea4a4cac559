"""Symbolic kinematics: exact constants, and the same poses and Jacobians as the reference."""

import numpy as np
import pytest
import sympy as sp

from symdyn import models
from symdyn.derivation import kinematics
from symdyn.derivation.entry import derive
from symdyn.derivation.symbols import joint_symbols
from symdyn.numeric import reference as ref

from conftest import random_states


@pytest.mark.parametrize("name", ["puma560", "puma560_mdh", "rrp", "twolink"])
def test_fkine_and_jacob0_agree_with_the_reference(name):
    robot = models.load(name)
    q = joint_symbols(robot.n)[0]
    T = sp.lambdify(q, kinematics.fkine(robot), "numpy")
    J = sp.lambdify(q, kinematics.jacob0(robot), "numpy")
    for state in random_states(robot, 50, seed=2)[0]:
        assert np.abs(np.array(T(*state), float) - ref.fkine(robot, state)).max() < 1e-12
        assert np.abs(np.array(J(*state), float) - ref.jacob0(robot, state)).max() < 1e-12


@pytest.mark.parametrize("name", ["puma560", "puma560_mdh", "rrp"])
def test_every_body_frame_agrees_with_the_reference(name):
    """The reference's body_frames (what pictures draw) are the symbolic link poses, the base first."""
    robot = models.load(name)
    q = joint_symbols(robot.n)[0]
    poses = sp.lambdify(q, kinematics.link_poses(robot), "numpy")
    for state in random_states(robot, 20, seed=3)[0]:
        got = ref.body_frames(robot, state)
        assert np.abs(got[0] - np.array(robot.base, dtype=float)).max() == 0
        assert np.abs(got[1:] - np.array(poses(*state), dtype=float)).max() < 1e-12


def test_right_angles_are_exact():
    robot = models.load("puma560")  # α = ±π/2 stored as floats
    for frame in kinematics.link_frames(robot):
        for x in list(frame.R) + list(frame.p):
            assert not any(isinstance(a, sp.Float) for a in sp.sympify(x).atoms(sp.Number))
    R1 = kinematics.link_frames(robot)[0].R
    q1 = joint_symbols(6)[0][0]
    assert R1 == sp.Matrix([[sp.cos(q1), 0, sp.sin(q1)], [sp.sin(q1), 0, -sp.cos(q1)], [0, 1, 0]])


def test_symbolic_parameters_flow_through_the_kinematics():
    robot = models.load("twolink", symbolic=True)
    a1, a2 = sp.symbols("a1 a2", real=True)
    q1, q2 = joint_symbols(2)[0]
    T = kinematics.fkine(robot)
    # the arm moves in the world x–z plane (base Rx(π/2))
    assert sp.simplify(T[0, 3] - (a1 * sp.cos(q1) + a2 * sp.cos(q1 + q2))) == 0
    assert sp.simplify(T[2, 3] - (a1 * sp.sin(q1) + a2 * sp.sin(q1 + q2))) == 0
    assert T[1, 3] == 0


def test_long_derivations_report_progress(capsys):
    derive(models.load("puma560"), cache=False, progress=True)
    err = capsys.readouterr().err
    assert "newton-euler puma560: 6/24" in err and "24/24 Christoffel 56" in err and "done in" in err


def test_symbolic_dh_angles_are_a_clear_error_for_lagrange():
    alpha = sp.Symbol("alpha1", real=True)
    base = models.load("twolink")
    import dataclasses

    robot = dataclasses.replace(base, links=(dataclasses.replace(base.links[0], alpha=alpha),) + base.links[1:])
    with pytest.raises(ValueError, match="alpha|α"):
        derive(robot, "lagrange", cache=False)
    dyn = derive(robot, "newton-euler", cache=False)  # Newton–Euler handles it
    assert dyn.M.free_symbols >= {alpha}
