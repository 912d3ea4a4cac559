"""Closed forms for people: named elements (M11, C23, G1, …) as text, pretty or LaTeX.

The last step for the reader: each element is rewritten (book form: S23·C4·S5
products of natural angles; or folded: sin(q2 + q3 + q5) sums) and collected by
`symdyn.derivation.simplify.tidy`; numeric coefficients are shown to `digits`
significant figures (the exact values stay in the derivation).
"""

from __future__ import annotations

import sympy as sp

from .dynamics import TERMS, Dynamics
from .simplify import prune, tidy

FORMATS = ("text", "pretty", "latex")


def _display(expr: sp.Expr, digits: int) -> sp.Expr:
    """Rationals shown as short decimals; integers and symbols untouched."""
    repl = {r: sp.Float(r, digits) for r in expr.atoms(sp.Rational) if not r.is_Integer}
    return expr.xreplace(repl)


def elements(dyn: Dynamics, term: str, *, prune_tol: float | None = None, digits: int = 5,
             form: str = "book") -> list:
    """[(name, expr)] for one term: M and C by (row, column), vectors by row;
    M lists its upper triangle only (it is symmetric).  form: "book" (products
    of sines and cosines of natural angles) or "folded" (sums of angles)."""
    mat = dyn.term(term)
    if prune_tol is not None:
        mat, _ = prune(dyn, term, prune_tol)
    out = []
    for i in range(mat.rows):
        for j in range(mat.cols):
            if term == "M" and j < i:
                continue
            name = f"{term}{i + 1}{j + 1}" if mat.cols > 1 else f"{term}{i + 1}"
            out.append((name, _display(tidy(mat[i, j], dyn, form), digits)))
    return out


def _latex_name(name: str) -> str:
    stem = name.rstrip("0123456789")
    index = name[len(stem):]
    stem = {"tau": r"\tau", "Cqd": r"(C\dot q)"}.get(stem, stem)
    return f"{stem}_{{{index}}}"


def render(items: list, fmt: str = "text") -> str:
    """The elements as text lines, pretty-printed blocks or LaTeX equations."""
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}: expected one of {', '.join(FORMATS)}")
    if fmt == "text":
        return "\n".join(f"{name} = {sp.sstr(e)}" for name, e in items)
    if fmt == "pretty":
        return "\n\n".join(f"{name} =\n{sp.pretty(e, use_unicode=True, wrap_line=False)}" for name, e in items)
    body = "\n".join(
        f"\\begin{{multline*}}\n{_latex_name(name)} = {sp.latex(e, symbol_names=_latex_symbols(e))}\n\\end{{multline*}}"
        for name, e in items)
    return ("\\documentclass{article}\n\\usepackage{amsmath}\n\\allowdisplaybreaks\n"
            "\\begin{document}\n\\small\n" + body + "\n\\end{document}\n")


def _latex_symbols(expr: sp.Expr) -> dict:
    """qd2 → \\dot{q}_{2}, qdd2 → \\ddot{q}_{2}."""
    names = {}
    for s in expr.free_symbols:
        for stem, tex in (("qdd", r"\ddot{q}"), ("qd", r"\dot{q}")):
            if s.name.startswith(stem) and s.name[len(stem):].isdigit():
                names[s] = f"{tex}_{{{s.name[len(stem):]}}}"
                break
    return names


def closed_form(dyn: Dynamics, terms=("M", "C", "G", "F", "tau"), fmt: str = "text",
                prune_tol: float | None = None, form: str = "book") -> str:
    """Every requested term of `dyn`, rendered."""
    for t in terms:
        if t not in TERMS:
            raise ValueError(f"unknown term {t!r}: expected one of {', '.join(TERMS)} or all")
    items = [item for t in terms for item in elements(dyn, t, prune_tol=prune_tol, form=form)]
    return render(items, fmt)
