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


def test_a_joints_turn_of_an_inertia_is_r_j_rt_by_the_double_angle_where_it_can():
    """turned_inertia gives R·J·Rᵀ for every joint rotation: a turn about x, y or z, after a
    signed permutation (a URDF's right-angle rpy) or before one (standard DH's Rz(q)·Rx(π/2)), by
    the double angle (it names C2); an offset angle or a general constant rotation by the plain
    product."""
    import numpy as np
    import sympy as sp

    from symdyn.derivation.kinematics import turned_inertia
    from symdyn.derivation.tape import Tape

    q = sp.Symbol("q", real=True)
    c, s = sp.cos(q), sp.sin(q)
    turns = [
        sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]]),
        sp.Matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    ]
    P = sp.Matrix([[0, 0, 1], [1, 0, 0], [0, 1, 0]])  # rpy (π/2, 0, π/2)
    Rx = sp.Matrix([[1, 0, 0], [0, 0, -1], [0, 1, 0]])  # DH's α = π/2
    general = sp.Matrix(
        [[sp.Rational(3, 5), sp.Rational(-4, 5), 0], [sp.Rational(4, 5), sp.Rational(3, 5), 0], [0, 0, 1]]
    )
    co, so = sp.Rational(3, 5), sp.Rational(4, 5)  # an offset angle, as link_frames writes it
    ct, st = c * co - s * so, s * co + c * so
    offset = sp.Matrix([[ct, -st, 0], [st, ct, 0], [0, 0, 1]])
    cases = [(T, True) for T in turns] + [(P * turns[0], True), (turns[2] * Rx, True), (offset, False)]
    cases += [(general * turns[1], False)]
    rng = np.random.default_rng(3)
    names = sp.symbols("J11 J12 J13 J22 J23 J33", real=True)
    J = [[names[0], names[1], names[2]], [names[1], names[3], names[4]], [names[2], names[4], names[5]]]
    for k, (R, cheap) in enumerate(cases):
        tape = Tape()
        got = sp.Matrix(turned_inertia(tape, R, J, f"t{k}"))
        assert any(str(x).startswith("C2_") for x in tape.defs) == cheap, (k, R)
        for _ in range(3):
            at = dict(zip(names, rng.normal(size=6))) | {q: rng.uniform(-4, 4)}
            want = np.array((R * sp.Matrix(J) * R.T).subs(at), dtype=float)
            value = np.array(tape.full(got).subs(at), dtype=float)
            assert np.abs(value - want).max() <= 1e-14 * max(1.0, np.abs(want).max()), (k, R)
