"""The order a C function computes its values and stores its outputs in, shared by the scalar
functions (`c`) and the SIMD kernels (`csimd`).

A program whose outputs include a matrix is computed output entry by output entry, the matrices
taken column by column (a Jacobian joint after joint, A_G's six rows of a joint together), each
entry stored as soon as its operands are computed: a column's values then die with it instead of
living to the function's end, where gcc, which does not reorder a long straight-line block to
spare registers, spills them.  Talos' centroidal SIMD kernel held 269 values live at most, not
493 (166 → 131 ns a state, docs/task_space.md); its scalar `centroidal_map` runs in 378 ns a
call, not 565 (`scripts/scalar_calls.py`).  A program of vectors only keeps its own order and
stores at its end (in the column order Talos' τ kernel ran 147 → 176 ns).  A caller's outputs
must not overlap its inputs: entries are stored before every input is read.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

from ...derivation.program import Program, evaluation_order
from . import sincos_pairs

__all__ = ["Step", "Schedule", "schedule", "by_columns", "defined", "peak_live"]


@dataclass(frozen=True)
class Step:
    """One `sincos_pairs` item (None, symbol, expression) or (x, sin symbol, cos symbol), and the
    output entries (output name, flat index, expression) stored right after it."""

    item: tuple
    stores: tuple = ()


@dataclass(frozen=True)
class Schedule:
    """head: the entries stored before any assignment (constants); steps; tail: the entries
    stored after the last step (a program of vectors: all of them)."""

    head: tuple
    steps: tuple
    tail: tuple


def by_columns(p: Program) -> bool:
    """Whether a program is computed output entry by entry (`schedule`): a matrix among its outputs."""
    return any(m.cols > 1 for _, m in p.outputs)


def defined(item) -> list:
    """The symbols a `sincos_pairs` item defines."""
    x, a, b = item
    return [a] if x is None else [a, b]


def schedule(p: Program) -> Schedule:
    """The program's steps and stores (module docstring), the matrices' entries in the order of
    `_ORDERS` that holds the fewest values live at once; deterministic.  Made once per program
    (its scalar function and its SIMD kernel both ask)."""
    found = _PLANS.get(id(p))
    if found is not None and found[0]() is p:
        return found[1]
    if not by_columns(p):
        steps = tuple(Step(item) for item in sincos_pairs(p.assignments))
        plan = Schedule((), steps, tuple((o, k, e) for o, m in p.outputs for k, e in enumerate(m)))
    else:
        entries = [(k % m.cols, i, k // m.cols, o, k, e) for i, (o, m) in enumerate(p.outputs) for k, e in enumerate(m)]
        plans = [_entry_schedule(p, sorted(entries, key=key)) for key in _ORDERS]
        plan = min(plans, key=peak_live)  # the first of equals: by columns
    _PLANS[id(p)] = (weakref.ref(p, lambda _, key=id(p): _PLANS.pop(key, None)), plan)
    return plan


#: Each program's schedule while the program lives: id → (a weak reference to it, its schedule).
_PLANS: dict[int, tuple] = {}


#: The orders of the output entries tried, each key of (column, output, row, name, flat index, expression):
#: column by column across the outputs (a Jacobian's joint after joint, A_G's six rows of a joint
#: with the centre of mass's three), and output after output in storage order (a frame's pose, then
#: the next frame's).  Fewest live values picked: Talos' `centroidal_map` 272 by columns, 491 by
#: outputs (381 against 545 ns a call); Solo 12's `frame_kinematics` 191 and 116 (160 against 131).
_ORDERS = (lambda t: t[:3], lambda t: (t[1], t[4]))


def _entry_schedule(p: Program, entries: list) -> Schedule:
    """The steps that compute `entries` in their order, each stored right after the step that
    completes its operands."""
    nodes = dict(p.assignments)
    order = evaluation_order(nodes, [e for *_, e in entries])
    items = list(sincos_pairs([(s, nodes[s]) for s in order]))  # a sin/cos pair where the first stood
    step_of = {sym: i for i, item in enumerate(items) for sym in defined(item)}
    head: list = []
    attached: list[list] = [[] for _ in items]
    for *_, o, k, e in entries:
        after = [step_of[s] for s in e.free_symbols if s in step_of]
        (attached[max(after)] if after else head).append((o, k, e))
    return Schedule(tuple(head), tuple(Step(item, tuple(a)) for item, a in zip(items, attached)), ())


def peak_live(plan: Schedule) -> int:
    """The most values a schedule holds at once: each assigned value from its step to the last
    step or store that reads it."""
    last: dict = {}
    for i, step in enumerate(plan.steps):
        x, a, b = step.item
        for sym in (b if x is None else x).free_symbols:
            last[sym] = i
        for *_, e in step.stores:
            for sym in e.free_symbols:
                last[sym] = i
    change = [0] * (len(plan.steps) + 1)  # +1 where a value starts being held, −1 where it is let go
    for i, step in enumerate(plan.steps):
        for sym in defined(step.item):
            if last.get(sym, -1) > i:
                change[i] += 1
                change[last[sym] + 1] -= 1  # held through the step that last reads it
    most = held = 0
    for delta in change:
        held += delta
        most = max(most, held)
    return most
