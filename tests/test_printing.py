"""Printed closed forms, significance pruning and the `symdyn print` command."""

import re

import numpy as np
import pytest
import sympy as sp

from symdyn import cli, models
from symdyn.derivation.entry import derive
from symdyn.presentation.printing import closed_form, elements, render
from symdyn.derivation.simplify import prune, tidy
from tests.conftest import tiered


def test_twolink_tau1_prints_in_the_grouping_of_eq_9_3():
    dyn = derive(models.load("twolink", symbolic=True))
    tau1 = dict(elements(dyn, "tau"))["tau1"]
    qdd1, qdd2 = dyn.qdd
    qd1, qd2 = dyn.qd
    a1, a2, c2, m2 = sp.symbols("a1 a2 c2 m2", real=True)
    terms = sp.Add.make_args(tau1)
    # one term per motion monomial, plus the gravity term g·[…]
    assert len(terms) == 5
    by = {t.as_independent(qdd1, qdd2, qd1, qd2)[1]: t for t in terms}
    assert set(by) == {qdd1, qdd2, qd1 * qd2, qd2**2, 1}
    assert sp.expand(by[qd1 * qd2] + 2 * a1 * m2 * (a2 + c2) * sp.sin(dyn.q[1]) * qd1 * qd2) == 0


def test_printed_text_names_every_element(capsys):
    assert cli.main(["print", "twolink", "--term", "M"]) == 0
    out = capsys.readouterr().out
    assert "M11 = " in out and "M12 = " in out and "M22 = " in out and "M21" not in out
    assert "cos(q2)" in out
    assert "operations (mul + add) at each stage, full inertial parameters (not regrouped), without friction:" in out


def test_latex_is_a_complete_document_with_balanced_braces():
    dyn = derive(models.load("twolink", symbolic=True))
    tex = closed_form(dyn, ("M", "tau"), "latex")
    assert tex.startswith("\\documentclass") and tex.rstrip().endswith("\\end{document}")
    assert tex.count("{") == tex.count("}")
    assert tex.count("\\begin{align*}") == tex.count("\\end{align*}") == 5
    assert "\\dot{q}_{2}" in tex and "\\ddot{q}_{1}" in tex


def _overfull_boxes(tex: str, folder) -> list[float]:
    """Compile `tex` with pdflatex; the widths (pt) by which boxes overflow."""
    import re
    import shutil
    import subprocess

    engine = shutil.which("pdflatex")
    if engine is None:
        pytest.skip(
            "pdflatex is not installed (Debian: apt-get install texlive-latex-base); "
            "test_every_printed_line_fits_its_width_budget guards the widths without TeX"
        )
    (folder / "eq.tex").write_text(tex)
    run = subprocess.run(
        [engine, "-interaction=nonstopmode", "-halt-on-error", "eq.tex"],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stdout[-2000:]
    return [float(w) for w in re.findall(r"Overfull \\\\hbox \\(([\\d.]+)pt too wide\\)", run.stdout)]


def test_latex_of_the_two_link_arm_compiles_with_no_overfull_box(tmp_path):
    dyn = derive(models.load("twolink", symbolic=True))
    tex = closed_form(dyn, ("M", "C", "G", "tau"), "latex")
    assert not [w for w in _overfull_boxes(tex, tmp_path) if w > 1]


def test_latex_of_the_pumas_named_constants_compiles_with_no_overfull_box(tmp_path):
    from symdyn.presentation.constants import constant_form, render_form

    tex = render_form(constant_form(derive(models.load("puma560"))), "latex")
    assert not [w for w in _overfull_boxes(tex, tmp_path) if w > 1]


@pytest.mark.parametrize("fmt", tiered(["text", "pretty", "latex"], 1))
def test_every_printed_line_fits_its_width_budget(fmt):
    from symdyn.presentation.printing import WIDTHS, latex_width

    measure = latex_width if fmt == "latex" else len
    for name, terms in (("twolink", ("M", "C", "G", "tau")), ("puma560", ("G",))):
        dyn = derive(models.load(name, symbolic=name == "twolink"))
        out = closed_form(dyn, terms, fmt)
        rows = [r.removesuffix(" \\\\") for r in out.splitlines() if r.strip() and not r.startswith("\\")]
        assert len(rows) > len(terms)
        assert max(measure(r) for r in rows) <= WIDTHS[fmt], max(rows, key=measure)
    # and the budget is what breaks them: the two-link tau1 needs several lines at 60 characters
    from symdyn.presentation.printing import wrap

    tau1 = dict(elements(derive(models.load("twolink", symbolic=True)), "tau"))["tau1"]
    lines = wrap("tau1", tau1, "text", width=60)
    assert len(lines) >= 4 and max(map(len, lines)) <= 60


def test_numbers_print_like_an_engineer_writes_them():
    from symdyn.presentation.printing import number

    assert number(0.25) == "0.25" and number(6.5) == "6.5" and number(1.23456e-5, 3) == "1.23e-5"
    dyn = derive(models.load("rrp"))
    text = closed_form(dyn, ("M",), "text", digits=4)
    assert "M33 = 6.5" in text and "0.25000" not in text and "e-" not in text
    assert not re.search(r"\\d{12,}", text)  # no giant integers of factored rationals


def test_twolink_prints_eq_9_3_as_the_book_groups_it():
    """Corke, RVC Eq. 9.3: τ1 = M11 q̈1 + M12 q̈2 + C1 q̇1q̇2 + C2 q̇2² + g1, with (the book's grouping)
    M11 = m1(a1² + 2a1c1 + c1²) + m2(a1² + (a2 + c2)² + (2a1a2 + 2a1c2) cos q2),
    M12 = m2(a2 + c2)(a2 + c2 + a1 cos q2), C1 = −2a1m2(a2 + c2) sin q2,
    C2 = −a1m2(a2 + c2) sin q2, g1 = g((a1m1 + a1m2 + c1m1) cos q1 + (a2m2 + c2m2) cos(q1 + q2))."""
    dyn = derive(models.load("twolink", symbolic=True))
    a1, a2, c1, c2, m1, m2, g = sp.symbols("a1 a2 c1 c2 m1 m2 g", real=True)
    q1, q2 = dyn.q
    qd1, qd2 = dyn.qd
    qdd1, qdd2 = dyn.qdd
    C, S = sp.cos(q2), sp.sin(q2)
    book = {  # outer factor → {trig monomial: coefficient}, as printed in the book
        "M11": {m1: {1: a1**2 + 2 * a1 * c1 + c1**2}, m2: {1: a1**2 + (a2 + c2) ** 2, C: 2 * a1 * a2 + 2 * a1 * c2}},
        "M12": {m2: {1: (a2 + c2) ** 2, C: a1 * (a2 + c2)}},
        "C1": {m2: {S: -2 * a1 * (a2 + c2)}},
        "C2": {m2: {S: -a1 * (a2 + c2)}},
        "g1": {g: {sp.cos(q1): a1 * m1 + a1 * m2 + c1 * m1, sp.cos(q1 + q2): a2 * m2 + c2 * m2}},
    }
    tau1 = dict(elements(dyn, "tau"))["tau1"]
    by_rate = {
        t.as_independent(qdd1, qdd2, qd1, qd2)[1]: t.as_independent(qdd1, qdd2, qd1, qd2)[0]
        for t in sp.Add.make_args(tau1)
    }
    printed = {
        "M11": by_rate[qdd1],
        "M12": by_rate[qdd2],
        "C1": by_rate[qd1 * qd2],
        "C2": by_rate[qd2**2],
        "g1": by_rate[1],
    }
    printed["M11"] = dict(elements(dyn, "M"))["M11"]
    for name, groups in book.items():
        expr = printed[name]
        outer = {}  # the printed outer factors: masses (M, C) or g (gravity), each once
        for term in sp.Add.make_args(expr):
            factor = [f for f in sp.Mul.make_args(term) if f in groups]
            assert len(factor) == 1, f"{name}: term {term} is not grouped by one of {list(groups)}"
            outer[factor[0]] = outer.get(factor[0], 0) + term / factor[0]
        assert set(outer) == set(groups), name
        for factor, inner in groups.items():
            trig = {}
            for t in sp.Add.make_args(sp.expand(outer[factor])):
                coeff, mono = t.as_independent(q1, q2)
                trig[mono] = trig.get(mono, 0) + coeff
            assert set(trig) == set(inner), f"{name}: {factor}·(…) has trig terms {set(trig)}"
            for mono, coeff in inner.items():
                assert sp.expand(trig[mono] - coeff) == 0, f"{name}: coefficient of {mono}"
        # the printed M entries keep each mass outside its bracket, as the book does
        if name in ("M11", "M12"):
            assert all(t.is_Mul and any(f in groups for f in t.args) for t in sp.Add.make_args(expr))


@pytest.mark.parametrize("form", ["book", "folded"])
def test_printed_gravity_of_the_puma_uses_the_natural_angle_q2_plus_q3(form):
    dyn = derive(models.load("puma560"))
    g2 = tidy(dyn.G[1], dyn, form)
    q2, q3, q4, q5 = dyn.q[1:5]
    assert g2.has(sp.cos(q2 + q3)) and g2.has(sp.sin(q2 + q3))
    assert not g2.has(sp.cos(q3)) and not g2.has(sp.sin(q3))
    if form == "book":  # products of natural angles, no angle sums beyond q2 + q3
        assert g2.has(sp.sin(q5) * sp.cos(q4) * sp.cos(q2 + q3))
        assert not any(len(a.args[0].args) > 2 for a in g2.atoms(sp.sin, sp.cos))
    else:
        assert g2.has(sp.sin(q2 + q3 + q4 + q5))


@pytest.mark.parametrize("name", ["puma560", "rrp"])
def test_book_form_is_exactly_the_derived_expression(name):
    from symdyn.derivation import trigpoly
    from symdyn.derivation.simplify import book_form

    dyn = derive(models.load(name))
    angles = [q for q, link in zip(dyn.q, dyn.robot.links) if link.is_revolute]
    for e in list(dyn.M) + list(dyn.G):
        assert trigpoly.equal(book_form(e, dyn), e, angles)


def test_parallel_joints_give_the_natural_angles():
    from symdyn.derivation.simplify import parallel_chains

    assert parallel_chains(models.load("puma560")) == [(1, 2)]
    assert parallel_chains(models.load("twolink")) == [(0, 1)]
    assert parallel_chains(models.load("rrp")) == []


def test_pruning_reports_its_worst_error_and_saves_operations():
    dyn = derive(models.load("puma560"))
    pruned, report = prune(dyn, "G", 1e-2, samples=500)
    assert report.dropped > 0 and report.kept > 0
    before = report.ops_before["mul"] + report.ops_before["add"]
    after = report.ops_after["mul"] + report.ops_after["add"]
    assert after < before
    # the reported worst error is what the pruned form actually does on fresh states
    f_full = sp.lambdify(dyn.q, dyn.G, "numpy")
    f_pruned = sp.lambdify(dyn.q, pruned, "numpy")
    rng = np.random.default_rng(1)
    lo, hi = dyn.robot.qlim.T
    worst, scale = 0.0, np.zeros(dyn.n)
    for q in rng.uniform(lo, hi, (300, dyn.n)):
        a, b = np.array(f_full(*q), float).ravel(), np.array(f_pruned(*q), float).ravel()
        worst = max(worst, float(np.abs(a - b).max()))
        scale = np.maximum(scale, np.abs(a))
    assert worst <= 2 * report.worst_error * scale.max() + 1e-12
    assert report.worst_error < 0.05


@pytest.mark.parametrize("tol", [0, 1, -0.1, 2, "x"])
def test_pruning_tolerance_out_of_range_is_an_error(tol):
    dyn = derive(models.load("twolink"))
    with pytest.raises(ValueError, match="tolerance"):
        prune(dyn, "M", tol)


def test_pruning_a_symbolic_robot_is_an_error():
    with pytest.raises(ValueError, match="numeric robot"):
        prune(derive(models.load("twolink", symbolic=True)), "M", 1e-3)


def test_unknown_term_and_format_are_errors():
    dyn = derive(models.load("twolink"))
    with pytest.raises(ValueError, match="unknown term 'K'"):
        closed_form(dyn, ("K",))
    with pytest.raises(ValueError, match="unknown format 'html'"):
        render([], "html")


def test_cli_reports_an_unknown_model_clearly(capsys):
    assert cli.main(["print", "nosuch"]) == 2
    err = capsys.readouterr().err
    assert "unknown model 'nosuch'" in err and "puma560" in err


# --------------------------------------------------------------------------- 7-joint arms


@pytest.fixture(scope="module")
def panda():
    return derive(models.load("panda"))


def _printed(text: str) -> dict:
    """{name: sympy expression} of printed text lines `name = …` (continuations indented)."""
    out, name = {}, None
    for line in text.splitlines():
        if line.startswith("#"):
            continue
        if not line.startswith(" "):
            name, _, rhs = line.partition(" = ")
            out[name] = rhs
        else:
            out[name] += " " + line.strip()
    return {k: sp.sympify(v) for k, v in out.items()}


def test_pandas_printed_gravity_equals_the_reference_gravity_load(panda):
    from symdyn.numeric import reference as ref

    printed = _printed(closed_form(panda, ("G",), digits=17))
    assert sorted(printed) == [f"G{i}" for i in range(1, 8)]
    for q in np.random.default_rng(3).uniform(-2, 2, (3, 7)):
        values = {sp.Symbol(str(s)): v for s, v in zip(panda.q, q)}  # printed text: plain symbols
        got = [float(printed[f"G{i}"].xreplace(values)) for i in range(1, 8)]
        np.testing.assert_allclose(got, ref.gravload(panda.robot, q), rtol=1e-12, atol=1e-12)


def test_pandas_inertia_prints_in_named_intermediates_that_evaluate_to_the_reference(panda):
    from symdyn.presentation.printing import plan
    from symdyn.numeric import reference as ref

    layouts = plan(panda, ("G", "M"))
    assert [lay.layout for lay in layouts] == ["closed", "named"]
    assert "M of panda has 20814 terms in closed form, more than 4000" in layouts[1].note
    text = closed_form(panda, ("M",), digits=17, layouts=layouts[1:])
    assert text.startswith("# M of panda has 20814 terms")
    printed = _printed(text)
    q = np.array([0.3, -0.5, 0.2, -1.9, 0.4, 1.6, -0.7])
    values = {sp.Symbol(str(s)): v for s, v in zip(panda.q, q)}  # printed text: plain symbols
    for name, expr in printed.items():  # definitions first, each before its first use
        values[sp.Symbol(name)] = float(expr.xreplace(values))
    M = ref.inertia(panda.robot, q)
    for i in range(7):
        for j in range(i, 7):
            assert values[sp.Symbol(f"M{i + 1}{j + 1}")] == pytest.approx(M[i, j], rel=1e-12, abs=1e-12)


def test_a_closed_form_too_large_to_print_is_refused_with_the_alternative(panda):
    from symdyn.presentation.printing import plan

    with pytest.raises(
        ValueError,
        match=r"M of panda has 20814 terms in closed form, more than 4000: .* "
        r"--layout named",
    ):
        plan(panda, ("M",), "closed")


@pytest.mark.parametrize("base", tiered(["planar", "free"], 1))
def test_a_floating_base_prints_its_closed_form_exactly(base):
    """A planar base's yaw folds like a joint angle, a free base's 1/|quaternion|² is a coefficient;
    both derivations print the same closed form, and each printed element is the derived one."""
    import dataclasses

    from symdyn.derivation import trigpoly
    from symdyn.model import Link, Robot

    arm = Robot(
        name="puck",
        links=(Link(joint="revolute", a=0.3, m=1, r=(0.2, 0, 0), I=((0.01, 0, 0), (0, 0.02, 0), (0, 0, 0.03))),),
        gravity=(0, 0, 9.81),
    )
    arm = dataclasses.replace(arm, base_joint=base, base_body=Link(m=2, I=((0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.2))))
    terms = ("G",) if base == "free" else ("tau", "M")
    ne, lag = derive(arm, cache=False), derive(arm, "lagrange", cache=False)
    angles = [s for s in ne.q if s.name in ("q1", "base_yaw")]
    for term in terms:
        printed = elements(ne, term)
        assert printed == elements(lag, term)
        for (_, expr), want in zip(printed, [e for i, e in enumerate(ne.term(term)) if term != "M" or i % 4 >= i // 4]):
            if base == "planar":
                assert trigpoly.equal(sp.nsimplify(expr, rational=True), sp.nsimplify(want, rational=True), angles)
            else:
                assert sp.simplify(sp.nsimplify(expr, rational=True) - sp.nsimplify(want, rational=True)) == 0
