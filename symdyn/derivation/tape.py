"""Named intermediates: the `Tape` on which both DAG derivations write their programs.

Every non-trivial intermediate gets a name (w2_z, dv3_x, dM12_q3, …) as it
is formed, so a derivation's result is a DAG of small definitions, never one
big tree; code generation reads the same names.
"""

from __future__ import annotations

from typing import Sequence

import sympy as sp

__all__ = ["Tape", "AXES"]

AXES = "xyz"


class Tape:
    """Named intermediates: an ordered DAG of definitions (Symbol → expression).

    `name(expr, label)` returns expr itself when it is trivial (a number, a
    symbol or its negative), an existing name when the same expression was
    named before, and a new Symbol otherwise.
    """

    def __init__(self) -> None:
        self.defs: dict[sp.Symbol, sp.Expr] = {}
        self._index: dict[sp.Expr, sp.Symbol] = {}
        self._full: dict[sp.Symbol, sp.Expr] = {}
        self._taken: set[str] = set()

    def name(self, expr: sp.Expr, label: str) -> sp.Expr:
        expr = sp.sympify(expr)
        if expr.is_Atom or (expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1 and expr.args[1].is_Atom):
            return expr
        if isinstance(expr, (sp.cos, sp.sin)) and expr.args[0].is_Symbol:
            return expr
        if expr in self._index:
            return self._index[expr]
        if -expr in self._index:
            return -self._index[-expr]
        sym = sp.Symbol(self._unique(label), real=True)
        self.defs[sym] = expr
        self._index[expr] = sym
        return sym

    def _unique(self, label: str) -> str:
        name, k = label, 2
        while name in self._taken:
            name, k = f"{label}_{k}", k + 1
        self._taken.add(name)
        return name

    def vector(self, exprs: Sequence, label: str) -> list:
        return [self.name(e, f"{label}_{AXES[k]}") for k, e in enumerate(exprs)]

    def full(self, expr: sp.Expr) -> sp.Expr:
        """The expression with every name replaced by its definition (shared subtrees)."""
        for sym, definition in self.defs.items():
            if sym not in self._full:
                self._full[sym] = definition.xreplace(self._full)
        return sp.sympify(expr).xreplace(self._full)

    def used_by(self, outputs: Sequence[sp.Expr]) -> list[tuple[sp.Symbol, sp.Expr]]:
        """The definitions the outputs depend on, in order (dead ones dropped)."""
        needed: set = set()
        stack = [s for e in outputs for s in sp.sympify(e).free_symbols if s in self.defs]
        while stack:
            s = stack.pop()
            if s in needed:
                continue
            needed.add(s)
            stack.extend(t for t in self.defs[s].free_symbols if t in self.defs and t not in needed)
        return [(s, e) for s, e in self.defs.items() if s in needed]
