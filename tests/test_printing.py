"""Printed closed forms, significance pruning and the `symdyn print` command."""

import numpy as np
import pytest
import sympy as sp

from symdyn import cli, models
from symdyn.derivation.entry import derive
from symdyn.derivation.printing import closed_form, elements, render
from symdyn.derivation.simplify import prune, tidy


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
    assert "operations (mul+add) at each stage" in out


def test_latex_is_a_complete_document_with_balanced_braces():
    dyn = derive(models.load("twolink", symbolic=True))
    tex = closed_form(dyn, ("M", "tau"), "latex")
    assert tex.startswith("\\documentclass") and tex.rstrip().endswith("\\end{document}")
    assert tex.count("{") == tex.count("}")
    assert tex.count("\\begin{align*}") == tex.count("\\end{align*}") == 5
    assert "\\dot{q}_{2}" in tex and "\\ddot{q}_{1}" in tex


def test_latex_compiles_when_a_tex_engine_is_present(tmp_path):
    import shutil
    import subprocess

    engine = shutil.which("pdflatex")
    if engine is None:
        pytest.skip("pdflatex is not installed (Debian: texlive-latex-base)")
    dyn = derive(models.load("twolink", symbolic=True))
    (tmp_path / "eq.tex").write_text(closed_form(dyn, ("M", "C", "G", "tau"), "latex"))
    run = subprocess.run([engine, "-interaction=nonstopmode", "-halt-on-error", "eq.tex"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-2000:]


@pytest.mark.parametrize("form", ["book", "folded"])
def test_printed_gravity_of_the_puma_uses_the_natural_angle_q2_plus_q3(form):
    dyn = derive(models.load("puma560"))
    g2 = tidy(dyn.G[1], dyn, form)
    q2, q3, q4, q5 = dyn.q[1:5]
    assert g2.has(sp.cos(q2 + q3)) and g2.has(sp.sin(q2 + q3))
    assert not g2.has(sp.cos(q3)) and not g2.has(sp.sin(q3))
    if form == "book":   # products of natural angles, no angle sums beyond q2 + q3
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
