"""Linearity in the inertial parameters: regressor, base parameters, regrouping."""

import numpy as np
import pytest
import sympy as sp

from symdyn import models
from symdyn.derivation.entry import derive
from symdyn.derivation.regressor import base_parameters, parameter_symbols, parameter_values, regressor
from symdyn.derivation.symbols import joint_symbols
from symdyn.numeric import reference as ref

from conftest import random_states


def _Y(reg, robot):
    q, qd, qdd = joint_symbols(robot.n)
    defs = list(reg.tape.defs.items())
    Y = sp.Matrix(robot.n, len(reg.params), lambda i, k: reg.columns[k][i])
    return sp.lambdify(list(q) + list(qd) + list(qdd), Y, "numpy", cse=lambda e: (defs, e), docstring_limit=0)


@pytest.mark.parametrize("name", ["twolink", "rrp", "puma560"])
def test_regressor_times_standard_parameters_is_the_reference_torque(name):
    robot = models.load(name)
    reg = regressor(robot)
    Y = _Y(reg, robot)
    pi = np.array([float(v) for v in parameter_values(robot)])
    base = base_parameters(robot)
    beta = np.array([float(v) for v in base.regrouped])
    q, qd, qdd = random_states(robot, 200, seed=11)
    for state in zip(q, qd, qdd):
        Ys = np.array(Y(*np.concatenate(state)), dtype=float)
        tau = ref.rne(robot, *state)
        assert np.abs(Ys @ pi - tau).max() <= 1e-12 * max(1, np.abs(tau).max())
        assert np.abs(Ys @ beta - tau).max() <= 1e-12 * max(1, np.abs(tau).max())


def test_twolink_has_the_seven_classical_base_inertial_parameters():
    robot = models.load("twolink")
    base = base_parameters(robot)
    names = [str(base.params[i]) for i in base.independent]
    inertial = [n for n in names if not n.startswith(("FV", "FS", "FO"))]
    # planar 2R with gravity in the plane: ZZ1R, MX1R, MY1, ZZ2R, MX2, MY2, IA2 (IA1 merges into ZZ1)
    assert sorted(inertial) == sorted(["ZZ1", "MX1", "MY1", "ZZ2", "MX2", "MY2", "IA2"])
    zz1 = base.expressions[names.index("ZZ1")]
    XX, ZZ, M, IA = (sp.Symbol(f"{s}{i}", real=True) for s, i in (("XX", 1), ("ZZ", 1), ("M", 2), ("IA", 1)))
    # Khalil's rule: ZZ1R = ZZ1 + IA1 + a2² M2 (a2 = 1 m in the modified frames); no XX1 in it
    assert zz1.coeff(IA) == 1 and zz1.coeff(M) == 1 and zz1.coeff(XX) == 0 and zz1.coeff(ZZ) == 1


def test_base_parameters_of_the_puma():
    base = base_parameters(models.load("puma560"))
    friction = [i for i in base.independent if str(base.params[i]).startswith(("FV", "FS", "FO"))]
    assert len(friction) == 18
    assert len(base.independent) - len(friction) == 40


def test_regrouped_recursion_has_the_same_dynamics_and_fewer_operations():
    robot = models.load("puma560")
    plain, grouped = derive(robot), derive(robot, regroup=True)
    q, qd, qdd = random_states(robot, 20, seed=5)
    f = sp.lambdify(
        list(grouped.q) + list(grouped.qd) + list(grouped.qdd),
        grouped.named["tau"],
        "numpy",
        cse=lambda e: (list(grouped.definitions), e),
        docstring_limit=0,
    )
    for state in zip(q, qd, qdd):
        tau = np.array(f(*np.concatenate(state)), dtype=float).ravel()
        assert np.abs(tau - ref.rne(robot, *state)).max() < 1e-11
    for term in ("tau", "M", "G"):
        a, b = plain.op_count(term), grouped.op_count(term)
        assert b["mul"] + b["add"] < a["mul"] + a["add"], term


def test_regressor_of_a_symbolic_arm_is_linear_in_its_parameters():
    robot = models.load("twolink", symbolic=True)
    reg = regressor(robot)
    assert len(reg.params) == 28 and reg.Y.shape == (2, 28)
    tau = derive(robot).tau
    pi = dict(zip(parameter_symbols(2), parameter_values(robot)))
    diff = (reg.Y * sp.Matrix([pi[p] for p in reg.params]) - tau).applyfunc(sp.expand)
    assert all(sp.expand(sp.expand_trig(d)) == 0 or sp.simplify(d) == 0 for d in diff)


def test_base_parameters_need_numeric_geometry():
    with pytest.raises(ValueError, match="numeric geometry"):
        base_parameters(models.load("twolink", symbolic=True))


def test_regroup_needs_a_numeric_robot_and_newton_euler():
    with pytest.raises(ValueError, match="regroup"):
        derive(models.load("twolink", symbolic=True), regroup=True)
    with pytest.raises(ValueError, match="regroup"):
        derive(models.load("twolink"), "lagrange", regroup=True)


def _exact_inertial_Y(robot, points: int, seed: int):
    """The sympy regressor's inertial columns at rational points, exactly (rows: joint × point)."""
    import random

    from sympy.polys.domains import QQ
    from sympy.polys.matrices import DomainMatrix

    from symdyn.derivation.exact import compile_exact, random_rational_point
    from symdyn.derivation.regressor import FRICTION, INERTIAL

    reg = regressor(robot)
    n, per = robot.n, len(INERTIAL) + len(FRICTION)
    inertial = [k for k in range(len(reg.params)) if k % per < len(INERTIAL)]
    q, qd, qdd = joint_symbols(n)
    inputs = [f(x) for x in q for f in (sp.cos, sp.sin)] + list(q) + list(qd) + list(qdd)
    evaluate = compile_exact(reg.tape.defs.items(), [reg.columns[k][i] for k in inertial for i in range(n)], inputs)
    rng, rows = random.Random(seed), []
    for _ in range(points):
        point = random_rational_point(n, rng)
        values = evaluate(*(sp.Rational(point[x]) for x in inputs))
        rows += [
            [QQ(values[c * n + i].numerator, values[c * n + i].denominator) for c in range(len(inertial))]
            for i in range(n)
        ]
    return inertial, DomainMatrix(rows, (len(rows), len(inertial)), QQ)


@pytest.mark.parametrize("seed", [3, 12])
def test_base_parameters_of_generically_turned_arms_are_exact(seed):
    """Khalil's rules and a rank analysis in doubles, checked against the symbolic regressor at
    fresh rational points, exactly: as many independent columns as Y's rank, and Y·β_regrouped
    equal to Y·π (every generic constant rotation included: no digits too many to handle)."""
    from symdyn.model.random_arms import ArmOptions, random_arm
    from symdyn.derivation.regressor import generic_turns

    robot = random_arm(seed, ArmOptions(general=1.0, symbolic=0.0, n_min=3, n_max=4))
    assert generic_turns(robot) >= 3
    base = base_parameters(robot)
    inertial, Y = _exact_inertial_Y(robot, 40 // robot.n + 2, seed=100 + seed)
    kept = [c for c, k in enumerate(inertial) if k in base.independent]
    assert Y.rank() == len(kept) == Y.extract(list(range(Y.shape[0])), kept).rank()
    values = parameter_values(robot)
    pi = sp.Matrix([values[k] for k in inertial]).to_DM().convert_to(Y.domain).transpose()
    beta = sp.Matrix([base.regrouped[k] for k in inertial]).to_DM().convert_to(Y.domain).transpose()
    assert (Y * pi.transpose()).to_Matrix() == (Y * beta.transpose()).to_Matrix()


def test_the_regrouped_recursion_gives_c_as_half_the_derivative_of_c_qd():
    """Code generation's derivation skips the n(n+1)/2 Christoffel recursions (the only part
    that grows like n³): its C is ½ ∂(C q̇)/∂q̇, exactly the Christoffel C of the full recursion."""
    robot = models.load("rrp")
    plain, grouped = derive(robot), derive(robot, regroup=True)
    assert "C" not in grouped.named and "C" in plain.named
    assert (grouped.C - plain.C).applyfunc(sp.expand) == sp.zeros(robot.n, robot.n)
    assert (grouped.Cqd - plain.Cqd).applyfunc(sp.expand) == sp.zeros(robot.n, 1)
