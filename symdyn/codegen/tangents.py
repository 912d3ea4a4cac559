"""Forward-mode derivatives in vectors: every direction's tangent of a straight-line program at once.

Beside `derivatives`, whose `forward` makes each nonzero ∂s/∂x_k a scalar definition of its own (one
multiply-add per direction, operand and definition).  Here the directions are lanes of vectors of
LANES doubles, grouped so that a quantity's directions share vectors (a free base's velocities, then
each branch of the tree: a leg's joints move neither another leg nor its contact), and a definition
s = f(u, …) has its tangent T_s = Σ_u ∂f/∂u · T_u on the vectors where an operand's tangent is
nonzero.  The local partials ∂f/∂u are scalars the program computes (`Plan.values`); the
accumulation is C over vector types (`Plan.c_source`), one vector multiply-add where the scalar
forward mode has up to LANES: the contact derivatives' residual Jacobians (`contact_functions`)
on the C target.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from ..derivation.engine import partials

__all__ = ["LANES", "Plan", "plan"]

#: Doubles per vector (an AVX-512 register; GCC and Clang split it where vectors are narrower).
LANES = 8


@dataclass(frozen=True)
class Plan:
    """The vector forward mode of one program: `values`, the partials' expressions (the program's
    scalar outputs the C reads as p[k]); `lanes`, each direction's lane (in vectors of LANES);
    `seeds`, (slot, lane) of the directions' unit vectors; `steps`, in order, ("set", slot,
    [(coefficient, operand slot)]) — a coefficient ("p", k) or a number — and ("store", output
    row, slot, block); `slots`, the vectors held at once (a slot is reused once its value is
    dead, so that the tangents stay in the first level of the cache); `support`, per output the
    directions it depends on (its other lanes are exact zeros)."""

    values: tuple
    lanes: dict
    slots: int
    seeds: tuple
    steps: tuple
    support: tuple  # per output, the directions its tangent depends on

    def pattern(self, columns: dict) -> set:
        """{(output row, column)} of the structurally nonzero entries (`columns`: direction → column)."""
        return {(i, columns[x]) for i, directions in enumerate(self.support) for x in directions}

    def c_source(self, name: str, columns: dict, stride: int) -> str:
        """`static void name(const double *p, double *R)`: the tangents from the partials p, output
        row i's written to R[i·stride + columns[x]] for every direction x (R's other entries
        untouched).  GCC's and Clang's vector types; elsewhere the same statements in a loop over
        the lanes.  Its preprocessing lines are indented: `cunits` splits a file into units at
        column 0."""
        lines = [
            f"static void {name}(const double *p, double *R)",
            "{",
            "    #if defined(__GNUC__)",
            f"    typedef double v_ __attribute__((vector_size({8 * LANES})));",
            f"    v_ T[{max(1, self.slots)}];",
            f"    const v_ zero_ = {{{', '.join(['0.0'] * LANES)}}};",
            "    #define SYMDYN_L_",
            "    #define SYMDYN_SEED_(s, l) (T[s] = zero_, T[s][l] = 1.0)",
            "    #define SYMDYN_STORE_(s, l, k) (R[k] = T[s][l])",
            "    #else",
            f"    double T[{max(1, self.slots)}][{LANES}];",
            "    int l_;",
            f"    for (l_ = 0; l_ < {LANES}; ++l_) {{",
            "    #define SYMDYN_L_ [l_]",
            "    #define SYMDYN_SEED_(s, l) (T[s][l_] = l_ == (l) ? 1.0 : 0.0)",
            "    #define SYMDYN_STORE_(s, l, k) (l_ == (l) ? (void)(R[k] = T[s][l_]) : (void)0)",
            "    #endif",
        ]
        lines += [f"    SYMDYN_SEED_({slot}, {lane % LANES});" for slot, lane in self.seeds]
        by_block: dict = {}
        for x, lane in self.lanes.items():
            by_block.setdefault(lane // LANES, []).append((lane % LANES, columns[x]))
        for step in self.steps:
            if step[0] == "set":
                _, slot, terms = step
                lines.append(f"    T[{slot}] SYMDYN_L_ = " + " + ".join(_term(c, u) for c, u in terms) + ";")
            else:
                _, i, slot, b = step
                lines += [f"    SYMDYN_STORE_({slot}, {lane}, {i * stride + col});" for lane, col in by_block[b]]
        lines += [
            "    #if !defined(__GNUC__)",
            "    }",
            "    #endif",
            "    #undef SYMDYN_L_",
            "    #undef SYMDYN_SEED_",
            "    #undef SYMDYN_STORE_",
            "}",
        ]
        return "\n".join(lines) + "\n"


def _term(coefficient, slot: int) -> str:
    operand = f"T[{slot}] SYMDYN_L_"
    if isinstance(coefficient, tuple):
        return f"p[{coefficient[1]}] * {operand}"
    if coefficient == 1:
        return operand
    if coefficient == -1:
        return f"-{operand}"
    return f"{float(coefficient)!r} * {operand}"


def plan(definitions: Sequence, outputs: Sequence, groups: Sequence[Sequence]) -> Plan:
    """The vector forward mode of the program (definitions [(Symbol, expr)] in evaluation order,
    outputs [expr]) by the directions `groups` lists, each group starting a new vector."""
    lanes, width = {}, 0
    for group in groups:
        for x in group:
            lanes[x] = width
            width += 1
        width = -(-width // LANES) * LANES
    slots: dict = {}  # (symbol, block) → logical slot
    seeds = []
    for x, lane in lanes.items():
        slots[x, lane // LANES] = len(slots)
        seeds.append((slots[x, lane // LANES], lane))
    blocks = {x: {lane // LANES} for x, lane in lanes.items()}
    support = {x: frozenset([x]) for x in lanes}
    values: dict = {}
    steps: list = []

    def tangent(expr) -> list:
        """[(block, [(coefficient, slot)])] of an expression's tangent."""
        active = sorted((u for u in expr.free_symbols if u in blocks), key=str)
        terms: dict = {}
        reached.clear()
        for u, pe in zip(active, partials(expr, active)):
            if pe == 0:
                continue
            reached.update(support[u])
            coefficient = pe if pe.is_Number else ("p", values.setdefault(pe, len(values)))
            for b in blocks[u]:
                terms.setdefault(b, []).append((coefficient, slots[u, b]))
        return sorted(terms.items())

    reached: set = set()  # the directions of the last `tangent`
    for s, e in _depth_first(dict(definitions), outputs):
        parts = tangent(sp.sympify(e))
        if parts:
            blocks[s] = {b for b, _ in parts}
            support[s] = frozenset(reached)
            for b, terms in parts:
                slots[s, b] = len(slots)
                steps.append(("set", slots[s, b], tuple(terms)))
    rows = []
    for i, o in enumerate(outputs):
        for b, terms in tangent(sp.sympify(o)):
            slot = len(slots)
            slots[("out", i), b] = slot
            steps += [("set", slot, tuple(terms)), ("store", i, slot, b)]
        rows.append(frozenset(reached))
    block = {slot: b for (_, b), slot in slots.items()}  # a vector's tangents read only that vector's
    steps.sort(key=lambda step: block[step[1]] if step[0] == "set" else step[3])  # one vector after another
    return _reused(Plan(tuple(values), lanes, len(slots), tuple(seeds), tuple(steps), tuple(rows)))


def _depth_first(definitions: dict, outputs: Sequence) -> list:
    """The definitions the outputs use, each after its operands, output after output (depth first):
    a value's tangent is made close to where it is read, so that fewer vectors are live at once
    than in the program's own order; `plan` then makes them one vector of directions after another
    (the steps of one vector read only that vector's).  Talos' contact residuals: 1 861 vectors in
    the program's order, 1 182 depth first, 387 (25 kB, within the first level of the cache) one
    vector after another, with `emit.ckkt`'s top rows through M⁻¹'s factors: its derivatives
    12.3 → 11.3 µs a call (the benchmark's harness, mean over 16 stack placements)."""
    order, done = [], set()
    for o in outputs:
        stack = [(s, False) for s in sorted(sp.sympify(o).free_symbols, key=str) if s in definitions]
        while stack:
            s, expanded = stack.pop()
            if s in done:
                continue
            if expanded:
                done.add(s)
                order.append((s, definitions[s]))
                continue
            stack.append((s, True))
            stack += [
                (u, False)
                for u in sorted(sp.sympify(definitions[s]).free_symbols, key=str)
                if u in definitions and u not in done
            ]
    return order


def _reused(p: Plan) -> Plan:
    """The plan with each slot's vector reused once its last reader has run."""
    last: dict = {}
    for k, step in enumerate(p.steps):
        for _, u in step[2] if step[0] == "set" else [(None, step[2])]:
            last[u] = k
    free: list = []
    where: dict = {}
    count = 0

    def place(logical: int) -> int:
        nonlocal count
        if free:
            where[logical] = free.pop()
        else:
            where[logical], count = count, count + 1
        return where[logical]

    seeds = tuple((place(slot), lane) for slot, lane in p.seeds)
    steps = []
    for k, step in enumerate(p.steps):
        if step[0] == "set":
            _, slot, terms = step
            terms = tuple((c, where[u]) for c, u in terms)
            for _, u in step[2]:
                if last.get(u) == k:
                    free.append(where[u])
            steps.append(("set", place(slot), terms))
            if slot not in last:  # never read (each reader's partial by it is zero): free at once
                free.append(where[slot])
        else:
            _, i, slot, b = step
            steps.append(("store", i, where[slot], b))
            if last.get(slot) == k:
                free.append(where[slot])
    return Plan(p.values, p.lanes, count, seeds, tuple(steps), p.support)
