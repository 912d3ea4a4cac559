"""SymEngine for the two hot spots of building programs: joint CSE and partial derivatives.

Stage "program".  sympy's `cse` and `diff` spend ~0.2 ms per operation of the
result in Python (a 10-joint arm's programs: 7.5 s, over half of it CSE); SymEngine
does the same algebra in C++ (CSE 10-20x faster, its result within ±1 % of sympy's
operations, lower as often as higher: docs/speed.md "Cold builds").  Expressions go in
and come out as sympy, with their own symbols and exact numbers; only these two steps
run in SymEngine, inside `use("symengine")` (code generation for every model but the
shipped ones, whose code in generated/ is pinned byte for byte and the operation counts
the docs quote: `codegen.choice`).  Elsewhere, and for anything SymEngine cannot
represent (a function it lacks, a derivative it leaves unevaluated), sympy does it.
"""

from __future__ import annotations

import contextlib
import contextvars
from typing import Iterator, Sequence

import symengine as se
import sympy as sp
from sympy.core.basic import _args_sortkey

__all__ = ["use", "current", "cse", "partials", "canonical"]

ENGINES = ("symengine", "sympy")
_ENGINE: contextvars.ContextVar[str] = contextvars.ContextVar("symdyn_engine", default="sympy")

_FUNCTIONS = {sp.sin: se.sin, sp.cos: se.cos, sp.tan: se.tan, sp.sign: se.sign, sp.Abs: se.Abs}
_BACK = {type(f(se.Symbol("x"))): g for g, f in _FUNCTIONS.items()}  # se.sin is a function, not its class
_CONSTANTS = {sp.pi: se.pi, sp.E: se.E}


class Unsupported(Exception):
    """An expression SymEngine does not take (or gives back) in the form programs need."""


@contextlib.contextmanager
def use(engine: str) -> Iterator[None]:
    """Build programs with `engine` ("symengine" or "sympy") inside the block.

    Raises:
        ValueError: an engine not in ENGINES.
    """
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}: expected one of {', '.join(ENGINES)}")
    token = _ENGINE.set(engine)
    try:
        yield
    finally:
        _ENGINE.reset(token)


def current() -> str:
    """The engine programs are built with here ("sympy" unless inside `use("symengine")`)."""
    return _ENGINE.get()


class _Bridge:
    """sympy ↔ SymEngine for one job: each sympy symbol gets a SymEngine symbol of its own
    (prefixed, so SymEngine's CSE temporaries x0, x1, … never meet a user's x0), and
    comes back as itself; `frozen` nodes (sign(·), held constant under differentiation)
    travel as symbols."""

    def __init__(self, frozen: tuple = ()) -> None:
        self.frozen = frozen
        self._to: dict = {}
        self._back: dict = {}
        self._names: set = set()

    def _symbol(self, node) -> se.Symbol:
        name, k = "_" + getattr(node, "name", "f"), 1
        while name in self._names:
            name, k = f"_{getattr(node, 'name', 'f')}_{k}", k + 1
        self._names.add(name)
        out = se.Symbol(name)
        self._back[out] = node
        return out

    def to(self, expr: sp.Basic):
        """expr in SymEngine (raises Unsupported for what it cannot hold exactly)."""
        hit = self._to.get(expr)
        if hit is not None:
            return hit
        if expr.is_Symbol or (self.frozen and expr.func in self.frozen):
            out = self._symbol(expr)
        elif expr.is_Integer:
            out = se.Integer(int(expr))
        elif expr.is_Rational:
            out = se.Rational(int(expr.p), int(expr.q))
        elif expr.is_Float:
            out = se.RealDouble(float(expr))
        elif expr.is_Add:
            out = se.Add(*(self.to(a) for a in expr.args))
        elif expr.is_Mul:
            out = se.Mul(*(self.to(a) for a in expr.args))
        elif expr.is_Pow:
            out = se.Pow(self.to(expr.base), self.to(expr.exp))
        elif expr.func in _FUNCTIONS and len(expr.args) == 1:
            out = _FUNCTIONS[expr.func](self.to(expr.args[0]))
        elif expr in _CONSTANTS:
            out = _CONSTANTS[expr]
        else:
            raise Unsupported(expr.func.__name__)
        self._to[expr] = out
        return out

    def back(self, expr, temps: dict | None = None):
        """A SymEngine result in sympy: its symbols the original ones (or `temps`' for
        CSE temporaries), numbers exact as they went in."""
        memo: dict = {}

        def walk(e):
            hit = memo.get(e)
            if hit is not None:
                return hit
            if isinstance(e, se.Symbol):
                out = self._back.get(e)
                if out is None:
                    out = temps.get(e) if temps is not None else None
                    if out is None:
                        raise Unsupported(f"symbol {e}")
            elif isinstance(e, se.Integer):  # One, Zero, NegativeOne are Integers
                out = sp.Integer(int(e))
            elif isinstance(e, se.Rational):
                p, q = e.get_num_den()
                out = sp.Rational(int(p), int(q))
            elif isinstance(e, se.RealDouble):
                out = sp.Float(float(e))
            elif isinstance(e, se.Add):
                out = canonical(sp.Add, [walk(a) for a in e.args])
            elif isinstance(e, se.Mul):
                out = canonical(sp.Mul, [walk(a) for a in e.args])
            elif isinstance(e, se.Pow):
                out = sp.Pow(walk(e.args[0]), walk(e.args[1]))
            elif type(e) in _BACK:
                out = _BACK[type(e)](walk(e.args[0]))
            elif e == se.pi:
                out = sp.pi
            elif e == se.E:
                out = sp.E
            else:
                raise Unsupported(type(e).__name__)
            memo[e] = out
            return out

        return walk(expr)


#: Inputs of at most this many distinct nodes are also CSE'd by sympy, and the result with
#: fewer operations kept: sympy's CSE takes ~0.02 s there, and it finds the common factors of
#: small expanded forms better (the 3-joint RRP's Lagrange τ: 111 operations, SymEngine's 118),
#: where a large recursion's program is as lean by SymEngine (±1 %) at a tenth of the time.
BOTH_BELOW = 500


def canonical(kind, args: list):
    """sympy's Add or Mul of terms or factors already collected (one number at most, no two
    alike: SymEngine's, or a canonical expression's renamed one to one): sorted as sympy sorts
    them, the number first, without re-evaluating them; sympy evaluates what it would rewrite
    (a nested sum or product, 2·(a + b) → 2a + 2b)."""
    numbers = [a for a in args if a.is_Number]
    rest = [a for a in args if not a.is_Number]
    if (
        len(numbers) > 1
        or any(a.func is kind for a in rest)
        or (kind is sp.Mul and numbers and len(rest) == 1 and rest[0].is_Add)
        or len(rest) < (2 - len(numbers))
    ):
        return kind(*args)
    rest.sort(key=_args_sortkey)
    return kind._from_args(numbers + rest, is_commutative=True)


def cse(exprs: Sequence, temps: Iterator[sp.Symbol], cost=None) -> tuple[list, list]:
    """(replacements, reduced) of one joint CSE over `exprs`, as `sympy.cse(exprs,
    symbols=temps, order="none")` gives them: SymEngine's CSE inside `use("symengine")`
    (and sympy's too when the input is small, the one of lower `cost(replacements,
    reduced)` kept: sympy's on ties), sympy's elsewhere and for what SymEngine does not take."""
    exprs = [sp.sympify(e) for e in exprs]
    if current() == "symengine":
        try:
            bridge = _Bridge()
            replaced, reduced = se.cse([bridge.to(e) for e in exprs])
            names = {t: next(temps) for t, _ in replaced}
            fast = (
                [(names[t], bridge.back(e, names)) for t, e in replaced],
                [bridge.back(e, names) for e in reduced],
            )
        except Unsupported:
            pass
        else:
            if cost is None or len(bridge._to) > BOTH_BELOW:
                return fast
            slow = sp.cse(exprs, symbols=temps, order="none")
            return fast if cost(*fast) < cost(*slow) else slow
    return sp.cse(exprs, symbols=temps, order="none")


def partials(expr: sp.Expr, wrt: Sequence[sp.Symbol]) -> list:
    """[∂expr/∂u for u in wrt] with every sign(·) held constant (Coulomb friction: 0, not
    a Dirac delta); SymEngine differentiates inside `use("symengine")`."""
    expr = sp.sympify(expr)
    if current() == "symengine":
        try:
            bridge = _Bridge(frozen=(sp.sign,))
            e = bridge.to(expr)
            return [bridge.back(e.diff(bridge.to(u))) for u in wrt]
        except Unsupported:
            pass
    signs = {node: sp.Dummy() for node in expr.atoms(sp.sign)}
    if not signs:
        return [expr.diff(u) for u in wrt]
    back = {d: node for node, d in signs.items()}
    held = expr.xreplace(signs)
    return [held.diff(u).xreplace(back) for u in wrt]
