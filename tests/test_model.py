"""The robot model: bad input is refused by name, operations return new robots.

Every refusal names its culprit (the argument, link or parameter) so that a
user can fix it; frozen robots are never mutated by payload, nofriction or
replace; a symbolic robot with its symbols substituted is the numeric one.
"""

import dataclasses
import math

import numpy as np
import pytest
import sympy as sp

from conftest import random_states
from symdyn import models
from symdyn.model import Link, Robot, rotx, transl
from symdyn.numeric import reference as ref

GOOD_I = ((0.1, 0, 0), (0, 0.2, 0), (0, 0, 0.3))


def _arm(*links, **kw):
    return Robot("arm", tuple(links), **kw)


def _puma_state(**bad):
    """Arguments (q, qd, qdd) for the Puma, with some replaced."""
    state = dict(q=np.zeros(6), qd=np.zeros(6), qdd=np.zeros(6))
    state.update(bad)
    return state


# --------------------------------------------------------------------------- bad states


@pytest.mark.parametrize(
    "bad, match",
    [
        (dict(q=np.zeros(5)), r"q must have shape \(6,\) or \(N, 6\); got shape \(5,\)"),
        (dict(qd=np.zeros((4, 7))), r"qd must have shape \(6,\) or \(N, 6\); got shape \(4, 7\)"),
        (dict(qdd=3.0), r"qdd must have shape \(6,\)"),
        (dict(q=np.zeros((3, 6)), qd=np.zeros((4, 6))), r"incompatible shapes: q \(3, 6\), qd \(4, 6\)"),
        (dict(q=[0, 0, math.nan, 0, 0, 0]), r"q contains NaN or infinity \(first at index \(2,\)\)"),
        (dict(qd=np.array([[0, 0, 0, 0, 0, 0], [0, math.inf, 0, 0, 0, 0]])), r"qd contains NaN or infinity"),
        (dict(qdd=["a"] * 6), r"qdd must be a numeric array"),
    ],
)
def test_bad_states_are_refused_by_name(puma, bad, match):
    with pytest.raises(ValueError, match=match):
        ref.rne(puma, **_puma_state(**bad))


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda r: ref.inertia(r, np.zeros(2)), r"q must have shape \(6,\)"),
        (lambda r: ref.gravload(r, [0, 0, 0, 0, 0, -math.inf]), r"q contains NaN"),
        (lambda r: ref.coriolis(r, np.zeros(6), np.zeros(3)), r"qd must have shape \(6,\)"),
        (lambda r: ref.accel(r, np.zeros(6), np.zeros(6), np.zeros(2)), r"tau must have shape \(6,\)"),
        (lambda r: ref.rne(r, np.zeros(6), np.zeros(6), np.zeros(6), wrench=np.zeros(3)), r"wrench .*shape \(6,\)"),
        (lambda r: ref.gravload(r, np.zeros(6), gravity=(0, 9.81)), r"gravity must be a finite 3-vector"),
        (lambda r: ref.fdyn(r, -1.0, np.zeros(6)), r"T must be a positive"),
        (lambda r: ref.fdyn(r, 1.0, np.zeros((2, 6))), r"q0 and qd0 must have shape \(6,\)"),
    ],
)
def test_bad_arguments_of_other_reference_functions_are_refused_by_name(puma, call, match):
    with pytest.raises(ValueError, match=match):
        call(puma)


# --------------------------------------------------------------------------- bad models


@pytest.mark.parametrize(
    "build, match",
    [
        (
            lambda: _arm(Link(m=1, I=((0.1, 0.05, 0), (0, 0.2, 0), (0, 0, 0.3)))),
            r"inertia of link 1 is not symmetric: I\[0,1\]=0.05, I\[1,0\]=0",
        ),
        (
            lambda: _arm(Link(m=1, I=GOOD_I), Link(m=1, I=((1, 0, 0), (0, -0.2, 0), (0, 0, 0.3)))),
            r"inertia of link 2 is not positive semidefinite",
        ),
        (
            lambda: _arm(Link(m=1, I=np.diag([1.0, 1.0, 3.0]))),
            r"inertia of link 1 is physically impossible: .* violate the triangle inequality",
        ),
        (lambda: _arm(Link(m=-2.0)), r"mass of link 1 is negative: m = -2.0"),
        (lambda: _arm(Link(m=1), convention="craig"), r"unknown DH convention 'craig'"),
        (lambda: Link(joint="spherical"), r"unknown joint type 'spherical'"),
        (lambda: Link(qlim=(1.0, -1.0)), r"joint limits reversed or empty: qlim = \(1.0, -1.0\)"),
        (lambda: _arm(Link(m=1), Link(G=0, Jm=1e-4)), r"gear ratio of link 2 is 0 but it has motor parameters"),
        (lambda: _arm(Link(m=1), base=np.diag([1.0, 1.0, -1.0, 1.0])), r"base rotation is not a proper rotation"),
        (lambda: _arm(Link(m=1), base=np.array(transl(1, 0, 0)) * 2), r"base is not a homogeneous transform"),
        (lambda: _arm(Link(m=1), tool=((1, 0, 0, 0), (0, 2, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))), r"tool rotation"),
        (lambda: Robot("empty", ()), r"robot 'empty' has no links"),
        (lambda: _arm(Link(m=1), "link"), r"links\[1\] of robot 'arm' is a str, expected Link"),
        (lambda: Link(r=(0, 0)), r"r must have 3 elements, got 2"),
        (lambda: Link(I=((1, 0), (0, 1))), r"I must be a 3×3 matrix"),
        (lambda: Link(m=math.nan), r"m must be finite"),
        (lambda: _arm(Link(Tc=(-0.1, -0.2), G=10)), r"Coulomb friction of link 1 must be Tc = \(Tc\+ >= 0"),
        (lambda: _arm(Link(B=-1.0, G=10)), r"B of link 1 is negative"),
        (lambda: models.load("puma560").payload(-1.0), r"payload mass is negative: -1.0"),
        (lambda: models.load("puma560").payload(1.0, (0, 0)), r"payload position must have 3 elements"),
    ],
)
def test_bad_models_are_refused_by_name(build, match):
    with pytest.raises(ValueError, match=match):
        build()


def test_unknown_model_name_lists_the_known_ones():
    with pytest.raises(KeyError, match=r"unknown model 'kuka': known models are .*puma560.*rrp") as info:
        models.load("kuka")
    for name in models.NAMES:
        assert name in str(info.value)


def test_symbolic_robot_is_refused_by_the_reference_naming_its_symbols():
    sym = models.load("twolink", symbolic=True)
    with pytest.raises(ValueError, match=r"needs a numeric robot.*'twolink_sym'.*a1, a2, c1, c2, g, m1, m2"):
        ref.rne(sym, np.zeros(2), np.zeros(2), np.zeros(2))
    with pytest.raises(KeyError, match=r"no parameter\(s\) \[x\]"):
        sym.subs({"x": 1})


# --------------------------------------------------------------------------- new robots, never mutated


def test_robot_and_link_are_frozen(puma):
    with pytest.raises(dataclasses.FrozenInstanceError):
        puma.gravity = (0, 0, 1.62)
    with pytest.raises(dataclasses.FrozenInstanceError):
        puma.links[0].m = 3.0


def test_payload_and_nofriction_return_new_robots_and_leave_the_original(puma):
    before = puma.fingerprint()
    links = puma.links
    book = puma.payload(2.5, (0.01, -0.02, 0.1))
    additive = puma.payload(2.5, (0.01, -0.02, 0.1), additive=True)
    coulomb_free, frictionless = puma.nofriction(), puma.nofriction(all=True)
    assert puma.fingerprint() == before and puma.links is links
    assert puma.links[-1].m == 0.09 and puma.links[0].Tc == (0.395, -0.435) and puma.links[0].B == 0.00148
    assert (
        len(
            {before, book.fingerprint(), additive.fingerprint(), coulomb_free.fingerprint(), frictionless.fingerprint()}
        )
        == 5
    )
    assert coulomb_free.links[0].Tc == (0, 0) and coulomb_free.links[0].B == 0.00148
    assert frictionless.links[0].Tc == (0, 0) and frictionless.links[0].B == 0
    assert book.links[:-1] == puma.links[:-1] == additive.links[:-1]


def test_payload_book_semantics_replaces_mass_and_com_keeps_inertia(puma):
    book = puma.payload(2.5, (0.01, -0.02, 0.1))
    last = book.links[-1]
    assert last.m == 2.5 and last.r == (0.01, -0.02, 0.1) and last.I == puma.links[-1].I


def test_payload_additive_combines_mass_com_and_inertia(puma):
    """m = m₆ + m, COM = mass-weighted mean, I about the new COM (parallel axes); Pinocchio in test_reference."""
    m6, r6 = 0.09, np.array([0, 0, 0.032])
    m, p = 2.5, np.array([0.01, -0.02, 0.1])
    last = puma.payload(m, p, additive=True).links[-1]
    c = (m6 * r6 + m * p) / (m6 + m)
    shift = lambda mass, d: mass * (d @ d * np.eye(3) - np.outer(d, d))  # noqa: E731
    I = np.array(puma.links[-1].I, float) + shift(m6, r6 - c) + shift(m, p - c)
    assert last.m == pytest.approx(m6 + m, rel=1e-15)
    assert np.allclose(last.r, c, rtol=1e-14, atol=0)
    assert np.allclose(np.array(last.I, float), I, rtol=1e-13, atol=1e-18)


def test_replace_gives_a_variant_robot_with_new_base_and_gravity(puma):
    moon = dataclasses.replace(puma, base=rotx(math.pi), gravity=(0, 0, 1.62))
    assert moon.base[2][2] == -1 and moon.gravity == (0, 0, 1.62) and moon.links == puma.links
    assert puma.base[2][2] == 1 and puma.gravity == (0, 0, 9.81)
    q = puma.qn
    assert np.allclose(ref.gravload(moon, q), -ref.gravload(puma, q) * 1.62 / 9.81, rtol=1e-12, atol=1e-14)
    with pytest.raises(ValueError, match="base rotation"):
        dataclasses.replace(puma, base=np.diag([2.0, 1.0, 0.5, 1.0]))


@pytest.mark.parametrize("by", ["name", "symbol"])
def test_subs_on_the_symbolic_twolink_gives_the_numeric_twolinks_dynamics(twolink, by):
    sym = models.load("twolink", symbolic=True)
    values = {"a1": 1, "a2": 1, "c1": sp.Rational(-1, 2), "c2": -0.5, "m1": 1, "m2": 1.0, "g": 9.81}
    if by == "symbol":
        values = {s: values[s.name] for s in sym.free_symbols}
    robot = sym.subs(values)
    assert not robot.is_symbolic and sym.is_symbolic
    q, qd, qdd = random_states(twolink, 100, seed=9)
    for a, b in (
        (ref.rne(robot, q, qd, qdd), ref.rne(twolink, q, qd, qdd)),
        (ref.inertia(robot, q), ref.inertia(twolink, q)),
        (ref.coriolis(robot, q, qd), ref.coriolis(twolink, q, qd)),
        (ref.fkine(robot, q), ref.fkine(twolink, q)),
    ):
        assert np.abs(a - b).max() <= 1e-13 * np.abs(b).max()
    assert np.abs(ref.gravload(twolink, q)).max() > 1.0


# --------------------------------------------------------------------------- general joints


def test_a_generic_float_rotation_becomes_an_exactly_orthogonal_rational_one():
    from symdyn.model.placement import rational_rotation
    from symdyn.model.random_arms import _rotation
    import random

    rng = random.Random(3)
    for R in [_rotation(rng) for _ in range(20)] + [np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, -1.0, 1.0])]:
        E = sp.Matrix(rational_rotation(R))
        assert E * E.T == sp.eye(3) and E.det() == 1
        np.testing.assert_allclose(np.array(E, dtype=float), R, atol=2e-15)


# make test-all: the regrouped recursion on generically turned arms is in the main suite at three and four
# joints (tests/test_regressor.py::test_base_parameters_of_generically_turned_arms_are_exact, and
# tests/test_any_arm.py::test_random_general_arm_agrees_at_every_stage derives it)
@pytest.mark.slow
def test_code_generation_regroups_generically_turned_arms():
    """Base parameters no longer cost minutes per generic constant rotation: a generically placed
    arm's code comes from the regrouped recursion like the shipped arms'."""
    from symdyn.codegen.entry import bundle
    from symdyn.derivation.regressor import generic_turns
    from symdyn.model import placement

    links = tuple(
        Link(origin=placement((0.1, 0, 0.2), (0.3 * k + 0.1, -0.2, 0.7)), axis=(0.6, 0, 0.8), m=1.0, I=0.01 * np.eye(3))
        for k in range(4)
    )
    robot = Robot("g4", links, convention="general")
    assert generic_turns(robot) == 4
    assert "newton-euler, base parameters" in bundle(robot).derivation


def test_placement_takes_exactly_three_finite_numbers_each():
    """xyz and rpy are three finite numbers (or symbols) each: extra entries are not dropped,
    missing ones are not an IndexError, NaN and inf are refused by name."""
    from symdyn.model import placement

    x = sp.Symbol("x")
    T = placement((x, 0, "0.5"), (0, 0, math.pi / 2))
    assert T[0] == (0, -1, 0, x) and T[1] == (1, 0, 0, 0) and T[2] == (0, 0, 1, sp.Rational(1, 2))
    bad = {
        (ValueError, r"xyz must have exactly three entries, got 4"): ((0, 0, 0, 1), (0, 0, 0)),
        (ValueError, r"xyz must have exactly three entries, got 2"): ((0, 0), (0, 0, 0)),
        (ValueError, r"rpy must have exactly three entries, got 2"): ((0, 0, 0), (0, 0)),
        (ValueError, r"xyz\[0\] must be finite, got nan"): ((math.nan, 0, 0), (0, 0, 0)),
        (ValueError, r"xyz\[2\] must be finite, got inf"): ((0, 0, math.inf), (0, 0, 0)),
        (ValueError, r"rpy\[1\] must be finite, got -inf"): ((0, 0, 0), (0, -math.inf, 0)),
        (ValueError, r"rpy\[0\] must be finite, got nan"): ((0, 0, 0), (math.nan, 0, 0)),
        (ValueError, r"xyz\[1\] must be a number, got the bool True"): ((0, True, 0), (0, 0, 0)),
        (TypeError, r"xyz\[0\] must be a number or sympy expression, got None"): ((None, 0, 0), (0, 0, 0)),
        (TypeError, r"rpy must be a sequence of three numbers, got 5"): ((0, 0, 0), 5),
    }
    for (error, message), (xyz, rpy) in bad.items():
        with pytest.raises(error, match=message):
            placement(xyz, rpy)


@pytest.mark.parametrize("angle", [math.inf, -math.inf, math.nan, sp.oo, sp.nan])
def test_a_rotation_of_a_non_finite_angle_is_refused_by_name(angle):
    from symdyn.model import exact_cos_sin, roty, rotz

    for f in (exact_cos_sin, rotx, roty, rotz):
        with pytest.raises(ValueError, match=r"the angle must be a finite number, got (-?inf|nan|oo)"):
            f(angle)
    x = sp.Symbol("x")
    assert rotx(x)[1] == (0, sp.cos(x), -sp.sin(x), 0) and rotz(math.pi)[0] == (-1, 0, 0, 0)
