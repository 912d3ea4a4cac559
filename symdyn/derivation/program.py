"""Straight-line programs: the one representation every emitter prints.

Stage "program" of model → derive → simplify → program → emit.  A `Program`
is a function's named inputs, its assignments after ONE joint common-
subexpression elimination over all its outputs (and the derivation's own
named intermediates), and its outputs.  `lower` walks one expression into
the primitive operations an emitter performs (add, sub, mul, div, neg,
function calls); the op count is that same walk, so the count is exactly
what the emitted code does.  Exact rationals stay exact until `lower`
turns them into doubles.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Protocol, Sequence

import sympy as sp

from . import engine

__all__ = [
    "Program",
    "make_program",
    "make_programs",
    "evaluation_order",
    "lower",
    "Algebra",
    "OpCounter",
    "format_ops",
    "FUNCTIONS",
]

#: sympy function → emitted primitive name (each counted as one "fun").
FUNCTIONS = {sp.sin: "sin", sp.cos: "cos", sp.tan: "tan", sp.sign: "sign", sp.Abs: "abs"}

#: Largest integer power written as repeated multiplication (x**5 and up call pow).
MAX_UNROLLED_POWER = 4

# Names an intermediate must never take: they are taken in some emitted file.
_RESERVED = {
    "np",
    "out",
    "shape",
    "n",
    "k",
    "const",
    "double",
    "int",
    "float",
    "return",
    "void",
    "sin",
    "cos",
    "tan",
    "sqrt",
    "pow",
    "fabs",
    "sign",
    "abs",
    "math",
    "static",
    "inline",
    "restrict",
    "signed",
    "unsigned",
    "char",
    "long",
    "short",
    "auto",
    "register",
    "for",
    "if",
    "else",
    "while",
    "do",
    "case",
    "switch",
    "default",
    "break",
    "continue",
    "goto",
    "struct",
    "union",
    "enum",
    "typedef",
    "sizeof",
    "volatile",
    "extern",
}


class Algebra(Protocol):
    """The primitive operations an emitter provides; `lower` calls only these."""

    def number(self, value: float): ...
    def symbol(self, name: str): ...
    def neg(self, x): ...
    def add(self, x, y): ...
    def sub(self, x, y): ...
    def mul(self, x, y): ...
    def div(self, x, y): ...
    def call(self, name: str, x): ...
    def pow(self, x, exponent: float): ...


def lower(expr: sp.Expr, alg: Algebra):
    """Evaluate `expr` in the algebra `alg`, one primitive per operation.

    Rules (and so the op count): a sum of k terms is k−1 add/sub (a − b is
    one op, the minus is folded); a negation by itself is one neg; a product
    is one mul per extra factor, a numeric coefficient ±1 is free and any
    other one is a factor; negative powers go to one division; x², x³, x⁴
    are 1, 2, 3 muls; sqrt, sin, cos, sign, |x| and other powers are one
    function call each.  Numbers become doubles here and only here.
    """
    if expr.is_Symbol:
        return alg.symbol(expr.name)
    if expr.is_number:
        return alg.number(float(expr))
    if expr.is_Add:
        terms = list(expr.args)
        first = next((t for t in terms if not _is_negative(t)), None)
        if first is None:
            acc = alg.neg(lower(-terms[0], alg))
            terms = terms[1:]
        else:
            acc = lower(first, alg)
            terms.remove(first)
        for t in terms:
            acc = alg.sub(acc, lower(-t, alg)) if _is_negative(t) else alg.add(acc, lower(t, alg))
        return acc
    if expr.is_Mul or expr.is_Pow:
        return _lower_product(expr, alg)
    name = FUNCTIONS.get(expr.func)
    if name is not None and len(expr.args) == 1:
        return alg.call(name, lower(expr.args[0], alg))
    raise ValueError(f"cannot emit {expr.func.__name__}: {str(expr)[:80]}")


def _is_negative(term: sp.Expr) -> bool:
    """Whether term's numeric coefficient is negative (`as_coeff_Mul()[0]`, without building
    the rest of the product: a program's op count asks this of every term)."""
    coeff = term if term.is_Number else term.args[0] if term.is_Mul and term.args[0].is_Number else None
    return coeff is not None and _below_zero(coeff)


def _below_zero(number: sp.Number) -> bool:
    """number < 0, read off its value (sympy's assumption system would deduce every fact of
    each new number first: a third of a program's op count)."""
    return number.p < 0 if number.is_Rational else float(number) < 0


def _lower_product(expr: sp.Expr, alg: Algebra):
    coeff, factors = expr.as_coeff_mul()
    num, den = [], []
    for f in factors:
        base, e = f.as_base_exp()
        if e.is_Integer and e.p < 0:
            den.append(_power(base, -int(e), alg))
        elif e.is_Rational and e.q == 2 and e.p < 0:
            den.append(_power(sp.sqrt(base), -int(2 * e), alg))
        else:
            num.append(_power(base, e, alg))
    negative = coeff.p < 0  # as_coeff_mul's coefficient is rational
    if abs(coeff) != 1:
        num.insert(0, alg.number(float(abs(coeff))))
    acc = num[0] if num else None
    for f in num[1:]:
        acc = alg.mul(acc, f)
    if den:
        d = den[0]
        for f in den[1:]:
            d = alg.mul(d, f)
        acc = alg.div(alg.number(1.0) if acc is None else acc, d)
    return alg.neg(acc) if negative else acc


def _power(base: sp.Expr, e, alg: Algebra):
    e = sp.sympify(e)
    if e == 1:
        return lower(base, alg)
    if base.func is sp.Pow and base.exp == sp.S.Half:
        return alg.call("sqrt", lower(base.base, alg))
    if e.is_Integer and 1 < e <= MAX_UNROLLED_POWER:
        b = lower(base, alg)
        acc = b
        for _ in range(int(e) - 1):
            acc = alg.mul(acc, b)
        return acc
    if e == sp.S.Half:
        return alg.call("sqrt", lower(base, alg))
    return alg.pow(lower(base, alg), float(e))


class OpCounter:
    """The counting algebra: every primitive adds one to its category."""

    def __init__(self) -> None:
        self.counts = {"add": 0, "mul": 0, "div": 0, "neg": 0, "fun": 0}

    def number(self, value):
        return None

    def symbol(self, name):
        return None

    def _bump(self, kind, *_):
        self.counts[kind] += 1

    def neg(self, x):
        self._bump("neg")

    def add(self, x, y):
        self._bump("add")

    def sub(self, x, y):
        self._bump("add")

    def mul(self, x, y):
        self._bump("mul")

    def div(self, x, y):
        self._bump("div")

    def call(self, name, x):
        self._bump("fun")

    def pow(self, x, exponent):
        self._bump("fun")


def format_ops(counts: dict) -> str:
    """'412 mul, 303 add, 6 div, 12 fun (733 total)' — negations are free and not shown."""
    parts = [f"{counts[k]} {k}" for k in ("mul", "add", "div", "fun") if counts.get(k)]
    return f"{', '.join(parts) or 'no ops'} ({counts['total']} total)"


@dataclass(frozen=True)
class Program:
    """A straight-line function: inputs → assignments → outputs.

    inputs: ((argname, (Symbol, …)), …), each argument a flat double vector;
    assignments: ((Symbol, expr), …) in evaluation order, each expr in the
    inputs and earlier symbols; outputs: ((outname, ImmutableMatrix), …);
    `matrices` names the outputs that are matrices even with one column (M of
    a one-joint arm is 1×1, not a vector); `shapes` gives ((outname, shape), …) for outputs
    of more dimensions, their matrix's entries row-major (frame poses: 4m×4 as (m, 4, 4)).
    """

    name: str
    inputs: tuple
    assignments: tuple
    outputs: tuple
    doc: str = ""
    origin: str = ""
    matrices: frozenset = frozenset()
    shapes: tuple = ()

    def output_shapes(self) -> tuple[tuple[int, ...], ...]:
        """Shape of each output per state: (rows,) for a vector, (rows, cols) for a matrix, or
        the shape `shapes` gives it."""
        given = dict(self.shapes)
        return tuple(
            tuple(given[o]) if o in given else (m.rows, m.cols) if o in self.matrices or m.cols != 1 else (m.rows,)
            for o, m in self.outputs
        )

    def op_count(self) -> dict[str, int]:
        """Primitive operations of the emitted code ({"mul", "add", "div", "neg",
        "fun", "total"}); a − b counts one add, negation is free in "total".
        Counted once per program (a walk of every expression; headers, the
        choice of derivation and the reports all ask)."""
        if "_op_count" not in self.__dict__:
            counter = OpCounter()
            for _, expr in self.assignments:
                lower(expr, counter)
            for _, mat in self.outputs:
                for expr in mat:
                    lower(expr, counter)
            counts = dict(counter.counts)
            counts["total"] = sum(v for k, v in counts.items() if k != "neg")
            object.__setattr__(self, "_op_count", counts)  # frozen: a cache, not a field
        return dict(self.__dict__["_op_count"])

    def used_inputs(self) -> set:
        """Input symbols the program actually reads."""
        used = set()
        for _, expr in self.assignments:
            used |= expr.free_symbols
        for _, mat in self.outputs:
            used |= mat.free_symbols
        return used


# --------------------------------------------------------------------------- construction


def make_program(
    name: str,
    inputs: Sequence,
    outputs: Sequence,
    definitions: Sequence = (),
    doc: str = "",
    origin: str = "",
    matrices: Sequence[str] = (),
    shapes: Sequence = (),
) -> Program:
    """Build the program of one function by a joint CSE over all its outputs.

    inputs: [(argname, symbols)]; outputs: [(outname, Matrix)]; definitions:
    [(Symbol, expr)] intermediates already named by a derivation (kept under
    their names when used; unused ones are dropped).  New intermediates are
    named by what they are (s1 = sin(q1), c23 = cos(q2 + q3), qd1_sq) or
    x1, x2, … in evaluation order, so output is reproducible byte for byte.
    `doc` and `origin` (which derivation) are carried along for the emitters.
    """
    function = dict(name=name, inputs=inputs, outputs=outputs, doc=doc, origin=origin, matrices=matrices, shapes=shapes)
    return make_programs([function], definitions)[0]


def make_programs(functions: Sequence[dict], definitions: Sequence = (), *, choose: bool = True) -> tuple[Program, ...]:
    """The programs of several functions over the same `definitions` from ONE joint CSE over all
    their outputs, each program keeping only the assignments its own outputs need (named in its
    own evaluation order): a family of functions that share a derivation's intermediates (the
    task space's thirteen) is CSE'd once instead of once each.  `functions`: dicts of
    `make_program`'s arguments but `definitions` (name, inputs, outputs; doc, origin, matrices,
    shapes optional).  `choose`: a small input is CSE'd by sympy too under SymEngine, the
    leaner kept (`engine.cse`); False: SymEngine's alone."""
    functions = [
        dict(
            f,
            inputs=tuple((str(a), tuple(syms)) for a, syms in f["inputs"]),
            outputs=tuple((str(o), sp.ImmutableMatrix(m)) for o, m in f["outputs"]),
        )
        for f in functions
    ]
    given = dict(definitions)
    input_syms = list(dict.fromkeys(s for f in functions for _, syms in f["inputs"] for s in syms))
    flat = [e for f in functions for _, m in f["outputs"] for e in m]
    for f in functions:
        _check_free(f["name"], f["inputs"], f["outputs"], _needed(given, [e for _, m in f["outputs"] for e in m]))
    defs = _needed(given, flat)

    defs, flat = _lower_trig(defs, flat, input_syms)
    defs, trivial = _inline_trivial(_needed(defs, flat))
    flat = [e.xreplace(trivial) for e in flat] if trivial else flat
    def_syms = list(defs)
    exprs = [defs[s] for s in def_syms] + flat
    temps = sp.numbered_symbols("_cse", real=True)
    replacements, reduced = engine.cse(exprs, temps, _cse_cost if choose else None) if exprs else ([], [])
    nodes = dict(replacements)
    nodes.update(zip(def_syms, reduced[: len(def_syms)]))
    nodes, out_exprs = _drop_aliases(nodes, reduced[len(def_syms) :], set(def_syms))

    programs, at = [], 0
    for f in functions:
        size = sum(len(m) for _, m in f["outputs"])
        own, at = out_exprs[at : at + size], at + size
        programs.append(_program(f, nodes, own, def_syms))
    return tuple(programs)


def _program(f: dict, nodes: dict, out_exprs: list, def_syms: list) -> Program:
    """One function's program from the shared CSE's `nodes`: the assignments its outputs
    `out_exprs` need, in evaluation order, the new intermediates named; a CSE temporary that
    only another function shares is written where this one uses it (`_inline_single_uses`)."""
    inputs, outputs, name = f["inputs"], f["outputs"], f["name"]
    nodes, out_exprs = _inline_single_uses(nodes, out_exprs, set(def_syms))
    order = evaluation_order(nodes, out_exprs)
    taken = (
        {s.name for _, syms in inputs for s in syms}
        | {s.name for s in def_syms}
        | {a for a, _ in inputs}
        | {o for o, _ in outputs}
        | {name}
        | _RESERVED
    )
    rename = _names(order, nodes, set(def_syms), taken)
    renamed = _renamer(rename)
    assignments = tuple((rename.get(s, s), renamed(nodes[s])) for s in order)
    out_iter = iter(renamed(e) for e in out_exprs)
    out = tuple((o, sp.ImmutableMatrix(m.rows, m.cols, [next(out_iter) for _ in range(len(m))])) for o, m in outputs)
    return Program(
        name=name,
        inputs=inputs,
        assignments=assignments,
        outputs=out,
        doc=f.get("doc", ""),
        origin=f.get("origin", ""),
        matrices=frozenset(f.get("matrices", ())),
        shapes=tuple((str(o), tuple(shape)) for o, shape in f.get("shapes", ())),
    )


def _inline_single_uses(nodes: dict, out_exprs: list, named: set) -> tuple[dict, list]:
    """(nodes, outputs) of one function with each CSE temporary it uses once put back into its
    use: what its own CSE would have left in place (a group's CSE names the terms other functions
    share, and each such name held across the function costs a register: Talos' `centroidal`
    1 201 assignments and 613 live values at most, 983 and 507 by its own CSE, 30 % slower)."""
    order = evaluation_order(nodes, out_exprs)
    uses = dict.fromkeys(order, 0)
    stack = [nodes[s] for s in order] + list(out_exprs)
    while stack:  # every occurrence, a subtree used twice counted twice
        e = stack.pop()
        if e.is_Symbol:
            if e in uses:
                uses[e] += 1
        else:
            stack.extend(e.args)
    once = {s for s in order if uses[s] == 1 and s not in named}
    if not once:
        return nodes, out_exprs
    mapping: dict = {}
    for s in order:  # operands first: each inlined value already has its own operands inlined
        if s in once:
            mapping[s] = _substitute([nodes[s]], mapping)[0]
    kept = {s: e for s, e in nodes.items() if s not in once}
    done = _substitute([kept[s] for s in order if s in kept] + list(out_exprs), mapping)
    k = sum(1 for s in order if s in kept)
    return dict(zip([s for s in order if s in kept], done[:k])), done[k:]


def _renamer(mapping: dict):
    """expr ↦ expr.xreplace(mapping) for a one-to-one map of symbols to symbols no expression
    holds yet, without sympy's re-evaluation of every rebuilt sum and product: such a
    renaming leaves a canonical expression canonical but for the order of its terms and
    factors, which are sorted again as sympy sorts them (the number first, then
    `Basic.compare`); a quarter of a program's construction otherwise."""
    cache = dict(mapping)

    def renamed(e):
        hit = cache.get(e)
        if hit is None:
            args = [renamed(a) for a in e.args]
            if all(a is b for a, b in zip(args, e.args)):
                hit = e
            elif e.is_Add or e.is_Mul:
                hit = engine.canonical(e.func, args)
            else:
                hit = e.func(*args, evaluate=False)
            cache[e] = hit
        return hit

    return renamed


def _cse_cost(replacements, reduced) -> int:
    """Operations (negation free) of a CSE's result, as `Program.op_count` counts them."""
    counter = OpCounter()
    for e in [e for _, e in replacements] + list(reduced):
        lower(e, counter)
    return sum(v for k, v in counter.counts.items() if k != "neg")


def _nodes(exprs):
    """Every distinct node of expressions that may be huge trees with shared
    subtrees, each visited once (sympy's own walks re-enter shared subtrees)."""
    seen = set()
    stack = [sp.sympify(e) for e in exprs]
    while stack:
        e = stack.pop()
        if id(e) not in seen:
            seen.add(id(e))
            yield e
            stack.extend(e.args)


def dag_size(outputs, definitions=()) -> int:
    """Non-atomic nodes of the outputs [(name, Matrix)] and of the definitions
    they use, each distinct node once: a cheap estimate of a program's size."""
    exprs = [e for _, m in outputs for e in m]
    used = _needed(dict(definitions), exprs)
    return sum(1 for e in _nodes(list(used.values()) + exprs) if not e.is_Atom)


def _symbols(exprs) -> set:
    """Free symbols of expressions (shared subtrees visited once)."""
    return {e for e in _nodes(exprs) if e.is_Symbol}


def _substitute(exprs: list, mapping: dict) -> list:
    """xreplace with memory: each distinct subtree is rebuilt once."""
    cache = dict(mapping)

    def sub(e):
        hit = cache.get(e)
        if hit is None:
            args = [sub(a) for a in e.args]
            hit = e.func(*args) if any(a is not b for a, b in zip(args, e.args)) else e
            cache[e] = hit
        return hit

    return [sub(sp.sympify(e)) for e in exprs]


# --------------------------------------------------------------------------- trigonometric lowering


def _angle(arg: sp.Expr, index: dict) -> tuple | None:
    """Integer coefficients of arg over the input symbols, or None if it is not such a sum."""
    coeffs = [0] * len(index)
    for term in sp.Add.make_args(arg):
        c, sym = term.as_coeff_Mul()
        if sym not in index or not c.is_Integer:
            return None
        coeffs[index[sym]] += int(c)
    return tuple(coeffs)


def _angle_name(a: tuple, syms: list, stem: str) -> str:
    """c23 for q2 + q3; c_2q2_mq3 for 2·q2 − q3."""
    parts = [(k, syms[i].name) for i, k in enumerate(a) if k]
    if all(k == 1 for k, _ in parts) and all(_JOINT.match(nm) for _, nm in parts):
        digits = [nm[1:] for _, nm in parts]
        return stem + ("_" if any(len(d) > 1 for d in digits) else "").join(digits)
    word = {1: "", -1: "m"}
    return stem + "_" + "_".join(f"{word.get(k, f'm{-k}' if k < 0 else k)}{nm}" for k, nm in parts)


def _lower_trig(defs: dict, outs: list, inputs: list) -> tuple[dict, list]:
    """Replace sin/cos of integer sums of inputs (cos(2q2 + q3), …) by named
    products of sin qᵢ, cos qᵢ via cos(a+b) = ca·cb − sa·sb, sin(a+b) = sa·cb
    + ca·sb, each angle built from two already built ones (3 ops per value
    instead of a ~20-flop libm call)."""
    index = {s: i for i, s in enumerate(inputs)}
    wanted = {}
    for node in _nodes(list(defs.values()) + outs):
        if node.func in (sp.sin, sp.cos):
            a = _angle(node.args[0], index)
            if a is not None and sum(map(abs, a)) > 1:
                wanted[node] = a
    if not wanted:
        return defs, outs
    taken = {s.name for s in defs} | {s.name for s in inputs}
    built: dict = {}  # canonical angle (first nonzero > 0) → (cos, sin) exprs
    new_defs: dict = {}

    def canonical(a):
        first = next(k for k in a if k)
        return (a, 1) if first > 0 else (tuple(-k for k in a), -1)

    def value(a):
        """(cos a, sin a) as expressions, building a when needed."""
        c, sign = canonical(a)
        if c not in built:
            build(c)
        cos_a, sin_a = built[c]
        return cos_a, sign * sin_a

    def unique(name):
        k, out = 1, name
        while out in taken:
            k += 1
            out = f"{name}_{k}"
        taken.add(out)
        return sp.Symbol(out, real=True)

    def build(a):
        if sum(map(abs, a)) == 1:
            i = next(i for i, k in enumerate(a) if k)
            built[a] = (sp.cos(inputs[i]), sp.sin(inputs[i]))
            return
        split = next(
            (
                b
                for b in sorted(built)
                if canonical(tuple(x - y for x, y in zip(a, b)))[0] in built and any(x != y for x, y in zip(a, b))
            ),
            None,
        )
        if split is None:
            i = next(i for i, k in enumerate(a) if k)
            split = tuple(int(j == i) * (1 if a[i] > 0 else -1) for j in range(len(a)))
        rest = tuple(x - y for x, y in zip(a, split))
        (cb, sb), (cr, sr) = value(split), value(rest)
        cos_a, sin_a = unique(_angle_name(a, inputs, "c")), unique(_angle_name(a, inputs, "s"))
        new_defs[cos_a] = cb * cr - sb * sr
        new_defs[sin_a] = sb * cr + cb * sr
        built[a] = (cos_a, sin_a)

    for a in sorted({canonical(a)[0] for a in wanted.values()}, key=lambda a: (sum(map(abs, a)), a)):
        value(a)
    mapping = {}
    for node, a in wanted.items():
        cos_a, sin_a = value(a)
        mapping[node] = cos_a if node.func is sp.cos else sin_a
    keys = list(defs)
    done = _substitute(list(defs.values()) + outs, mapping)
    out_defs = dict(new_defs)
    out_defs.update(zip(keys, done[: len(keys)]))
    return out_defs, done[len(keys) :]


def _needed(defs: dict, roots: list) -> dict:
    """The definitions the roots depend on, in their given order."""
    needed, stack = set(), [s for s in _symbols(roots) if s in defs]
    while stack:
        s = stack.pop()
        if s not in needed:
            needed.add(s)
            stack.extend(t for t in _symbols([defs[s]]) if t in defs)
    return {s: sp.sympify(e) for s, e in defs.items() if s in needed}


def _check_free(name, inputs, outputs, defs) -> None:
    known = {s for _, syms in inputs for s in syms} | set(defs)
    unknown = _symbols([e for _, m in outputs for e in m] + list(defs.values())) - known
    if unknown:
        names = ", ".join(sorted(map(str, unknown)))
        raise ValueError(
            f"function {name!r} uses symbols that are neither inputs nor "
            f"definitions: {names} (a symbolic model parameter? substitute numbers)"
        )


def _inline_trivial(defs: dict) -> tuple[dict, dict]:
    """Substitute definitions that are a number, a symbol or its negative."""
    trivial: dict = {}
    kept: dict = {}
    for s, e in defs.items():
        e = e.xreplace(trivial)
        if e.is_Atom or (e.is_Mul and len(e.args) == 2 and e.args[0] == -1 and e.args[1].is_Atom):
            trivial[s] = e
        else:
            kept[s] = e
    return kept, trivial


def _drop_aliases(nodes: dict, outs: list, named: set) -> tuple[dict, list]:
    """Remove copies d = t of a CSE temp t: the named definition d takes t's place."""
    alias = {}
    for s, e in nodes.items():
        if s in named and e.is_Symbol and e in nodes and e not in named and e not in alias:
            alias[e] = s
    kept = {}
    for s, e in nodes.items():
        if s in alias:
            continue
        if alias.get(e) is s:
            e = nodes[e]
        kept[s] = e.xreplace(alias)
    return kept, [e.xreplace(alias) for e in outs]


def evaluation_order(nodes: dict, roots: list) -> list:
    """Depth-first post-order from the roots (the outputs), in their order: every symbol after
    its operands, each computed just before its first use (deterministic: operands in print
    order)."""
    order, done = [], set()

    def operands(expr):
        return iter([s for s in _symbols_in_order(expr) if s in nodes])

    for root in roots:
        stack = [(None, operands(root))]
        while stack:
            node, pending = stack[-1]
            for s in pending:
                if s not in done:
                    stack.append((s, operands(nodes[s])))
                    break
            else:
                stack.pop()
                if node is not None and node not in done:
                    done.add(node)
                    order.append(node)
    return order


def _symbols_in_order(expr: sp.Expr) -> list:
    """Free symbols of expr in pre-order of its (canonically ordered) tree."""
    seen, out = set(), []
    for node in sp.preorder_traversal(expr):
        if node.is_Symbol and node not in seen:
            seen.add(node)
            out.append(node)
    return out


def _names(order: list, nodes: dict, named: set, taken: set) -> dict:
    """Readable names for the CSE temporaries, in evaluation order."""
    rename, counter = {}, 0
    for s in order:
        if s in named:
            continue
        wanted = _descriptive(nodes[s].xreplace(rename))
        if wanted is None or wanted in taken:
            counter += 1
            while f"x{counter}" in taken:
                counter += 1
            wanted = f"x{counter}"
        taken.add(wanted)
        rename[s] = sp.Symbol(wanted, real=True)
    return rename


_JOINT = re.compile(r"^q(\d+)$")


def _descriptive(expr: sp.Expr) -> str | None:
    """s1 = sin(q1), c23 = cos(q2 + q3), sgn_qd1 = sign(qd1), qd1_sq = qd1**2;
    None when nothing fits."""
    if isinstance(expr, (sp.sin, sp.cos)):
        joints = []
        for term in sp.Add.make_args(expr.args[0]):
            m = term.is_Symbol and _JOINT.match(term.name)
            if not m:
                return None
            joints.append(m.group(1))
        sep = "_" if any(len(j) > 1 for j in joints) else ""
        return ("s" if expr.func is sp.sin else "c") + sep.join(joints)
    if expr.func is sp.sign and expr.args[0].is_Symbol:
        return f"sgn_{expr.args[0].name}"
    if expr.is_Pow and expr.exp == 2 and expr.base.is_Symbol:
        return f"{expr.base.name}_sq"
    return None
