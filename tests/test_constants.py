"""The named-constant form (issue 14): exact, Armstrong-like, and Eq. 9.3 for the two-link arm."""

import pytest
import sympy as sp

from symdyn import cli, models
from symdyn.derivation import trigpoly
from symdyn.presentation.constants import constant_form, render_form, units
from symdyn.derivation.entry import derive
from tests.conftest import tiered


@pytest.fixture(scope="module")
def twolink_sym():
    return constant_form(derive(models.load("twolink", symbolic=True)))


@pytest.fixture(scope="module")
def puma():
    return constant_form(derive(models.load("puma560")))


def _angles(dyn):
    return [q for q, link in zip(dyn.q, dyn.robot.links) if link.is_revolute]


@pytest.mark.parametrize("kind", tiered(["M", "G", "F", "Cqd"], 3))  # C·q̇: make test-all
def test_the_puma_form_expands_back_to_exactly_the_derived_dynamics(puma, kind):
    dyn = puma.dyn
    ours = puma.matrix(kind)
    derived = {"M": dyn.M, "Cqd": dyn.Cqd, "G": dyn.G, "F": dyn.F}[kind]
    values = {c.symbol: c.value for c in puma.constants}
    values.update(dict(puma.abbreviations))
    for a, b in zip(ours, derived):
        if kind == "F":  # sgn(q̇) is no trig polynomial: F is compared as it stands
            assert sp.expand(a.xreplace(values) - b) == 0
        else:
            assert trigpoly.equal(a.xreplace(values), b, _angles(dyn))


def test_the_puma_has_armstrong_like_constants_with_values_and_units(puma):
    names = [str(c.symbol) for c in puma.constants]
    inertial = [n for n in names if n.startswith("I")]
    gravity = [n for n in names if n.startswith("g")]
    assert 20 <= len(inertial) <= 40 and len(gravity) == 5  # Armstrong et al.: 23 and 5 (pruned)
    assert {c.units for c in puma.constants if str(c.symbol) in inertial} == {"kg·m²"}
    assert {c.units for c in puma.constants if str(c.symbol) in gravity} == {"N·m"}
    assert all(c.value > 0 for c in puma.constants if not str(c.symbol).startswith("F"))
    # the q2 + q3 axis is folded: S23, C23 abbreviations and never a bare S3·C2 product in G
    abbreviations = {str(s): e for s, e in puma.abbreviations}
    assert abbreviations["S23"] == sp.sin(puma.dyn.q[1] + puma.dyn.q[2])
    G2 = dict((n, t) for n, _, t in puma.elements)["G2"]
    # Armstrong et al.'s five terms and the S23·C5 term of the wrist offset they pruned
    assert {" ".join(sorted(map(str, t.free_symbols))) for t in G2} == {
        "C5 S23 g1",
        "C23 C4 S5 g1",
        "S2 g2",
        "S23 g3",
        "C2 g4",
        "C23 g5",
    }
    # M55 and M66 are one constant each: the rotor and link inertias of the wrist
    by = {n: t for n, _, t in puma.elements}
    assert len(by["M55"]) == len(by["M66"]) == 1


def test_the_puma_constant_definition_is_exact_in_link_parameters(puma):
    from symdyn.derivation.regressor import parameter_symbols, parameter_values

    robot = puma.dyn.robot
    values = dict(zip(parameter_symbols(robot.n), parameter_values(robot)))
    for c in puma.constants:
        if not str(c.symbol).startswith("F"):
            assert c.definition.xreplace(values) == c.value


def test_twolink_constants_are_the_books_groups(twolink_sym):
    a1, a2, c1, c2, m1, m2, g = sp.symbols("a1 a2 c1 c2 m1 m2 g", real=True)
    defs = {str(c.symbol): c.definition for c in twolink_sym.constants}
    assert sp.expand(defs["I1"] - (m1 * (a1 + c1) ** 2 + m2 * (a1**2 + (a2 + c2) ** 2))) == 0
    assert sp.expand(defs["I2"] - 2 * a1 * m2 * (a2 + c2)) == 0
    assert defs["I3"] == m2 * (a2 + c2) ** 2
    assert defs["g2"] == g * m2 * (a2 + c2)
    # masses outside: I1 is m1·(…) + m2·(…), the printed grouping of Eq. 9.3
    assert set(sp.Add.make_args(defs["I1"])) == {m1 * (a1 + c1) ** 2, m2 * (a1**2 + (a2 + c2) ** 2)}


def test_twolink_form_expands_to_the_derived_torque(twolink_sym):
    dyn = twolink_sym.dyn
    for (name, terms), tau in zip(twolink_sym.tau, dyn.tau):
        assert trigpoly.equal(twolink_sym.expand(sp.Add(*terms)), tau, dyn.q)


def test_units_read_like_an_engineer_writes_them():
    assert units((1, 2, 0)) == "kg·m²"
    assert units((1, 2, -2)) == "N·m"
    assert units((1, 1, -2)) == "N"
    assert units((1, 1, 0)) == "kg·m"


def test_rendered_constants_fit_their_width_in_every_format(twolink_sym):
    from symdyn.presentation.printing import WIDTHS, latex_width

    for fmt in ("text", "pretty", "latex"):
        out = render_form(twolink_sym, fmt)
        rows = [r for r in out.splitlines() if r and not r.startswith(("#", "%", "\\"))]
        measure = latex_width if fmt == "latex" else len
        assert rows and max(measure(r) for r in rows) <= WIDTHS[fmt]


def test_cli_prints_the_constants_and_the_op_counts(capsys):
    assert cli.main(["print", "twolink", "--constants"]) == 0
    out = capsys.readouterr().out
    assert "I1 [kg·m²] = m1*(a1 + c1)**2 + m2*(a1**2 + (a2 + c2)**2)" in out
    assert "tau1 = M11*qdd1 + M12*qdd2 + b1_12*qd1*qd2 + c1_2*qd2**2 + G1" in out
    assert "named constants" in out and "generated (" in out
