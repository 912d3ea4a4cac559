"""Closed forms for people: named elements (M11, C23, G1, …) as text, pretty or LaTeX.

The last step for the reader: each element is rewritten (book form: S23·C4·S5
products of natural angles; or folded: sin(q2 + q3 + q5) sums) and collected by
`symdyn.derivation.simplify.tidy`; numeric coefficients are shown to `digits`
significant figures, as an engineer writes them (0.25, 1.2e-5; the exact
values stay in the derivation).  Long right-hand sides are broken across
lines at top-level + and − (and, for a term that alone is too wide, inside
its parenthesised factor) to a width budget, the same way in every format:
LaTeX gets one `align*` row per line, so every equation fits the page.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import sympy as sp
from sympy.printing.latex import LatexPrinter
from sympy.printing.pretty.pretty import PrettyPrinter
from sympy.printing.pretty.stringpict import prettyForm, stringPict
from sympy.printing.str import StrPrinter

from ..derivation.dynamics import TERMS, Dynamics
from ..derivation.simplify import closed_size, prune, tidy, used_definitions

FORMATS = ("text", "pretty", "latex")

#: Width budget per format: characters for text and pretty; for LaTeX, the
#: estimated printed width (`latex_width`) of one line of a \small display in
#: the article class's 345 pt text width.
WIDTHS = {"text": 100, "pretty": 100, "latex": 66}
DIGITS = 5

LAYOUTS = ("auto", "closed", "named")

#: The largest term printed in closed form, in terms of its exact trig
#: polynomial (`simplify.closed_size`, M's upper triangle).  The Puma's C has
#: 1,594 and prints in seconds, the iiwa's M 2,549; the Panda's M has 20,814
#: and a 7-joint C or τ well over 10⁵: pages no one reads, minutes to write.
CLOSED_LIMIT = 4000
#: Folding a term's intermediates stops past this many terms in all: the
#: term is then known to be far over CLOSED_LIMIT, in a second or two.
FOLD_BUDGET = 25 * CLOSED_LIMIT


def number(x: float, digits: int = DIGITS) -> str:
    """x to `digits` significant figures, trailing zeros dropped: 0.25, 6.5, 1.2e-5."""
    text = f"{x:.{digits}g}"
    if "e" in text:
        mantissa, exp = text.split("e")
        text = f"{mantissa}e{int(exp)}"
    return text


def latex_number(x: float, digits: int = DIGITS) -> str:
    """`number` for LaTeX: 1.2e-5 → 1.2 \\cdot 10^{-5}."""
    text = number(x, digits)
    if "e" in text:
        mantissa, exp = text.split("e")
        return rf"{mantissa} \cdot 10^{{{exp}}}"
    return text


def _display(expr: sp.Expr) -> sp.Expr:
    """Non-integer rationals as Floats (printed to the chosen digits); integers and symbols untouched."""
    repl = {r: sp.Float(r, 17) for r in expr.atoms(sp.Rational) if not r.is_Integer}
    return expr.xreplace(repl)


class _Text(StrPrinter):
    def __init__(self, digits: int):
        super().__init__()
        self.digits = digits

    def _print_Float(self, expr):
        return number(float(expr), self.digits)


class _Latex(LatexPrinter):
    def __init__(self, digits: int):
        super().__init__()
        self.digits = digits

    def _print_Symbol(self, expr, style="plain"):
        return _latex_symbol(expr.name) or super()._print_Symbol(expr, style)

    def _print_Float(self, expr):
        return latex_number(float(expr), self.digits)

    def _print_sign(self, expr, exp=None):
        tex = rf"\operatorname{{sgn}}\left({self._print(expr.args[0])}\right)"
        return f"{tex}^{{{exp}}}" if exp else tex


class _Pretty(PrettyPrinter):
    def __init__(self, digits: int):
        super().__init__({"use_unicode": True, "wrap_line": False})
        self.digits = digits

    def _print_Float(self, expr):
        return prettyForm(number(float(expr), self.digits))


def _latex_symbol(name: str) -> str | None:
    """qd2 → \\dot{q}_{2}, qdd2 → \\ddot{q}_{2}, tau1 → \\tau_{1}; None for other names."""
    for stem, tex in (("qdd", r"\ddot{q}"), ("qd", r"\dot{q}"), ("tau", r"\tau")):
        if name.startswith(stem) and name[len(stem) :].isdigit():
            return f"{tex}_{{{name[len(stem) :]}}}"
    return None


# --------------------------------------------------------------------------- line breaking


@dataclass(frozen=True)
class _Piece:
    """One unbreakable run of a right-hand side: an operator ("", "+", "-"),
    the (factor, sign) pairs that open a parenthesis before the term, as in
    "m2*(-", the term itself, and how many parentheses close after it."""

    op: str
    opens: tuple
    term: sp.Expr
    closes: int


def _terms(expr, printer) -> list:
    """The top-level terms in print order (a list or tuple is taken as given)."""
    if isinstance(expr, (list, tuple)):
        return list(expr)
    return list(printer._as_ordered_terms(expr, order=None)) if expr.is_Add else [expr]


def _pieces(expr, fmt: str, printer, budget: float) -> list[_Piece]:
    """Break points of a right-hand side: before each top-level term, and inside
    a term too wide for the budget that is a product with a sum factor."""
    out = []
    for k, term in enumerate(_terms(expr, printer)):
        op, body = ("-", -term) if term.could_extract_minus_sign() else ("+", term)
        if k == 0 and op == "+":
            op = ""
        piece = _Piece(op, (), body, 0)
        sums = [f for f in sp.Mul.make_args(body) if f.is_Add]
        if not sums or _width([piece], fmt, printer) <= budget:
            out.append(piece)
            continue
        coeff = sp.Mul(*[f for f in sp.Mul.make_args(body) if f is not sums[0]])
        parts = _pieces(sums[0], fmt, printer, budget)
        first, last = parts[0], parts[-1]
        parts[0] = _Piece(op, ((coeff, first.op),) + first.opens, first.term, first.closes)
        parts[-1] = (
            _Piece(parts[-1].op, parts[-1].opens, parts[-1].term, last.closes + 1)
            if len(parts) > 1
            else _Piece(op, parts[0].opens, parts[0].term, parts[0].closes + 1)
        )
        out += parts
    return out


def _render_piece(piece: _Piece, fmt: str, printer, lead: bool = False):
    """A piece as a string (text, LaTeX) or a prettyForm (pretty); the first
    piece of an equation (`lead`) writes its minus sign without a space."""
    op = piece.op
    if fmt == "pretty":
        parts = [prettyForm(op if lead else op + " ")] if op else []
        for factor, sign in piece.opens:
            parts += [
                printer._print(factor) if factor != 1 else prettyForm(""),
                prettyForm(("⋅(" if factor != 1 else "(") + sign),
            ]
        parts.append(printer._print(piece.term))
        parts.append(prettyForm(")" * piece.closes))
        return prettyForm(*stringPict.next(*parts))
    mul, open_, close = ("*", "(", ")") if fmt == "text" else (" ", r"\bigl(", r"\bigr)")
    text = {"": "", "-": "-"}.get(op, f"{op} ") if lead else (f"{op} " if op else "")
    for factor, sign in piece.opens:
        text += (printer.doprint(factor) + mul if factor != 1 else "") + open_ + sign
    text += printer.doprint(piece.term) + close * piece.closes
    return text


def _width(pieces: list, fmt: str, printer) -> float:
    """Printed width of pieces on one line (characters; LaTeX: `latex_width`)."""
    return sum(_piece_width(_render_piece(p, fmt, printer), fmt) for p in pieces) + len(pieces) - 1


def _piece_width(rendered, fmt: str) -> float:
    if fmt == "pretty":
        return rendered.width()
    return latex_width(rendered) if fmt == "latex" else len(rendered)


_COMMAND = re.compile(r"\\([a-zA-Z]+)")
_WORDS = {
    "cos": 3,
    "sin": 3,
    "operatorname": 0,
    "cdot": 1,
    "left": 0,
    "right": 0,
    "bigl": 0.3,
    "bigr": 0.3,
    "dot": 0,
    "ddot": 0,
    "quad": 2,
    "tau": 1,
    "pi": 1,
    "mathrm": 0,
    "colon": 0.5,
}


def latex_width(tex: str) -> float:
    """Estimated printed width of one line of math, in character units: a
    character counts 1, one in a sub- or superscript 0.7, + − = with their
    spacing 2, \\cos 3; commands that only place things (\\left, \\dot) 0."""
    width, i = 0.0, 0
    scripts: list = []  # brace depths at which open sub/superscripts end
    depth = 0
    while i < len(tex):
        ch = tex[i]
        scale = 0.7 if scripts else 1.0
        if ch == "\\":
            m = _COMMAND.match(tex, i)
            width += (_WORDS.get(m.group(1), 1) if m else 0.5) * scale
            i = m.end() if m else i + 2
            continue
        if ch in "^_" and tex[i + 1 : i + 2] == "{":
            scripts.append(depth + 1)
        elif ch in "^_":  # a one-character script
            width += 0.7
            i += 2
            continue
        elif ch == "{":
            depth += 1
        elif ch == "}":
            if scripts and scripts[-1] == depth:
                scripts.pop()
            depth -= 1
        elif ch in "+-=":
            width += 2 * scale
        elif ch != " ":
            width += scale
        i += 1
    return width


def wrap(
    name: str, expr, fmt: str = "text", *, width: float | None = None, digits: int = DIGITS, lhs: str | None = None
) -> list:
    """name = expr broken into lines of at most `width` (the format's budget by
    default): text lines, LaTeX `align*` rows (`&=` and `&\\quad` aligned), or
    pretty-printed blocks.  expr may be an ordered list of terms; `lhs`
    replaces the left-hand side "name = " (LaTeX: it must hold the `&`)."""
    printer = _printer(fmt, digits)
    width = WIDTHS[fmt] if width is None else width
    if fmt == "latex":
        head = lhs or f"{latex_name(name)} &= "
        cont = r"&\quad "
        lead = latex_width(head.split("&")[-1]) + max(latex_width(head.split("&")[0]), 2)
    else:
        head = lhs or f"{name} = "
        cont = " " * len(head)
        lead = len(head)
    budget = width - lead
    pieces = _pieces(expr, fmt, printer, budget)
    lines, current, used = [], [], 0.0
    for piece in pieces:
        w = _piece_width(_render_piece(piece, fmt, printer), fmt)
        if current and used + 1 + w > budget:
            lines.append(current)
            current, used = [], 0.0
        current.append(piece)
        used += w + (1 if len(current) > 1 else 0)
    lines.append(current)
    if fmt == "pretty":
        blocks = []
        for k, line in enumerate(lines):
            parts = [prettyForm(head if k == 0 else cont)]
            for j, piece in enumerate(line):
                if j:
                    parts.append(prettyForm(" "))
                parts.append(_render_piece(piece, fmt, printer, k == 0 and j == 0))
            blocks.append(prettyForm(*stringPict.next(*parts)).render(wrap_line=False))
        return blocks
    return [
        (head if k == 0 else cont)
        + " ".join(_render_piece(p, fmt, printer, k == 0 and j == 0) for j, p in enumerate(line))
        for k, line in enumerate(lines)
    ]


def _printer(fmt: str, digits: int):
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}: expected one of {', '.join(FORMATS)}")
    return {"text": _Text, "pretty": _Pretty, "latex": _Latex}[fmt](digits)


# --------------------------------------------------------------------------- elements and documents


def elements(dyn: Dynamics, term: str, *, prune_tol: float | None = None, form: str = "book") -> list:
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
            out.append((name, _display(tidy(mat[i, j], dyn, form))))
    return out


def latex_name(name: str) -> str:
    """M11 → M_{11}, tau2 → \\tau_{2}, b1_23 → b_{1,23}, Cqd1 → (C\\dot q)_{1}, w2_z → w_{2 z}."""
    stem = name.rstrip("0123456789_")
    index = name[len(stem) :].replace("_", ",")
    if not index:  # a derivation's intermediate: w2_z → w_{2 z}
        return sp.latex(sp.Symbol(name))
    stem = {"tau": r"\tau", "Cqd": r"(C\dot q)"}.get(stem, stem)
    return f"{stem}_{{{index}}}"


def render(
    items: list, fmt: str = "text", *, digits: int = DIGITS, width: float | None = None, document: bool = True
) -> str:
    """The elements [(name, expr or ordered terms)] as wrapped text lines,
    pretty-printed blocks or LaTeX `align*` rows (a complete document unless
    document=False)."""
    _printer(fmt, digits)
    blocks = [wrap(name, e, fmt, width=width, digits=digits) for name, e in items]
    if fmt == "text":
        return "\n".join(line for b in blocks for line in b)
    if fmt == "pretty":
        return "\n\n".join("\n".join(b) for b in blocks)
    body = "\n".join("\\begin{align*}\n" + " \\\\\n".join(b) + "\n\\end{align*}" for b in blocks)
    return latex_document(body) if document else body


def latex_document(body: str) -> str:
    """A complete article around display math (amsmath; long pages break between displays)."""
    return (
        "\\documentclass{article}\n\\usepackage{amsmath}\n\\allowdisplaybreaks\n"
        "\\begin{document}\n\\small\n" + body + "\n\\end{document}\n"
    )


@dataclass(frozen=True)
class Layout:
    """How one term is printed: "closed" (every element as a closed form) or
    "named" (the derivation's named intermediates, then the elements in
    them), and, where the size decided it, why (a line for the reader)."""

    term: str
    layout: str
    note: str = ""


def plan(dyn: Dynamics, terms, layout: str = "auto", *, limit: int = CLOSED_LIMIT) -> list[Layout]:
    """The layout of each term.  "auto": closed form up to `limit` terms of
    its trig polynomial (`simplify.closed_size`), named intermediates beyond;
    "named": named for every term; "closed": closed for every term, refused
    (ValueError naming the size and the alternatives) beyond `limit`, since
    writing it would take minutes and fill pages."""
    if layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r}: expected one of {', '.join(LAYOUTS)}")
    for t in terms:
        if t not in TERMS:
            raise ValueError(f"unknown term {t!r}: expected one of {', '.join(TERMS)} or all")
    if layout == "named":
        return [Layout(t, "named") for t in terms]
    out = []
    budget = max(FOLD_BUDGET, 25 * limit)
    for t in terms:
        size = closed_size(dyn, t, budget)
        if size is not None and size <= limit:
            out.append(Layout(t, "closed"))
            continue
        how_big = (
            f"more than {limit} terms in closed form (its intermediates alone hold more than {budget})"
            if size is None
            else f"{size} terms in closed form, more than {limit}"
        )
        if layout == "closed":
            raise ValueError(
                f"{t} of {dyn.robot.name} has {how_big}: writing it would take minutes and fill "
                f"pages; print it with --layout named (the {dyn.method} derivation's named "
                f"intermediates) or choose a smaller term"
            )
        out.append(
            Layout(
                t,
                "named",
                f"{t} of {dyn.robot.name} has {how_big}: printed in the {dyn.method} "
                f"derivation's named intermediates, each defined once before its first use",
            )
        )
    return out


def named_items(dyn: Dynamics, terms) -> list:
    """[(name, expr)] of the named layout: the definitions the terms use, in
    derivation order and each once, then the terms' elements written in them
    (M's upper triangle).  A derivation without named intermediates gives
    its plain elements."""
    mats = {t: dyn.named[t] if t in dyn.named else dyn.term(t) for t in terms}
    items = [(str(sym), _display(d)) for sym, d in used_definitions(dyn, [e for m in mats.values() for e in m])]
    for t, mat in mats.items():
        for i in range(mat.rows):
            for j in range(mat.cols):
                if not (t == "M" and j < i):
                    items.append((f"{t}{i + 1}{j + 1}" if mat.cols > 1 else f"{t}{i + 1}", _display(mat[i, j])))
    return items


def closed_form(
    dyn: Dynamics,
    terms=("M", "C", "G", "F", "tau"),
    fmt: str = "text",
    prune_tol: float | None = None,
    form: str = "book",
    *,
    digits: int = DIGITS,
    layouts: list[Layout] | None = None,
) -> str:
    """Every requested term of `dyn`, rendered and wrapped: in closed form, or
    in named intermediates where `layouts` (default: `plan(dyn, terms)`) says
    so, after a comment saying why."""
    layouts = plan(dyn, terms) if layouts is None else layouts
    items = [
        item
        for lay in layouts
        if lay.layout == "closed"
        for item in elements(dyn, lay.term, prune_tol=prune_tol, form=form)
    ]
    named = [lay.term for lay in layouts if lay.layout == "named"]
    if named:
        items += named_items(dyn, named)
    mark = "%" if fmt == "latex" else "#"
    lines = [lay.note for lay in layouts if lay.note]
    if named and prune_tol is not None:
        lines.append(f"{', '.join(named)} not pruned: pruning applies to closed forms")
    head = "".join(f"{mark} {line}\n" for line in lines)
    return head + render(items, fmt, digits=digits)
