"""The named-constant form of M, C, G, F and τ (Armstrong, Khatib & Burdick 1986).

A reader's closed form, built after derive and simplify: every element is a
short sum of named constants times trig abbreviations (C2 = cos q2,
S23 = sin(q2 + q3), sums of parallel-axis angles folded),

    M11 = I1 + I2·C2² + 2·I5·C2·S23 + …,    G2 = g1·C2 + g2·S23 + …,

and each constant is listed once with its definition in link parameters,
its value and its units.  τ = M q̈ + Σ b_ijk q̇_j q̇_k + Σ c_ij q̇_j² + G + F,
with the Coriolis (b, j < k) and centripetal (c) coefficients of Armstrong
et al. rather than the Christoffel matrix.

Where the constants come from: for a numeric arm, τ = Y·β with the base
parameters β (`derivation.regressor.base_parameters`, Khalil's regrouping), so every
coefficient is a linear combination of the base parameters and its
definition is exact in Khalil's standard link parameters (XXj … MZj, Mj,
IAj in modified-DH link frames); base parameters whose value is zero for
the arm are left out (the form is exact for the arm, not for every arm of
its geometry).  For a symbolic arm (the two-link arm in a1, c1, m1, …) the
coefficients are polynomials in the arm's own symbols.  Coefficients that
are small multiples of one another (2·I5) share one name.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import sympy as sp

from ..derivation.dynamics import Dynamics
from ..derivation.program import make_program
from ..derivation.regressor import FRICTION, INERTIAL, base_parameters, regressor
from ..derivation.simplify import angle_products, closed_size, group_parameters, natural_chains
from ..derivation.symbols import joint_symbols
from ..derivation.trigpoly import TrigSpace
from .printing import (
    CLOSED_LIMIT,
    DIGITS,
    FOLD_BUDGET,
    _display,
    latex_document,
    latex_name,
    latex_number,
    number,
    wrap,
)

__all__ = ["Constant", "ConstantForm", "constant_form"]

#: A coefficient that is this simple a multiple of a named constant reuses its name.
_MAX_NUMERATOR, _MAX_DENOMINATOR = 8, 4


@dataclass(frozen=True)
class Constant:
    """One named constant: its symbol (I3, g2, FV1), its definition in link
    parameters, its exact value (None for a symbolic arm) and its units."""

    symbol: sp.Symbol
    definition: sp.Expr
    value: sp.Expr | None
    units: str


@dataclass(frozen=True)
class ConstantForm:
    """M (upper triangle), b, c, G, F and τ of one arm in named constants.

    elements: ((name, kind, terms), …) with kind "M", "b", "c", "G", "F" and
    terms (in print order: by constant) in the constants' symbols and the
    abbreviations; tau: ((name, terms), …) in the element names;
    abbreviations: ((Symbol, sin/cos expr), …).
    """

    dyn: Dynamics
    constants: tuple
    abbreviations: tuple
    elements: tuple
    tau: tuple

    def expand(self, expr: sp.Expr) -> sp.Expr:
        """expr with abbreviations and element names replaced by what they stand
        for, and the constants by their values (numeric arm) or definitions."""
        values = {c.symbol: c.definition if c.value is None else c.value for c in self.constants}
        values.update(dict(self.abbreviations))
        elements = {sp.Symbol(name): sp.Add(*e) for name, _, e in self.elements}
        return sp.sympify(expr).xreplace(elements).xreplace(values)

    def matrix(self, kind: str) -> sp.ImmutableMatrix:
        """The named-constant M (n×n, symmetric), G, F or Cqd = Σ b q̇q̇ + Σ c q̇² (n)."""
        n, (_, qd, _) = self.dyn.n, joint_symbols(self.dyn.n)
        by = {name: sp.Add(*e) for name, _, e in self.elements}
        if kind == "M":
            return sp.ImmutableMatrix(n, n, lambda i, j: by.get(f"M{min(i, j) + 1}{max(i, j) + 1}", 0))
        if kind in ("G", "F"):
            return sp.ImmutableMatrix([by.get(f"{kind}{i + 1}", 0) for i in range(n)])
        if kind == "Cqd":
            return sp.ImmutableMatrix(
                [
                    sp.Add(
                        *(
                            sp.Add(*e) * _rate(name, qd)
                            for name, k, e in self.elements
                            if k in "bc" and name[1:].split("_")[0] == str(i + 1)
                        )
                    )
                    for i in range(n)
                ]
            )
        raise ValueError(f"unknown kind {kind!r}: expected M, Cqd, G or F")

    def term_count(self, kind: str) -> int:
        """Constant × abbreviation terms of one kind: "M", "b", "c", "G", "F"."""
        return sum(len(e) for _, k, e in self.elements if k == kind)

    def op_count(self, kind: str) -> dict:
        """Operations of evaluating this form of "M", "Cqd", "G" or "tau": the
        constants as numbers, one joint CSE (`make_program`), sin/cos calls as
        "fun"; τ from the element formulas through M q̈ + Cqd + G + F."""
        dyn = self.dyn
        if kind == "tau":
            M, Cqd, G, F = (self._evaluated(k) for k in ("M", "Cqd", "G", "F"))
            outputs = [("tau", sp.Matrix(M * sp.Matrix(dyn.qdd) + Cqd + G + F))]
        else:
            outputs = [(kind, self._evaluated(kind))]
        return make_program(kind, dyn.inputs("tau") if kind in ("tau", "Cqd") else dyn.inputs(kind), outputs).op_count()

    def _evaluated(self, kind: str) -> sp.Matrix:
        values = {c.symbol: c.value if c.value is not None else c.definition for c in self.constants}
        values.update(dict(self.abbreviations))
        return sp.Matrix(self.matrix(kind).xreplace(values))


def _rate(name: str, qd) -> sp.Expr:
    """b1_23 → qd2·qd3, c1_2 → qd2²."""
    index = name.split("_")[1]
    joints = [int(x) - 1 for x in (index if len(qd) < 10 else index.split(","))]
    return qd[joints[0]] ** 2 if name[0] == "c" else qd[joints[0]] * qd[joints[1]]


# --------------------------------------------------------------------------- torques in parameters


def _torques(dyn: Dynamics):
    """(space, τ without friction as TrigPolys, parameter symbols, their
    definitions and values): through the base parameters for a numeric arm,
    the derived τ for a symbolic one."""
    robot = dyn.robot
    q, qd, qdd = dyn.q, dyn.qd, dyn.qdd
    angles = [x for x, link in zip(q, robot.links) if link.is_revolute]
    prismatic = [x for x, link in zip(q, robot.links) if not link.is_revolute]
    motion = prismatic + list(qd) + list(qdd)
    if robot.is_symbolic:
        params = sorted(robot.free_symbols, key=str)
        space = TrigSpace(angles, params + motion)
        bias = dyn.M * sp.Matrix(qdd) + dyn.Cqd + dyn.G
        memo: dict = {}
        return space, [space.from_expr(e, memo) for e in bias], params, {p: (p, None) for p in params}
    reg = regressor(robot)
    base = base_parameters(robot)
    per = len(INERTIAL) + len(FRICTION)
    kept = [
        (k, e, v)
        for k, e, v in zip(base.independent, base.expressions, base.values)
        if k % per < len(INERTIAL) and v != 0
    ]
    symbols = [
        sp.Symbol(f"{reg.params[k]}R" if e != reg.params[k] else str(reg.params[k]), real=True) for k, e, _ in kept
    ]
    space = TrigSpace(angles, symbols + motion)
    memo = {}
    for s, e in reg.tape.defs.items():
        memo[s] = space.from_expr(e, memo)
    torques = []
    for i in range(robot.n):
        terms = [space.from_expr(reg.columns[k][i], memo) * space.gen(b) for (k, _, _), b in zip(kept, symbols)]
        torques.append(sum(terms, space.zero))
    info = {b: (e, v) for b, (_, e, v) in zip(symbols, kept)}
    return space, torques, symbols, info


# --------------------------------------------------------------------------- units

_KG_M_S = {"revolute": (1, 2, -2), "prismatic": (1, 1, -2)}


def units(exps: tuple) -> str:
    """(kg, m, s) exponents as an engineer writes them: N·m, kg·m², N·s, m."""
    kg, m, s = exps
    if kg == 1 and s == -2:
        return "·".join(x for x in ("N", _power("m", m - 1)) if x)
    if kg == 1 and s == -1:
        return "·".join(x for x in ("N", _power("m", m - 1), "s") if x)
    text = "·".join(x for x in (_power("kg", kg), _power("m", m), _power("s", s)) if x)
    return text or "1"


def _power(unit: str, e: int) -> str:
    if e == 0:
        return ""
    return f"{unit}" + ("" if e == 1 else {2: "²", 3: "³", -1: "⁻¹", -2: "⁻²"}.get(e, f"^{e}"))


# --------------------------------------------------------------------------- the form


def abbreviation(atom: sp.Expr) -> sp.Symbol:
    """cos(q2 + q3) → C23, sin(q4) → S4 (indices joined by commas from joint 10 on)."""
    joints = [int(s.name[1:]) for s in sorted(atom.args[0].free_symbols, key=lambda s: int(s.name[1:]))]
    sep = "," if max(joints) >= 10 else ""
    return sp.Symbol(("C" if atom.func is sp.cos else "S") + sep.join(map(str, joints)), real=True)


def constant_form(dyn: Dynamics) -> ConstantForm:
    """M, b, c, G, F and τ of `dyn`'s arm in named constants and trig abbreviations (module docstring).

    Refused (ValueError) for an arm whose τ has more than `printing.CLOSED_LIMIT`
    terms as a trig polynomial (every 7-joint arm shipped): its form would
    run to thousands of constants and take minutes; the check takes a second.  A floating
    base is refused (NotImplementedError): its parameters are not laid out per link."""
    dyn.robot.require_fixed_base("named constants")
    size = closed_size(dyn, "tau", FOLD_BUDGET)
    if size is None or size > CLOSED_LIMIT:
        how_big = f"more than {FOLD_BUDGET} terms in its intermediates" if size is None else f"{size} terms"
        raise ValueError(
            f"the named-constant form of {dyn.robot.name} is not offered: its tau has {how_big} "
            f"(the form is made for arms up to {CLOSED_LIMIT}); print "
            f"`symdyn print {dyn.robot.name} --term G` (closed form) or `symdyn print "
            f"{dyn.robot.name}` (named intermediates where a term is larger)"
        )
    robot, n = dyn.robot, dyn.n
    space, torques, params, info = _torques(dyn)
    q, qd, qdd = dyn.q, dyn.qd, dyn.qdd
    angles = tuple(x for x, link in zip(q, robot.links) if link.is_revolute)
    prismatic = [x for x, link in zip(q, robot.links) if not link.is_revolute]
    chains = natural_chains(dyn)
    P = len(params)
    masses = tuple(link.m for link in robot.links if isinstance(link.m, sp.Symbol))
    kinds = ["revolute" if link.is_revolute else "prismatic" for link in robot.links]

    # acc[element][abbreviated monomial] = {parameter exponents: coefficient}
    acc: dict = {}
    meta: dict = {}
    for i, tau in enumerate(torques):
        for k, kind, coeff in tau.items():
            products = sp.expand(angle_products(tuple(k), kind, chains, angles))
            for exps, c in coeff.items():
                name, rates, rest = _element(i, exps[P:], n, len(prismatic))
                if name is None:
                    continue
                meta[name] = (i, rates)
                pmono = sp.Mul(*(x**e for x, e in zip(prismatic, rest)))
                for term in sp.Add.make_args(products):
                    num, mono = term.as_coeff_Mul()
                    slot = acc.setdefault(name, {}).setdefault(mono * pmono, {})
                    key = exps[:P]
                    slot[key] = slot.get(key, 0) + Fraction(int(c.numerator), int(c.denominator)) * Fraction(
                        int(num.p), int(num.q)
                    )

    abbreviations: dict = {}
    named: dict = {}  # (units, normalized coefficient) -> [(scale, Constant)]
    constants: list = []
    counters = {"I": 0, "g": 0}
    elements = []
    for name in sorted(acc, key=_element_order):
        kind = name[0]
        terms = []
        for mono in sorted(acc[name], key=sp.default_sort_key):
            coeff = {e: c for e, c in acc[name][mono].items() if c}
            if not coeff:
                continue
            unit = _units(*meta[name], tuple(sp.degree(mono, x) for x in prismatic), kinds)
            factor, const = _name(
                coeff, unit, params, info, named, constants, counters, "g" if kind == "G" else "I", masses
            )
            if factor is None:
                continue
            for atom in mono.atoms(sp.sin, sp.cos):
                abbreviations.setdefault(abbreviation(atom), atom)
            abbr = mono.xreplace({a: abbreviation(a) for a in mono.atoms(sp.sin, sp.cos)})
            terms.append((constants.index(const), sp.default_sort_key(abbr), factor * const.symbol * abbr))
        elements.append((name, kind, tuple(t for *_, t in sorted(terms, key=lambda t: t[:2]))))
    elements += _friction(dyn, constants)
    tau = []
    for i in range(n):
        parts = [sp.Symbol(f"M{min(i, j) + 1}{max(i, j) + 1}") * qdd[j] for j in range(n)]
        parts += [
            sp.Symbol(nm) * _rate(nm, qd) for nm, k, _ in elements if k in "bc" and nm[1:].split("_")[0] == str(i + 1)
        ]
        parts += [sp.Symbol(f"{k}{i + 1}") for k in ("G", "F") if any(nm == f"{k}{i + 1}" for nm, _, _ in elements)]
        tau.append((f"tau{i + 1}", tuple(parts)))
    order = sorted(abbreviations, key=lambda s: (s.name[0] == "S", len(s.name), s.name))
    return ConstantForm(
        dyn=dyn,
        constants=tuple(constants),
        abbreviations=tuple((s, abbreviations[s]) for s in order),
        elements=tuple((nm, k, e) for nm, k, e in elements),
        tau=tuple(tau),
    )


def _element(i: int, motion: tuple, n: int, n_prismatic: int) -> tuple[str, tuple, tuple]:
    """Which element of τ_i a monomial of the motion generators belongs to
    (M_ij for q̈_j, b_ijk for q̇_j q̇_k, c_ij for q̇_j², G_i): its name (None
    below M's diagonal), its rate factors as (joint, derivative order), its
    prismatic exponents."""
    pris, rates, accs = motion[:n_prismatic], motion[n_prismatic : n_prismatic + n], motion[n_prismatic + n :]
    sep = "," if n >= 10 else ""
    if any(accs):
        j = accs.index(1)
        if j < i:  # M is symmetric: its upper triangle comes from τ_i, q̈_j with j ≥ i
            return None, (), pris
        return f"M{min(i, j) + 1}{sep}{max(i, j) + 1}", ((j, 2),), pris
    if any(rates):
        js = tuple(j for j, e in enumerate(rates) for _ in range(e))
        factors = ((js[0], 1), (js[1], 1))
        if js[0] == js[1]:
            return f"c{i + 1}_{js[0] + 1}", factors, pris
        return f"b{i + 1}_{js[0] + 1}{sep}{js[1] + 1}", factors, pris
    return f"G{i + 1}", (), pris


def _element_order(name: str) -> tuple:
    return ("MbcGF".index(name[0]), len(name), name)


def _units(i: int, rates: tuple, pris: tuple, kinds: list) -> str:
    """Units of a constant in τ_i: those of τ_i over the rate factors
    ((joint, derivative order), …) and prismatic joint values it multiplies."""
    kg, m, s = _KG_M_S[kinds[i]]
    s += sum(order for _, order in rates)
    m -= sum(kinds[j] == "prismatic" for j, _ in rates) + sum(pris)
    return units((kg, m, s))


def _name(
    coeff: dict,
    unit: str,
    params: list,
    info: dict,
    named: dict,
    constants: list,
    counters: dict,
    stem: str,
    masses: tuple,
):
    """(factor, Constant) with coefficient = factor·constant: an existing constant
    when the coefficient is a simple multiple of one, else a new one.  (None, None)
    when the coefficient's value is zero for this arm."""
    keys = sorted(coeff, reverse=True)
    lead = coeff[keys[0]]
    normal = tuple((e, coeff[e] / lead) for e in keys)
    expr = sp.Add(
        *(
            sp.Rational(c.numerator, c.denominator) * sp.Mul(*(p**x for p, x in zip(params, e)))
            for e, c in coeff.items()
        )
    )
    numeric = all(v is not None for _, v in info.values())
    value = sp.expand(expr.xreplace({p: v for p, (_, v) in info.items()})) if numeric else None
    if numeric and value == 0:
        return None, None
    sign = -1 if (value is not None and value < 0) or (value is None and lead < 0) else 1
    for scale, const in named.get((unit, normal), ()):
        ratio = lead / scale
        if abs(ratio.numerator) <= _MAX_NUMERATOR and ratio.denominator <= _MAX_DENOMINATOR:
            return sp.Rational(ratio.numerator, ratio.denominator), const
    counters[stem] += 1
    definition = sp.expand(expr.xreplace({p: d for p, (d, _) in info.items()}))
    if not numeric:
        definition = group_parameters(sign * definition, set(params), masses)
    else:
        definition = sign * definition
    const = Constant(
        sp.Symbol(f"{stem}{counters[stem]}", real=True), definition, None if value is None else sign * value, unit
    )
    named.setdefault((unit, normal), []).append((lead * sign, const))
    constants.append(const)
    return sp.Integer(sign), const


def _friction(dyn: Dynamics, constants: list) -> list:
    """F_i in named constants FVi, FSi, FOi (numeric arms: their values; symbolic: the derived F_i)."""
    out = []
    if dyn.robot.is_symbolic:
        return [(f"F{i + 1}", "F", (f,)) for i, f in enumerate(dyn.F) if f != 0]
    for i, f in enumerate(dyn.F):
        s = sp.sign(dyn.qd[i])
        expanded = sp.expand(f)
        coeffs = {"FV": expanded.coeff(dyn.qd[i]), "FS": expanded.coeff(s, 1), "FO": expanded.coeff(s, 2)}
        unit = {"FV": "N·m·s" if dyn.robot.links[i].is_revolute else "N·s/m", "FS": "N·m", "FO": "N·m"}
        terms = []
        for stem, basis in (("FV", dyn.qd[i]), ("FS", s), ("FO", s**2)):
            v = coeffs[stem]
            if v == 0:
                continue
            u = unit[stem] if dyn.robot.links[i].is_revolute or stem == "FV" else "N"
            const = Constant(sp.Symbol(f"{stem}{i + 1}", real=True), sp.Symbol(f"{stem}{i + 1}", real=True), v, u)
            constants.append(const)
            terms.append(const.symbol * basis)
        if terms:
            out.append((f"F{i + 1}", "F", tuple(terms)))
    return out


# --------------------------------------------------------------------------- printing


def _param_key(term: sp.Expr) -> tuple:
    """Order of a definition's terms: link by link, Khalil's parameter order within a link."""
    syms = sorted(term.free_symbols, key=str)
    if len(syms) != 1:
        return (0, 0, str(term))
    stem = syms[0].name.rstrip("0123456789")
    index = syms[0].name[len(stem) :]
    order = (INERTIAL + FRICTION).index(stem) if stem in INERTIAL + FRICTION else len(INERTIAL + FRICTION)
    return (int(index) if index.isdigit() else 0, order, syms[0].name)


def render_form(form: ConstantForm, fmt: str = "text", *, digits: int = DIGITS) -> str:
    """The named-constant form as text, pretty or a LaTeX document: the table of
    constants (value and units, then the definition), the abbreviations, then
    M, b, c, G, F and τ, every line within the format's width."""
    robot = form.dyn.robot
    numeric = not robot.is_symbolic
    comment = "%" if fmt == "latex" else "#"
    sections = []
    rows = []
    for c in form.constants:
        if numeric:
            definition = sorted(sp.Add.make_args(c.definition), key=_param_key)
            value = _display(c.value)
            lhs = (
                f"{c.symbol} = {number(float(value), digits)} {c.units} = "
                if fmt != "latex"
                else f"{latex_name(str(c.symbol))} &= {latex_number(float(value), digits)}\\,"
                f"\\mathrm{{{_latex_units(c.units)}}} = "
            )
        else:
            definition = c.definition
            lhs = (
                f"{c.symbol} [{c.units}] = "
                if fmt != "latex"
                else f"{latex_name(str(c.symbol))}\\;[\\mathrm{{{_latex_units(c.units)}}}] &= "
            )
        rows.append((str(c.symbol), definition, lhs))
    sections.append(("Named constants", rows))
    sections.append(("Abbreviations", [(str(s), e, None) for s, e in form.abbreviations]))
    sections.append(
        (
            "Inertia M (upper triangle), Coriolis b, centripetal c, gravity G, friction F",
            [(name, list(terms), None) for name, _, terms in form.elements],
        )
    )
    sections.append(("Joint torques", [(name, list(terms), None) for name, terms in form.tau]))
    source = (
        "definitions in Khalil's standard link parameters (modified-DH link frames); "
        "base parameters that are zero for this arm are left out"
        if numeric
        else "definitions in the arm's symbols"
    )
    head = [f"{comment} {robot.name}: closed form in named constants (Armstrong, Khatib & Burdick 1986); {source}"]
    if fmt == "latex":
        body = []
        for title, rows in sections:
            body.append(f"\\section*{{{title}}}")
            lines = [
                line
                for name, e, lhs in rows
                for line in [" \\\\\n".join(wrap(name, _display_terms(e), fmt, digits=digits, lhs=lhs))]
            ]
            body.append("\\begin{align*}\n" + " \\\\\n".join(lines) + "\n\\end{align*}")
        return "\n".join(head) + "\n" + latex_document("\n".join(body))
    out = list(head)
    for title, rows in sections:
        out.append(f"{comment} {title}")
        joiner = "\n\n" if fmt == "pretty" else "\n"
        out.append(
            joiner.join("\n".join(wrap(name, _display_terms(e), fmt, digits=digits, lhs=lhs)) for name, e, lhs in rows)
        )
    return "\n".join(out)


def _display_terms(e):
    return [_display(t) for t in e] if isinstance(e, (list, tuple)) else _display(e)


def _latex_units(text: str) -> str:
    """N·m·s → N\\,m\\,s, kg·m² → kg\\,m^{2}."""
    for sup, tex in (("²", "^{2}"), ("³", "^{3}"), ("⁻¹", "^{-1}"), ("⁻²", "^{-2}")):
        text = text.replace(sup, tex)
    return text.replace("·", "\\,")
